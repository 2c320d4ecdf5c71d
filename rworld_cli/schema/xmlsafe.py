"""The one XML parser set-up for files from other people (URDF, xacro, SRDF).

No entity is expanded and no DTD is loaded (an entity naming ``file:///...`` would copy a file
into the document; nested ones multiply it), nothing is fetched from the network, and the
libxml2 limits on depth and size stay on (``huge_tree=False``).
"""

from __future__ import annotations

from typing import Any


def xml_parser(remove_comments: bool = True) -> Any:
    """An ``lxml.etree.XMLParser`` for a file rworld did not write."""
    from lxml import etree

    return etree.XMLParser(
        resolve_entities=False,
        no_network=True,
        load_dtd=False,
        huge_tree=False,
        remove_pis=True,
        remove_comments=remove_comments,
    )

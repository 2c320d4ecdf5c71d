"""SRDF files (MoveIt's semantic robot description): the link pairs it disables for collision
checking, read with their lines for located errors.

Only ``<disable_collisions link1=... link2=... reason=...>`` is read: MoveIt's setup assistant
writes one for every pair of links that are adjacent, always in contact, or never in contact
over its sampled joint states; ``rworld import urdf --srdf`` turns them into the cell's
``allowed_contacts``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..errors import Issue, UserError
from .xmlsafe import xml_parser


@dataclass(frozen=True)
class DisabledPair:
    link1: str
    link2: str
    reason: str
    line: int


def read_srdf(path: str | Path) -> list[DisabledPair]:
    """The disabled collision pairs of an SRDF file.

    Raises
    ------
    UserError
        No such file, malformed XML, a root that is not <robot>, a pair without its links.
    """
    from lxml import etree

    shown = str(path)
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise UserError(f"{shown}: cannot read the SRDF ({exc.strerror})") from None
    try:
        root = etree.fromstring(data, xml_parser())
    except etree.XMLSyntaxError as exc:
        line, column = exc.position if exc.position else (0, 0)
        raise UserError(
            f"invalid: {shown}",
            [Issue(shown, line, max(column, 1), "(xml)", f"malformed XML: {exc.msg}")],
        ) from None
    if root.tag != "robot":
        raise UserError(
            f"invalid: {shown}",
            [
                Issue(
                    shown,
                    root.sourceline or 1,
                    1,
                    "(root)",
                    f"the root is <{root.tag}>; an SRDF has <robot>",
                )
            ],
        )
    out, issues = [], []
    for el in root.iter("disable_collisions"):
        link1, link2 = el.get("link1"), el.get("link2")
        if not link1 or not link2:
            issues.append(
                Issue(
                    shown, el.sourceline or 0, 1, "disable_collisions", "needs 'link1' and 'link2'"
                )
            )
            continue
        out.append(DisabledPair(link1, link2, el.get("reason") or "disabled", el.sourceline or 0))
    if issues:
        raise UserError(f"invalid: {shown}", issues)
    return out

"""xacro documents as rworld reads and writes them: a file parsed into elements that keep their
file, line and column (no entity, no DTD, no network: :mod:`.xmlsafe`), ROS packages found under
the package paths, and the expanded document written with each element's source.  The expansion
itself is :mod:`.xacro`'s.
"""

from __future__ import annotations

import os
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from xml.sax.saxutils import escape, quoteattr

from .xacro_eval import _Refused
from .xmlsafe import xml_parser

_XACRO_URIS = frozenset(
    {"http://www.ros.org/wiki/xacro", "http://ros.org/wiki/xacro", "http://wiki.ros.org/xacro"}
)


@dataclass
class _El:
    """An element: ``tag`` as written (``xacro:property``, ``link``), attributes in order."""

    tag: str
    attrs: list[tuple[str, Any]]
    children: list[Any]
    file: str = ""
    line: int = 0
    column: int = 0

    def get(self, name: str) -> Any:
        for key, value in self.attrs:
            if key == name:
                return value
        return None


@dataclass
class _Text:
    data: str


@dataclass
class _SetAttribute:
    """``xacro:attribute``: an attribute for the enclosing element."""

    name: str
    value: Any


def _qualified(name: str, prefixes: dict[str, str]) -> str:
    if name.startswith("{"):
        uri, local = name[1:].split("}", 1)
        prefix = prefixes.get(uri)
        return f"{prefix}:{local}" if prefix else local
    return name


def _parse(path: Path, shown: str, file_bytes: int) -> tuple[_El, dict[str, str]]:
    """The file as a tree of :class:`_El`, and its root's name spaces other than xacro's."""
    from lxml import etree

    size = path.stat().st_size
    if size > file_bytes:
        raise _Refused(f"{shown} has {size} bytes; rworld reads xacro files up to {file_bytes}")
    data = path.read_bytes()
    parser = xml_parser()
    try:
        root = etree.fromstring(data, parser)
    except etree.XMLSyntaxError as exc:
        line = exc.position[0] if exc.position else 0
        message = re.sub(r" \(.*, line \d+\)$|, line \d+, column \d+$", "", str(exc.msg))
        raise _Refused(f"{shown}:{line}: malformed XML: {message}") from None
    lines = data.decode(root.getroottree().docinfo.encoding or "utf-8", "replace").splitlines()

    namespaces: dict[str, str] = {}

    def convert(el) -> _El:
        prefixes = {uri: prefix for prefix, uri in el.nsmap.items() if prefix}
        namespaces.update(
            (p, u) for p, u in el.nsmap.items() if p and p != "xacro" and u not in _XACRO_URIS
        )
        tag = _qualified(el.tag, prefixes)  # a default name space's elements by local name
        # libxml2 gives the line where a start tag ends: its start is the last '<tag' at or
        # above it (a tag spread over lines, as the vendors write inertias)
        line, column = el.sourceline or 0, 0
        for back in range(line, max(line - 200, 0), -1):
            found = lines[back - 1].rfind("<" + tag) if back <= len(lines) else -1
            if found >= 0:
                line, column = back, found + 1
                break
        node = _El(
            tag,
            [(_qualified(k, prefixes), v) for k, v in el.attrib.items()],
            [],
            shown,
            line,
            column or 1,
        )
        if el.text:
            node.children.append(_Text(el.text))
        for child in el:
            if isinstance(child, etree._Entity):
                raise _Refused(
                    f"{shown}:{child.sourceline}: the entity {child.text} is not "
                    "expanded (rworld reads no DTD)"
                )
            if isinstance(child.tag, str):
                node.children.append(convert(child))
            if child.tail:
                node.children.append(_Text(child.tail))
        return node

    return convert(root), namespaces


def _shown(path: Path) -> str:
    """An included file's name for messages: relative to the working folder when it is below
    it (as the user names files; links in the way kept as the user sees them), else absolute."""
    absolute = os.path.abspath(path)
    relative = os.path.relpath(absolute)
    return absolute if relative.startswith("..") else relative


def _package_root(path: Path) -> Path:
    """The ROS package a file is in (the nearest folder above it with a package.xml), else
    its own folder."""
    for folder in path.parents:
        if (folder / "package.xml").is_file():
            return folder
    return path.parent


def _serialise(root: _El, namespaces: dict[str, str]) -> tuple[str, dict[int, tuple]]:
    """The document's text, and for each line that starts an element the (file, line, column)
    of the xacro element it was expanded from."""
    out = ['<?xml version="1.0" encoding="utf-8"?>\n']
    origins: dict[int, tuple[str, int, int]] = {}
    line = [2]  # the line the next piece starts on

    def put(text: str) -> None:
        out.append(text)
        line[0] += text.count("\n")

    def write(el: _El, indent: str, declarations: str = "") -> None:
        origins[line[0]] = (el.file, el.line, el.column)
        attrs = "".join(f" {k}={quoteattr(str(v))}" for k, v in el.attrs)
        children = [c for c in el.children if isinstance(c, _El) or c.data.strip()]
        if not children:
            put(f"{indent}<{el.tag}{declarations}{attrs}/>\n")
            return
        put(f"{indent}<{el.tag}{declarations}{attrs}>")
        if all(isinstance(c, _Text) for c in children):
            put(escape("".join(c.data for c in children).strip()))
            put(f"</{el.tag}>\n")
            return
        put("\n")
        for child in children:
            if isinstance(child, _El):
                write(child, indent + "  ")
            else:
                put(f"{indent}  {escape(child.data.strip())}\n")
        put(f"{indent}</{el.tag}>\n")

    declared = "".join(f" xmlns:{p}={quoteattr(u)}" for p, u in namespaces.items())
    write(root, "", declared)
    return "".join(out), origins


def find_package(name: str, package_paths: Sequence[Path]) -> Path | None:
    """A ROS package's folder under the package paths: the path itself when it is the package
    (its ``package.xml`` names it, or the folder has its name), a folder of that name in it, or
    one level deeper (a repository of several packages)."""
    for root in package_paths:
        candidates = [root, root / name, *sorted(root.glob(f"*/{name}"))]
        for folder in candidates:
            if folder != root and folder.name != name:
                continue
            manifest = folder / "package.xml"
            if folder.is_dir() and (folder.name == name or _package_name(manifest) == name):
                return folder
    return None


def _package_name(manifest: Path) -> str | None:
    try:
        if manifest.stat().st_size > 1_000_000:
            return None
        found = re.search(r"<name>\s*([^<\s]+)\s*</name>", manifest.read_text(errors="replace"))
    except OSError:
        return None
    return found.group(1) if found else None

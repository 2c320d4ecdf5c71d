"""Seeded fuzz tests: mutations of real inputs, with thresholds (no internal error, no traceback,
no damaged input accepted, nothing written on refusal)."""

from __future__ import annotations


def value_paths(node, path=(), per_list: int = 4):
    """Every path into a JSON-like document (``()`` the root); of a list, its first ``per_list``
    items stand for the rest."""
    yield path
    if isinstance(node, dict):
        for k, v in node.items():
            yield from value_paths(v, path + (k,), per_list)
    elif isinstance(node, list):
        for i, v in enumerate(node[:per_list]):
            yield from value_paths(v, path + (i,), per_list)

"""JSON documents that every reader can parse: no ``Infinity`` or ``NaN``.

JSON has no infinities (Python writes ``Infinity``, which strict parsers refuse).  rworld's
documents use ``null`` for "none" - no limit, not applicable, beyond the report range - and
:func:`finite` turns every non-finite float into it on the way out.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np


def finite(value: Any) -> Any:
    """``value`` with every non-finite float (numpy's too) replaced by None, numpy scalars and
    arrays made plain, text that UTF-8 cannot carry (lone surrogates) with '?' in their place;
    dicts, lists and tuples walked."""
    if isinstance(value, dict):
        return {k: finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite(v) for v in value]
    if isinstance(value, np.ndarray):
        return finite(value.tolist())
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, str):
        try:
            value.encode("utf-8")
        except UnicodeEncodeError:  # a lone surrogate: a file name's byte that is not UTF-8
            return value.encode("utf-8", "replace").decode("utf-8")
    return value

"""Turn pydantic validation errors into located, plain-spoken issues.

Pydantic's own messages ("Input should be a valid number") name neither the
value that was wrong nor what would be right.  Here each error type gets a
sentence that does, positioned on the offending value, on the unknown key,
or - for a missing key - on the mapping that lacks it.
"""

from __future__ import annotations

import types
import typing
from typing import Any

from pydantic import BaseModel, ValidationError

from ..errors import Issue, did_you_mean
from .models import NAME_PATTERN, REF_PATTERN, UNITS_HINT
from .yamlio import Marked, format_path


def describe(value: Any) -> str:
    """A short, YAML-flavoured description of a value for messages."""
    if value is None:
        return "nothing (null)"
    if isinstance(value, bool):
        return (
            f"{str(value).lower()} (YAML reads yes/no/on/off/true/false as booleans; quote it "
            "if you meant text)"
        )
    if isinstance(value, dict):
        return "a mapping"
    if isinstance(value, list):
        return f"a list of {len(value)}"
    if isinstance(value, str):
        return f"'{value}'" if len(value) < 40 else f"'{value[:37]}...'"
    return repr(value)


def _unwrap(annotation):
    """Strip Optional/Annotated; return the inner annotation."""
    while True:
        origin = typing.get_origin(annotation)
        if origin is typing.Annotated:
            annotation = typing.get_args(annotation)[0]
            continue
        if origin in (typing.Union, types.UnionType):
            args = [a for a in typing.get_args(annotation) if a is not type(None)]
            if len(args) == 1:
                annotation = args[0]
                continue
        return annotation


def annotation_at(root: type[BaseModel], loc: tuple) -> Any:
    """The type annotation (still wrapped in Annotated/Optional) that validates ``loc``, or None."""
    current: Any = root
    for part in loc:
        current = _unwrap(current)
        if isinstance(current, type) and issubclass(current, BaseModel):
            field = current.model_fields.get(part) if isinstance(part, str) else None
            if field is None:
                return None
            current = field.annotation
            continue
        origin = typing.get_origin(current)
        if origin is list and isinstance(part, int):
            current = typing.get_args(current)[0]
        elif origin is dict and isinstance(part, str):
            current = typing.get_args(current)[1]
        else:
            return None
    return current


def model_at(root: type[BaseModel], loc: tuple) -> type[BaseModel] | None:
    """The pydantic model class that validates the mapping at ``loc``, if any."""
    current = _unwrap(annotation_at(root, loc))
    return current if isinstance(current, type) and issubclass(current, BaseModel) else None


def _length_bounds(annotation) -> tuple[int | None, int | None]:
    """(min, max) of an ``annotated_types.Len`` on a list annotation."""
    lo = hi = None
    while annotation is not None:
        origin = typing.get_origin(annotation)
        if origin is typing.Annotated:
            for meta in typing.get_args(annotation)[1:]:
                if hasattr(meta, "min_length") and hasattr(meta, "max_length"):
                    lo, hi = meta.min_length, meta.max_length
            annotation = typing.get_args(annotation)[0]
        elif origin in (typing.Union, types.UnionType):
            args = [a for a in typing.get_args(annotation) if a is not type(None)]
            annotation = args[0] if len(args) == 1 else None
        else:
            break
    return lo, hi


def _message(err: dict, root: type[BaseModel]) -> tuple[str, str]:
    """(message, where) for one pydantic error; where is 'value', 'key' or 'parent'."""
    kind = err["type"]
    loc = tuple(err["loc"])
    value = err.get("input")
    ctx = err.get("ctx") or {}
    if kind == "missing":
        if loc[-1] == "units":
            return f"missing required key 'units': {UNITS_HINT}", "parent"
        if loc[-2:-1] == ("units",):
            return f"missing required key 'units.{loc[-1]}': {UNITS_HINT}", "parent"
        return f"missing required key '{loc[-1]}'", "parent"
    if kind == "extra_forbidden":
        model = model_at(root, loc[:-1])
        allowed = list(model.model_fields) if model else []
        hint = did_you_mean(loc[-1], allowed)
        if not hint and allowed:
            hint = f" (expected one of: {', '.join(allowed)})"
        return f"unknown key '{loc[-1]}'{hint}", "key"
    if kind in ("float_type", "float_parsing", "int_from_float"):
        if kind == "int_from_float":
            return f"expected a whole number, got {describe(value)}", "value"
        return f"expected a number, got {describe(value)}", "value"
    if kind in ("int_type", "int_parsing"):
        return f"expected a whole number, got {describe(value)}", "value"
    if kind == "finite_number":
        return f"expected a finite number, got {describe(value)}", "value"
    if kind == "string_type":
        return f"expected text, got {describe(value)}", "value"
    if kind == "bool_type":
        return f"expected true or false, got {describe(value)}", "value"
    if kind == "list_type":
        return f"expected a list, got {describe(value)}", "value"
    if kind in ("model_type", "dict_type", "model_attributes_type"):
        return f"expected a mapping (key: value), got {describe(value)}", "value"
    if kind == "literal_error" and loc[:1] == ("conditions",) and loc[-1] == "type":
        from .models import CONDITION_CODES

        names = ", ".join(f"{n} ({c})" for n, c in CONDITION_CODES.items())
        return (
            f"unknown condition type {describe(value)}{did_you_mean(value, CONDITION_CODES)}; "
            f"expected one of: {names}",
            "value",
        )
    if kind == "literal_error":
        expected = ctx.get("expected", "")
        choices = [c.strip().strip("'") for c in expected.replace(" or ", ", ").split(",")]
        return f"expected {expected}, got {describe(value)}{did_you_mean(value, choices)}", "value"
    if kind in ("too_short", "too_long"):
        lo, hi = _length_bounds(annotation_at(root, loc))
        lo = ctx.get("min_length", lo)
        hi = ctx.get("max_length", hi)
        actual = ctx.get("actual_length")
        if lo is not None and lo == hi:
            want = f"exactly {lo} values"
        elif kind == "too_short":
            want = f"at least {lo} value{'s' if lo != 1 else ''}"
        else:
            want = f"at most {hi} values"
        return f"expected {want}, got {actual}", "value"
    if kind in ("greater_than", "greater_than_equal", "less_than", "less_than_equal"):
        op = {
            "greater_than": ">",
            "greater_than_equal": ">=",
            "less_than": "<",
            "less_than_equal": "<=",
        }[kind]
        bound = next(iter(ctx.values())) if ctx else "?"
        return f"must be {op} {bound}, got {describe(value)}", "value"
    if kind == "string_pattern_mismatch":
        if ctx.get("pattern") == NAME_PATTERN:
            return (
                f"invalid name {describe(value)}: use letters, digits, '_' or '-', not starting "
                "with a digit, no '.'",
                "value",
            )
        if ctx.get("pattern") == REF_PATTERN:
            return (
                f"invalid frame reference {describe(value)}: expected 'name' or 'owner.frame'",
                "value",
            )
        return f"{describe(value)} does not match the pattern {ctx.get('pattern')}", "value"
    if kind == "value_error":
        msg = err["msg"]
        return (msg[len("Value error, ") :] if msg.startswith("Value error, ") else msg), "value"
    return f"{err['msg']} (got {describe(value)})", "value"


def pydantic_issues(exc: ValidationError, doc: Marked, root: type[BaseModel]) -> list[Issue]:
    """All errors of ``exc`` as issues located in ``doc``, in document order."""
    issues = []
    seen = set()
    for err in exc.errors(include_url=False):
        loc = tuple(err["loc"])
        message, where = _message(err, root)
        if where == "parent":
            line, col = doc.position(loc[:-1])
        else:
            line, col = doc.position(loc, prefer=where)
        issue = Issue(doc.file, line, col, format_path(loc), message)
        if issue not in seen:
            seen.add(issue)
            issues.append(issue)
    return sorted(issues, key=lambda i: (i.line, i.column))

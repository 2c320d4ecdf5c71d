"""xacro's expressions as data: ``${...}`` and ``$(eval ...)`` parsed by :mod:`ast` and walked
(:class:`_Evaluator`) over numbers, text, lists and dicts, properties (:class:`_Scope`),
arithmetic, comparisons, ``x if c else y``, math functions and a short list of built-ins;
every value's size bounded.  No attribute of a Python object is looked up (only keys of YAML
data and of name spaces), nothing is imported, nothing not listed is called.  The document's
expansion (macros, includes, files) is :mod:`.xacro`'s.
"""

from __future__ import annotations

import ast
import math
import operator
import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol


class _Host(Protocol):
    """What the evaluator asks of the expansion it serves (``xacro._Expander``)."""

    limits: Any  # xacro.XacroLimits: value_chars

    def tick(self) -> None: ...

    def get(self, scope: _Scope, name: str) -> Any: ...


class _Refused(Exception):
    """A problem in the xacro; :class:`_Expander` adds the element (file and line) it was
    raised in, and the macro calls that led there."""

    element: Any = None  # the xacro._El
    macros: list[str] = []


class _Scope:
    """A table of properties with a parent: xacro's ``Table`` (and ``NameSpace`` when
    ``namespace``).  Values given as text are evaluated lazily, on first use, in this scope."""

    def __init__(self, parent: _Scope | None = None, namespace: bool = False):
        self.parent = parent
        self.namespace = namespace
        self.values: dict[str, Any] = {}
        self.lazy: set[str] = set()
        self.resolving: list[str] = []

    def has(self, name: str) -> bool:
        scope: _Scope | None = self
        while scope is not None:
            if name in scope.values:
                return True
            scope = scope.parent
        return False

    def top(self) -> _Scope:
        scope = self
        while scope.parent is not None:
            scope = scope.parent
        return scope


def _literal(value: Any) -> Any:
    """xacro's ``_eval_literal``: quoted text unquoted, else a number or boolean if it reads as
    one (text with '_' stays text), else the text."""
    if not isinstance(value, str):
        return value
    if len(value) >= 2 and value[0] == "'" and value[-1] == "'":
        return value[1:-1]
    if "_" in value:
        return value
    for convert in (int, float):
        try:
            return convert(value)
        except ValueError:
            pass
    if value in ("true", "True"):
        return True
    if value in ("false", "False"):
        return False
    return value


def _boolean(value: Any, condition: str) -> bool:
    if isinstance(value, str):
        if value in ("true", "True"):
            return True
        if value in ("false", "False"):
            return False
        try:
            return bool(int(value))
        except ValueError:
            pass
        raise _Refused(f"the condition {condition!r} is {value!r}, not true or false")
    return bool(value)


class _YamlDict(dict):
    """A mapping from ``xacro.load_yaml``: keys by ``d['k']`` or ``d.k``."""


class _YamlList(list):
    pass


def _wrap(value: Any, budget: list[int] | None = None) -> Any:
    """YAML data as xacro's wrappers; at most ``budget[0]`` nodes (YAML's aliases share one
    object, which a copy would multiply: a 'billion laughs' file)."""
    budget = [1_000_000] if budget is None else budget
    budget[0] -= 1
    if budget[0] < 0:
        raise _Refused("the YAML data has over 1000000 nodes (aliases counted each time)")
    if isinstance(value, dict):
        return _YamlDict({k: _wrap(v, budget) for k, v in value.items()})
    if isinstance(value, list):
        return _YamlList(_wrap(v, budget) for v in value)
    return value


@dataclass(frozen=True)
class _Function:
    """A callable an expression may call: one of rworld's, never an arbitrary Python object."""

    name: str
    call: Callable[..., Any]


class _Names(dict):
    """A fixed name space of functions and constants (``math``, ``python``, ``xacro``)."""


_MATH_FUNCTIONS = (
    "sin cos tan asin acos atan atan2 sinh cosh tanh asinh acosh atanh sqrt exp log log10 log2 "
    "fabs floor ceil trunc radians degrees hypot copysign fmod isclose isfinite isinf isnan pow"
).split()


_MATH_CONSTANTS = {"pi": math.pi, "e": math.e, "tau": math.tau, "inf": math.inf, "nan": math.nan}


_STRING_METHODS = frozenset(
    "lower upper strip lstrip rstrip split startswith endswith replace join count find".split()
)


_DICT_METHODS = frozenset({"get", "keys", "values", "items"})


_BINARY = {
    ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
    ast.Div: operator.truediv, ast.FloorDiv: operator.floordiv, ast.Mod: operator.mod,
    ast.Pow: operator.pow,
}  # fmt: skip


_COMPARE = {
    ast.Eq: operator.eq, ast.NotEq: operator.ne, ast.Lt: operator.lt, ast.LtE: operator.le,
    ast.Gt: operator.gt, ast.GtE: operator.ge, ast.In: lambda a, b: a in b,
    ast.NotIn: lambda a, b: a not in b, ast.Is: operator.is_, ast.IsNot: operator.is_not,
}  # fmt: skip


_UNARY: dict[type, Callable[[Any], Any]] = {
    ast.USub: operator.neg,
    ast.UAdd: operator.pos,
    ast.Not: operator.not_,
}


_SEQUENCES = (str, list, tuple)


MAX_EXPRESSION_CHARS = 20_000  # vendors' longest: under 300


class _Evaluator:
    """Evaluates one xacro expression on the AST: the operations listed above and nothing else."""

    def __init__(self, expander: _Host, lookup: Callable[[str], Any]):
        self.expander = expander
        self.lookup = lookup
        self.limit = expander.limits.value_chars

    def __call__(self, source: str) -> Any:
        source = source.strip()
        if len(source) > MAX_EXPRESSION_CHARS:
            raise _Refused(
                f"an expression of {len(source)} characters (at most {MAX_EXPRESSION_CHARS})"
            )
        try:
            tree = ast.parse(source, mode="eval")
        except SyntaxError as exc:
            raise _Refused(f"invalid expression {_short(source)}: {exc.msg}") from None
        except (MemoryError, RecursionError):  # the parser's own stack
            raise _Refused(f"the expression {_short(source)} is nested too deeply") from None
        try:
            return self.eval(tree.body)
        except RecursionError:
            raise _Refused(f"the expression {_short(source)} is nested too deeply") from None
        except _Refused:
            raise
        except (ArithmeticError, TypeError, ValueError, KeyError, IndexError) as exc:
            kind = type(exc).__name__
            raise _Refused(f"{kind} in {_short(source)}: {exc}") from None

    def sized(self, value: Any) -> Any:
        if isinstance(value, str | list | tuple | dict | set) and len(value) > self.limit:
            raise _Refused(f"a value of {len(value)} items or characters (at most {self.limit})")
        return value

    def eval(self, node: ast.AST) -> Any:
        self.expander.tick()
        method = getattr(self, "_" + type(node).__name__, None)
        if method is None:
            raise _Refused(
                f"{type(node).__name__} is not allowed in a xacro expression: rworld evaluates "
                "numbers, text, properties, arithmetic, comparisons and math functions only"
            )
        return method(node)

    def _Constant(self, node: ast.Constant) -> Any:
        if not isinstance(node.value, int | float | str | bool | type(None)):
            raise _Refused(f"the constant {node.value!r} is not allowed")
        return self.sized(node.value)

    def _Name(self, node: ast.Name) -> Any:
        if node.id.startswith("_"):
            raise _Refused(f"the name {node.id!r} is not allowed (names starting with '_')")
        return self.lookup(node.id)

    def _Attribute(self, node: ast.Attribute) -> Any:
        name = node.attr
        if name.startswith("_"):
            raise _Refused(f"the attribute .{name} is not allowed (names starting with '_')")
        value = self.eval(node.value)
        if isinstance(value, _Scope) and value.namespace:
            return self.expander.get(value, name)
        if isinstance(value, _Names | _YamlDict) and name in value:
            return value[name]
        if isinstance(value, _Names):
            raise _Refused(f"no {name!r} in {_describe(value)}")
        if isinstance(value, str) and name in _STRING_METHODS:
            return _Function(f"str.{name}", self._string_method(value, name))
        if isinstance(value, dict) and name in _DICT_METHODS:
            method = getattr(value, name)
            return _Function(f"dict.{name}", lambda *a: _listed(method(*a)))
        raise _Refused(f"the attribute .{name} of {_describe(value)} is not allowed")

    def _string_method(self, text: str, name: str) -> Callable[..., Any]:
        method = getattr(text, name)

        def call(*args: Any) -> Any:
            if name == "replace" and len(args) >= 2 and isinstance(args[1], str):
                grows = (
                    (text.count(args[0]) + 1) * len(args[1])
                    if args[0] != ""
                    else ((len(text) + 1) * len(args[1]))
                )
                if len(text) + grows > self.limit:
                    raise _Refused(f"str.replace would make over {self.limit} characters")
            if name == "join" and len(args) == 1:
                parts = list(args[0])
                if sum(len(str(p)) for p in parts) + len(text) * len(parts) > self.limit:
                    raise _Refused(f"str.join would make over {self.limit} characters")
                return method(parts)
            return _listed(method(*args))

        return call

    def _Subscript(self, node: ast.Subscript) -> Any:
        value = self.eval(node.value)
        if not isinstance(value, str | list | tuple | dict):
            raise _Refused(f"{_describe(value)} cannot be indexed")
        if isinstance(node.slice, ast.Slice):
            parts = [
                None if p is None else self.eval(p)
                for p in (node.slice.lower, node.slice.upper, node.slice.step)
            ]
            if any(p is not None and not isinstance(p, int) for p in parts):
                raise _Refused("slice bounds must be whole numbers")
            return value[slice(*parts)]  # type: ignore[index]
        key = self.eval(node.slice)
        if isinstance(value, dict):
            if key not in value:
                raise _Refused(f"no key {key!r} in {_describe(value)}")
            return value[key]
        if not isinstance(key, int) or isinstance(key, bool):
            raise _Refused(f"an index must be a whole number, not {key!r}")
        return value[key]

    def _Call(self, node: ast.Call) -> Any:
        function = self.eval(node.func)
        if not isinstance(function, _Function):
            raise _Refused(f"{_describe(function)} cannot be called")
        if any(isinstance(a, ast.Starred) for a in node.args) or any(
            k.arg is None for k in node.keywords
        ):
            raise _Refused("*args and **kwargs are not allowed")
        args = [self.eval(a) for a in node.args]
        kwargs = {str(k.arg): self.eval(k.value) for k in node.keywords}
        return self.sized(function.call(*args, **kwargs))

    def _BinOp(self, node: ast.BinOp) -> Any:
        kind = type(node.op)
        if kind not in _BINARY:
            raise _Refused(f"the operator {kind.__name__} is not allowed")
        left, right = self.eval(node.left), self.eval(node.right)
        if kind is ast.Mult:
            for seq, count in ((left, right), (right, left)):
                if isinstance(seq, _SEQUENCES) and isinstance(count, int):
                    if len(seq) * max(count, 0) > self.limit:
                        raise _Refused(
                            f"a repetition of {len(seq)} x {count} items or "
                            f"characters (at most {self.limit})"
                        )
        if kind is ast.Add and isinstance(left, _SEQUENCES) and isinstance(right, _SEQUENCES):
            if len(left) + len(right) > self.limit:
                raise _Refused(f"a value of over {self.limit} items or characters")
        if kind is ast.Mod and isinstance(left, str):
            raise _Refused("text formatting with '%' is not allowed")
        if kind is ast.Pow and isinstance(left, int) and isinstance(right, int) and right > 0:
            if abs(left) > 1 and right * abs(left).bit_length() > 4096:
                raise _Refused(f"{left} ** {right} is too large a number")
        return self.sized(_BINARY[kind](left, right))

    def _UnaryOp(self, node: ast.UnaryOp) -> Any:
        kind = type(node.op)
        if kind not in _UNARY:
            raise _Refused(f"the operator {kind.__name__} is not allowed")
        return _UNARY[kind](self.eval(node.operand))

    def _BoolOp(self, node: ast.BoolOp) -> Any:
        value: Any = None
        for operand in node.values:
            value = self.eval(operand)
            if isinstance(node.op, ast.And) and not value:
                return value
            if isinstance(node.op, ast.Or) and value:
                return value
        return value

    def _Compare(self, node: ast.Compare) -> Any:
        left = self.eval(node.left)
        for op, operand in zip(node.ops, node.comparators, strict=True):
            right = self.eval(operand)
            if not _COMPARE[type(op)](left, right):
                return False
            left = right
        return True

    def _IfExp(self, node: ast.IfExp) -> Any:
        return self.eval(node.body) if self.eval(node.test) else self.eval(node.orelse)

    def _List(self, node: ast.List) -> Any:
        return self.sized([self.eval(e) for e in node.elts])

    def _Tuple(self, node: ast.Tuple) -> Any:
        return self.sized(tuple(self.eval(e) for e in node.elts))

    def _Dict(self, node: ast.Dict) -> Any:
        if any(k is None for k in node.keys):
            raise _Refused("**mapping in a dict is not allowed")
        pairs = zip(node.keys, node.values, strict=True)
        return self.sized({self.eval(k): self.eval(v) for k, v in pairs})  # type: ignore[arg-type]


_DICT_VIEWS: tuple[type, ...] = (type({}.keys()), type({}.values()), type({}.items()))


def _listed(value: Any) -> Any:
    if isinstance(value, _DICT_VIEWS):
        return list(value)  # type: ignore[call-overload]
    return value


def _short(source: str) -> str:
    return repr(source if len(source) <= 80 else source[:77] + "...")


def _describe(value: Any) -> str:
    if isinstance(value, _Function):
        return f"the function {value.name}"
    if isinstance(value, _Scope):
        return "a name space"
    if isinstance(value, _Names):
        return "a name space of functions"
    if hasattr(value, "tag") and hasattr(value, "children"):  # a block (xacro._El)
        return f"the block <{value.tag}>"
    return f"a {type(value).__name__.lstrip('_').replace('Yaml', 'YAML ').lower()}"


def _range(*args: Any) -> list[int]:
    values = range(*args)
    if len(values) > 100_000:
        raise _Refused(f"range of {len(values)} numbers (at most 100000)")
    return list(values)


def _round(number: Any, digits: Any = None) -> Any:
    if digits is not None and (not isinstance(digits, int) or abs(digits) > 300):
        raise _Refused(f"round to {digits!r} digits")
    return round(number) if digits is None else round(number, digits)


def _tokenize(text: str, sep: str = ",; ", skip_empty: bool = True) -> list[str]:
    parts = re.split(f"[{re.escape(sep)}]", text)
    return [p for p in parts if p] if skip_empty else parts


def as_text(value: Any, limit: int = 1_000_000) -> str:
    """``str(value)``, refused when it would be longer than ``limit`` characters (a list can
    hold one long text a million times without holding its characters)."""
    if isinstance(value, str | int | float | bool | type(None)):
        text = str(value)
    else:
        budget = [limit]

        def measure(v: Any) -> None:
            budget[0] -= len(v) + 4 if isinstance(v, str) else 8
            if budget[0] < 0:
                raise _Refused(f"a value whose text is over {limit} characters")
            if isinstance(v, dict):
                for k, item in v.items():
                    measure(k)
                    measure(item)
            elif isinstance(v, list | tuple | set):
                for item in v:
                    measure(item)

        measure(value)
        text = str(value)
    if len(text) > limit:
        raise _Refused(f"a value whose text is over {limit} characters")
    return text


def _sum(values: Any, start: Any = 0) -> Any:
    values = list(values)
    if not all(isinstance(v, int | float) for v in [*values, start]):
        raise _Refused("sum() adds numbers only")
    return sum(values, start)


_PYTHON: dict[str, Callable[..., Any]] = {
    "list": list, "dict": dict, "len": len, "str": as_text, "float": float, "int": int,
    "bool": bool, "min": min, "max": max, "round": _round, "abs": abs, "sum": _sum,
    "sorted": sorted, "range": _range, "any": any, "all": all, "tuple": tuple, "set": set,
    "zip": lambda *a: list(zip(*a, strict=False)), "enumerate": lambda *a: list(enumerate(*a)),
    "reversed": lambda a: list(reversed(a)), "divmod": divmod,
}  # fmt: skip


_GLOBALS: dict[str, Any] = {name: _Function(name, f) for name, f in _PYTHON.items()}


_GLOBALS.update({"True": True, "False": False, "None": None})


_MATH = _Names({name: _Function(f"math.{name}", getattr(math, name)) for name in _MATH_FUNCTIONS})


_MATH.update(_MATH_CONSTANTS)


_GLOBALS.update(_MATH)

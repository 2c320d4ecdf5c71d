"""Read YAML into plain Python data while keeping where every key and value was.

PyYAML's ``compose`` gives a node tree with start marks; we walk it ourselves
so that each path in the document (``("devices", 0, "joints", 2, "a")``) maps
to the 1-based line and column of its key and of its value.  That table is
what turns a pydantic error location or a semantic check into
``file:line:col``.

Why a custom walk: the stock constructors throw the marks away, and silently
keep the last of duplicated keys; both are wrong for a validator.
"""

from __future__ import annotations

import ast
import hashlib
import math
import operator
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from ..errors import Issue, UserError

PathKey = tuple  # tuple[str | int, ...]

try:  # the C loader is ~10x faster and gives the same marks
    _Base = yaml.CSafeLoader  # type: ignore[attr-defined]
except AttributeError:  # pragma: no cover - pure-python PyYAML build
    _Base = yaml.SafeLoader


class _Loader(_Base):  # type: ignore[misc, valid-type]
    """Safe loader that also reads YAML 1.2 floats such as ``4e-05`` and ``1E3``.

    Why: YAML 1.1 (PyYAML's default) wants a dot in the mantissa and reads
    ``4e-05`` as text - numbers copied from papers and datasheets then fail.
    """


_Loader.yaml_implicit_resolvers = {k: list(v) for k, v in _Base.yaml_implicit_resolvers.items()}
_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


@dataclass
class Marked:
    """A parsed YAML document with positions.

    Attributes
    ----------
    data : Any
        Plain dicts, lists and scalars.
    file : str
        The path as given by the user (used verbatim in messages).
    value_marks : dict
        Path tuple -> (line, column) of the value's first character (1-based).
    key_marks : dict
        Path tuple -> (line, column) of the mapping key that leads to it.
    digest : str
        SHA-256 of the bytes parsed ('' for text not read from a file): what a cache entry
        records, so that it describes the bytes this parse saw, not the file as it is later.
    """

    data: Any
    file: str
    value_marks: dict[PathKey, tuple[int, int]] = field(default_factory=dict)
    key_marks: dict[PathKey, tuple[int, int]] = field(default_factory=dict)
    digest: str = ""

    def position(self, path: PathKey, prefer: str = "value") -> tuple[int, int]:
        """Best position for ``path``: its value (or key), else the nearest ancestor."""
        path = tuple(path)
        table_first = self.key_marks if prefer == "key" else self.value_marks
        while True:
            if path in table_first:
                return table_first[path]
            if path in self.value_marks:
                return self.value_marks[path]
            if not path:
                return (1, 1)
            path = path[:-1]

    def issue(
        self, path: PathKey, message: str, *, prefer: str = "value", severity: str = "error"
    ) -> Issue:
        line, col = self.position(path, prefer)
        return Issue(self.file, line, col, format_path(path), message, severity)  # type: ignore[arg-type]


_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f\u2028\u2029]")


def comment_text(text: object) -> str:
    """``text`` fit for one line of a YAML comment: every control character (a newline would
    end the comment and make the rest YAML) written as its escape, ``\\n``, ``\\x07``."""
    return _CONTROL.sub(lambda m: repr(m.group())[1:-1], str(text))


_PLAIN = re.compile(r"[A-Za-z_][A-Za-z0-9_.\-]*")
_SPECIAL = {"true", "false", "yes", "no", "on", "off", "null", "y", "n"}  # YAML 1.1 and 1.2


def yaml_value(value: object) -> str:
    """One value as YAML flow text for a line a writer lays out: a name as it is when YAML reads
    it back as that text (``plate.hole1``), any other text double-quoted with escapes (a name or
    path holding ``: ``, ``#``, a quote, a newline, or reading as a boolean or null stays one
    value on one line); numbers, booleans and lists as YAML writes them."""
    if isinstance(value, str) and _PLAIN.fullmatch(value) and value.lower() not in _SPECIAL:
        return value
    if isinstance(value, str):
        text = yaml.safe_dump(value, default_style='"', width=float("inf"), allow_unicode=False)
    else:
        text = yaml.safe_dump(value, default_flow_style=True, width=float("inf"))
    return text.removesuffix("\n...\n").strip()


def format_path(path: PathKey) -> str:
    """``("devices", 0, "joints", 2, "a")`` -> ``devices[0].joints[2].a``; ``()`` -> ``(root)``."""
    out = ""
    for part in path:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out or "(root)"


def _mark(node: yaml.Node) -> tuple[int, int]:
    return (node.start_mark.line + 1, node.start_mark.column + 1)


# xacro's load_yaml tags (ROS packages' YAML: UR's joint_limits.yaml gives `!degrees 120.0`):
# each value times its factor to SI
ROS_UNIT_TAGS = {
    "!radians": 1.0,
    "!degrees": math.pi / 180.0,
    "!meters": 1.0,
    "!millimeters": 1e-3,
    "!foot": 0.3048,
    "!inches": 0.0254,
}
_ARITHMETIC = {
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Mult: operator.mul,
    ast.Div: operator.truediv,
}


def _unit_number(text: str) -> float:
    """A unit tag's value: a number, or arithmetic (+ - * /, brackets) of numbers and ``pi``,
    as xacro evaluates it (``!radians pi/2``), read as data: nothing else is evaluated.

    Raises ValueError when it is anything else."""

    def value(node: ast.AST, depth: int) -> float:
        if depth > 32:
            raise ValueError("nested too deep")
        if isinstance(node, ast.Constant) and type(node.value) in (int, float):
            return float(node.value)
        if isinstance(node, ast.Name) and node.id in ("pi", "e", "tau"):
            return float(getattr(math, node.id))
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.UAdd | ast.USub):
            inner = value(node.operand, depth + 1)
            return -inner if isinstance(node.op, ast.USub) else inner
        if isinstance(node, ast.BinOp) and type(node.op) in _ARITHMETIC:
            return _ARITHMETIC[type(node.op)](
                value(node.left, depth + 1), value(node.right, depth + 1)
            )
        raise ValueError("not arithmetic of numbers and pi")

    if len(text) > 200:
        raise ValueError("too long")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError:
        raise ValueError("not an expression") from None
    try:
        out = value(tree.body, 0)
    except ZeroDivisionError:
        raise ValueError("divides by zero") from None
    if not math.isfinite(out):
        raise ValueError("not finite")
    return out


def parse_yaml_text(text: str, file: str, ros_units: bool = False) -> Marked:
    """Parse one YAML document from ``text``.  ``ros_units``: xacro's unit tags
    (:data:`ROS_UNIT_TAGS`, ``!degrees 120``) read as numbers in SI, as ROS packages' YAML
    files use them.

    Raises
    ------
    UserError
        On a syntax error, a duplicated key, a non-scalar key, an unsafe tag,
        several documents or an empty document; each with file:line:col.
    """
    loader = _Loader(text)
    try:
        try:
            root = loader.get_single_node()
        except yaml.MarkedYAMLError as exc:
            mark = exc.problem_mark or exc.context_mark
            line, col = (mark.line + 1, mark.column + 1) if mark else (1, 1)
            problem = exc.problem or "invalid YAML"
            if exc.context and "expected a single document" in exc.context:
                problem = (
                    "several YAML documents in one file; keep one (remove the '---' separators)"
                )
            raise UserError(
                "invalid YAML", [Issue(file, line, col, "(yaml)", f"YAML syntax error: {problem}")]
            ) from None
        except yaml.YAMLError as exc:  # reader errors: bad bytes
            raise UserError(
                "invalid YAML", [Issue(file, 1, 1, "(yaml)", f"cannot read YAML: {exc}")]
            ) from None
        doc = Marked(data=None, file=file)
        if root is None:
            raise UserError(
                "empty file",
                [Issue(file, 1, 1, "(root)", "the file is empty; expected a YAML mapping")],
            )
        issues: list[Issue] = []
        state = _WalkState()
        state.ros_units = ros_units
        doc.data = _walk(loader, root, (), doc, issues, state)
        if issues:
            raise UserError("invalid YAML", issues)
        return doc
    except RecursionError:
        raise UserError(
            "invalid YAML",
            [Issue(file, 1, 1, "(yaml)", "the document nests too deep to be a file of rworld's")],
        ) from None
    finally:
        loader.dispose()


MAX_VALUES = 2_000_000  # values a document may expand to (aliases counted at each use)


class _WalkState:
    """What :func:`_walk` shares over one document: each node's value and size once built (an
    alias reuses them, so ``*a`` costs one step however large ``&a`` is), the nodes being built
    (an alias to one of them is a cycle), and the values counted so far."""

    def __init__(self) -> None:
        self.built: dict[int, tuple[Any, int]] = {}
        self.active: set[int] = set()
        self.values = 0
        self.ros_units = False  # xacro's unit tags read (parse_yaml_text)


def _walk(
    loader, node: yaml.Node, path: PathKey, doc: Marked, issues: list[Issue], state: _WalkState
) -> Any:
    doc.value_marks[path] = _mark(node)
    key = id(node)
    if key in state.active:  # an alias inside its own anchor
        line, col = _mark(node)
        issues.append(
            Issue(doc.file, line, col, format_path(path), "an alias refers to itself (a cycle)")
        )
        return None
    if key in state.built:  # an alias: the value built at the anchor, counted again
        value, size = state.built[key]
        state.values += size
        if state.values > MAX_VALUES:
            raise UserError(
                "invalid YAML",
                [
                    Issue(
                        doc.file,
                        *_mark(node),
                        format_path(path),
                        f"through its aliases (*name) the document expands to more than "
                        f"{MAX_VALUES:,} values; rworld reads no more (an alias bomb?)",
                    )
                ],
            )
        return value
    before = state.values
    state.active.add(key)
    try:
        value = _build(loader, node, path, doc, issues, state)
    finally:
        state.active.discard(key)
    state.values += 1
    state.built[key] = (value, state.values - before)
    return value


def _at(doc: Marked, node: yaml.Node, path: PathKey, message: str) -> Issue:
    """An issue at ``node``'s first character, located by ``path``."""
    line, col = _mark(node)
    return Issue(doc.file, line, col, format_path(path), message)


def _build(
    loader, node: yaml.Node, path: PathKey, doc: Marked, issues: list[Issue], state: _WalkState
) -> Any:
    if state.ros_units and node.tag in ROS_UNIT_TAGS and not isinstance(node, yaml.ScalarNode):
        issues.append(_at(doc, node, path, f"{node.tag} takes one number"))
        return None
    if isinstance(node, yaml.MappingNode):
        loader.flatten_mapping(node)  # resolves '<<' merge keys
        out: dict[str, Any] = {}
        for key_node, value_node in node.value:
            if not isinstance(key_node, yaml.ScalarNode):
                issues.append(
                    _at(doc, key_node, path, "a key must be a plain name, not a list or mapping")
                )
                continue
            # Keys are names: keep their text, so 'no:' or '1:' stay strings.
            key = key_node.value
            child = path + (key,)
            if key in out:
                first = doc.key_marks[child]
                issues.append(
                    _at(
                        doc,
                        key_node,
                        child,
                        f"duplicate key '{key}' (first given at line {first[0]})",
                    )
                )
                continue
            doc.key_marks[child] = _mark(key_node)
            out[key] = _walk(loader, value_node, child, doc, issues, state)
        return out
    if isinstance(node, yaml.SequenceNode):
        return [
            _walk(loader, item, path + (i,), doc, issues, state)
            for i, item in enumerate(node.value)
        ]
    if state.ros_units and isinstance(node, yaml.ScalarNode) and node.tag in ROS_UNIT_TAGS:
        try:
            return _unit_number(str(node.value)) * ROS_UNIT_TAGS[node.tag]
        except ValueError as exc:
            message = f"{node.tag} {node.value!r}: {exc} (a number, or arithmetic of numbers and pi"
            issues.append(_at(doc, node, path, message + ", as xacro reads it)"))
            return None
    try:
        return loader.construct_object(node, deep=True)
    except yaml.constructor.ConstructorError as exc:
        issues.append(_at(doc, node, path, f"unsupported YAML value: {exc.problem}"))
        return None


def read_yaml(path: str | Path, display: str | None = None, ros_units: bool = False) -> Marked:
    """Read and parse a YAML file; ``display`` is the name used in messages; ``ros_units``:
    xacro's unit tags read (:func:`parse_yaml_text`).

    Raises
    ------
    UserError
        The file is missing, unreadable, not UTF-8, or not valid YAML.
    """
    shown = display if display is not None else str(path)
    try:
        data = Path(path).read_bytes()
        text = data.decode("utf-8")
    except FileNotFoundError:
        raise UserError(
            f"{shown}: no such file", [Issue(shown, 0, 0, "(file)", "no such file")]
        ) from None
    except IsADirectoryError:
        raise UserError(
            f"{shown}: is a directory",
            [Issue(shown, 0, 0, "(file)", "is a directory, expected a YAML file")],
        ) from None
    except UnicodeDecodeError as exc:
        raise UserError(
            f"{shown}: not UTF-8",
            [Issue(shown, 1, 1, "(file)", f"not UTF-8 text ({exc.reason} at byte {exc.start})")],
        ) from None
    except OSError as exc:
        raise UserError(
            f"{shown}: cannot read", [Issue(shown, 0, 0, "(file)", f"cannot read: {exc.strerror}")]
        ) from None
    marked = parse_yaml_text(text, shown, ros_units)
    marked.digest = hashlib.sha256(data).hexdigest()
    return marked

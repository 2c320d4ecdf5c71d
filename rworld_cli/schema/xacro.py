"""xacro without code: a vendor's robot description expanded as data, never run.

xacro files are other people's files.  The ROS tool evaluates ``${...}`` and ``$(eval ...)``
with Python's ``eval`` (a name filter in front of it, which attribute walks such as
``python.vars(python.type)`` step round), reads ``$(env ...)`` from the environment and includes
any file a path names.  This module expands the same language with none of that:

- expressions are parsed by :mod:`ast` and walked (:mod:`.xacro_eval`), which knows numbers,
  strings, lists and dicts, properties, arithmetic, comparisons, ``x if c else y``, math
  functions and a short list of built-ins (``len``, ``float``, ``str``, ``min``, ...); no
  attribute of a Python object is ever looked up (only keys of YAML data and of xacro's name
  spaces), nothing is imported, no callable that is not on the list can be called;
- ``$(env NAME)`` and ``$(optenv NAME ...)`` read ``--xacro-arg NAME:=VALUE``, never the
  environment; ``$(eval ...)`` goes through the same walker;
- includes and ``xacro.load_yaml`` read only files that resolve (links followed) inside the
  package paths or the xacro's own package;
- the work is bounded (:class:`XacroLimits`): file sizes, files, expanded elements, output
  characters, the length of any one value, macro calls and nesting, and time;
- every refusal names the file and line of the element that asked for it.

It follows the semantics of xacro 2 (in-order processing, lazy properties, dynamic scoping of
macro bodies, block parameters, ``^`` forwarding, name spaces of includes, ``scope="parent"``
and ``"global"``); the tests expand vendor packages with both and compare the robots.
"""

from __future__ import annotations

import glob
import math
import os
import re
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import Issue, UserError
from .xacro_doc import (
    _El,
    _package_root,
    _parse,
    _serialise,
    _SetAttribute,
    _shown,
    _Text,
    find_package,
)
from .xacro_eval import (
    _GLOBALS,
    _MATH,
    _PYTHON,
    _boolean,
    _Evaluator,
    _Function,
    _literal,
    _Names,
    _Refused,
    _Scope,
    _short,
    _tokenize,
    _wrap,
    as_text,
)

__all__ = ["XacroExpansion", "XacroLimits", "expand_xacro_file", "find_package"]


@dataclass(frozen=True)
class XacroLimits:
    """How much work a xacro expansion may do; past any of these it is refused, located.

    The defaults are far above the vendor packages tried (Universal Robots' ``ur.urdf.xacro``
    with its four YAML files: 219 elements in 25 ms, ``bench/xacro_expand.py``).
    """

    file_bytes: int = 8_000_000  # one xacro or YAML file
    files: int = 2_000  # files read (includes and YAML)
    elements: int = 200_000  # elements in the expanded document
    output_chars: int = 64_000_000  # attribute values and text of the expanded document
    value_chars: int = 1_000_000  # one string, list or dict in an expression
    macro_calls: int = 50_000
    macro_depth: int = 40
    seconds: float = 10.0


@dataclass(frozen=True)
class XacroExpansion:
    """A xacro file expanded.

    Attributes
    ----------
    urdf : bytes
        The expanded document (UTF-8 XML).
    warnings : list of Issue
        ``xacro.warning(...)`` / ``xacro.message(...)`` calls, located.
    origins : dict
        Line of the expanded document -> (file, line, column) of the xacro element written on
        it: messages about the robot then name the vendor's file, not the expansion.
    """

    urdf: bytes
    warnings: list[Issue]
    origins: dict[int, tuple[str, int, int]]

    def source_of(self, issue: Issue, expanded: str) -> Issue:
        """``issue`` moved from the expansion (named ``expanded``) to the xacro element it
        came from; as it is when it names another file or a line without an element."""
        origin = self.origins.get(issue.line) if issue.file == expanded else None
        if origin is None:
            return issue
        file, line, column = origin
        return Issue(file, line, column, issue.location, issue.message, issue.severity)


# --- the expansion --------------------------------------------------------------------------

_LEXER = re.compile(
    r"(?P<dollars>\$\$+[{(])|(?P<expr>\$\{[^}]*\})|(?P<ext>\$\([^)]*\))|"
    r"(?P<text>[^$]+|\$[^{($]+|\$$)"
)  # xacro's QuickLexer, token by token
_MACRO_PARAM = re.compile(
    r"^\s*([^\s:=]+?)\s*:?=\s*(\^\|?)?(\$\{.*?\}|\$\(.*?\)|(?:'.*?'|\".*?\"|[^\s'\"]+)+|)"
    r"(?:\s+|$)(.*)"
)
_UNITS = {"!radians": 1.0, "!degrees": math.pi / 180, "!meters": 1.0, "!millimeters": 1e-3,
          "!foot": 0.3048, "!inches": 0.0254}  # fmt: skip


@dataclass
class _Macro:
    name: str
    body: _El
    params: list[str]
    defaults: dict[str, tuple[str | None, str | None]]


class _Macros:
    def __init__(self, parent: _Macros | None = None):
        self.parent = parent
        self.table: dict[str, Any] = {}  # name -> _Macro, or a name space's _Macros

    def find(self, name: str) -> Any:
        macros: _Macros | None = self
        while macros is not None:
            if name in macros.table:
                return macros.table[name]
            macros = macros.parent
        raise KeyError(name)


@dataclass
class _Expander:
    package_paths: Sequence[Path]
    args: dict[str, str]
    roots: list[Path]
    limits: XacroLimits
    warnings: list[Issue] = field(default_factory=list)
    files: int = 0
    elements: int = 0
    chars: int = 0
    calls: int = 0
    depth: int = 0
    ticks: int = 0
    deadline: float = 0.0
    where: list[_El] = field(default_factory=list)
    macro_stack: list[str] = field(default_factory=list)
    builtins: dict[str, Any] = field(default_factory=dict)
    namespaces: dict[str, str] = field(default_factory=dict)

    # bounds

    def tick(self) -> None:
        self.ticks += 1
        if self.ticks % 256 == 0 and time.monotonic() > self.deadline:
            raise _Refused(f"the expansion took over {self.limits.seconds:g} s; rworld stops there")

    def count_output(self, value: str) -> str:
        self.chars += len(value)
        if self.chars > self.limits.output_chars:
            raise _Refused(f"the expanded document is over {self.limits.output_chars} characters")
        if _XML_INVALID.search(value):
            raise _Refused(f"a value holds a control character XML cannot carry: {value[:60]!r}")
        return value

    # files

    def confined(self, name: str, what: str) -> Path:
        """``name`` (relative to the current file) as a file inside the package paths or the
        xacro's own package, links resolved; else refused."""
        current = Path(self.where[-1].file).parent if self.where else Path(".")
        path = Path(name) if os.path.isabs(name) else current / name
        real = Path(os.path.realpath(path))
        if not any(real == root or root in real.parents for root in self.roots):
            shown = ", ".join(str(r) for r in self.roots)
            raise _Refused(
                f"{what} {name!r} resolves to {real}, outside the package paths and "
                f"the xacro's own package ({shown}); rworld reads no other file"
            )
        if not real.is_file():
            raise _Refused(f"{what} {name!r}: no such file ({real})")
        self.files += 1
        if self.files > self.limits.files:
            raise _Refused(f"over {self.limits.files} files read")
        return real

    def load_yaml(self, name: Any) -> Any:
        import yaml

        path = self.confined(str(name), "xacro.load_yaml of")
        if path.stat().st_size > self.limits.file_bytes:
            raise _Refused(f"{path} is over {self.limits.file_bytes} bytes")
        expander = self

        class Loader(yaml.SafeLoader):
            pass

        for tag, factor in _UNITS.items():

            def construct(loader, node, factor=factor, tag=tag):
                text = loader.construct_scalar(node)
                value = expander.evaluate(str(text), lambda n: expander.global_name(n))
                if not isinstance(value, int | float) or isinstance(value, bool):
                    raise _Refused(f"{tag} {text!r} is not a number")
                return float(value) * factor

            Loader.add_constructor(tag, construct)
        try:
            with path.open("rb") as stream:
                data = yaml.load(stream, Loader=Loader)  # noqa: S506 - a SafeLoader subclass
        except yaml.YAMLError as exc:
            raise _Refused(f"{path}: invalid YAML: {exc}") from None
        return _wrap(data)

    def find(self, package: str) -> str:
        folder = find_package(package, self.package_paths)
        if folder is None:
            where = ", ".join(str(p) for p in self.package_paths) or "no --package-path given"
            raise _Refused(
                f"$(find {package}): no ROS package '{package}' under the package paths "
                f"({where}); give the folder that holds it with --package-path DIR"
            )
        return os.path.abspath(folder)  # as given (links kept): what messages then show

    # names

    def global_name(self, name: str) -> Any:
        if name in _GLOBALS:
            return _GLOBALS[name]
        if name in self.builtins:
            return self.builtins[name]
        raise _Refused(f"name {name!r} is not defined")

    def get(self, scope: _Scope, name: str) -> Any:
        """A property's value through the scope chain, evaluating a lazy one in its scope."""
        s: _Scope | None = scope
        while s is not None:
            if name in s.values:
                if name in s.lazy:
                    if name in s.resolving:
                        chain = " -> ".join([*s.resolving, name])
                        raise _Refused(f"circular property definition: {chain}")
                    s.resolving.append(name)
                    try:
                        s.values[name] = _literal(self.text(s.values[name], s))
                    finally:
                        s.resolving.remove(name)
                    s.lazy.discard(name)
                return s.values[name]
            s = s.parent
        return self.global_name(name)

    def set(self, scope: _Scope, name: str, value: Any, lazy: bool) -> None:
        value = _literal(value)
        scope.values[name] = value
        if lazy and isinstance(value, str):
            scope.lazy.add(name)
        else:
            scope.lazy.discard(name)

    # text

    def evaluate(self, source: str, lookup: Callable[[str], Any]) -> Any:
        return _Evaluator(self, lookup)(source)

    def text(self, text: Any, scope: _Scope) -> Any:
        """xacro's ``eval_text``: ``${...}`` and ``$(...)`` replaced; one piece keeps its type."""
        if not isinstance(text, str):
            return text
        results: list[Any] = []
        position = 0
        while position < len(text):
            match = _LEXER.match(text, position)
            if match is None:
                raise _Refused(f"invalid expression: {_short(text[position:])} (no closing brace)")
            position = match.end()
            kind, piece = match.lastgroup, match.group()
            if kind == "expr":
                inner = self.text(piece[2:-1], scope)
                results.append(self.evaluate(as_text(inner), lambda n: self.get(scope, n)))
            elif kind == "ext":
                results.append(self.extension(as_text(self.text(piece[2:-1], scope))))
            elif kind == "dollars":
                results.append(piece[1:])
            else:
                results.append(piece)
        if len(results) == 1:
            return results[0]
        joined = "".join(as_text(r, self.limits.value_chars) for r in results)
        if len(joined) > self.limits.value_chars:
            raise _Refused(
                f"a value of {len(joined)} characters (at most {self.limits.value_chars})"
            )
        return joined

    def extension(self, text: str) -> str:
        """``$(command ...)``: find, arg, env and optenv (from the --xacro-arg values), eval
        (the same walker), dirname."""
        words = text.split()
        command, rest = (words[0], words[1:]) if words else ("", [])
        if command == "eval":
            value = self.evaluate(text.strip()[4:], self.eval_name)
            return str(value)
        if command == "find" and len(rest) == 1:
            return self.find(rest[0])
        if command == "arg" and len(rest) == 1:
            if rest[0] not in self.args:
                raise _Refused(
                    f"$(arg {rest[0]}): undefined; give it with --xacro-arg {rest[0]}:=VALUE"
                )
            return self.args[rest[0]]
        if command == "env" and len(rest) == 1:
            if rest[0] not in self.args:
                raise _Refused(
                    f"$(env {rest[0]}): rworld reads no environment variable for a xacro; give "
                    f"the value with --xacro-arg {rest[0]}:=VALUE"
                )
            return self.args[rest[0]]
        if command == "optenv" and rest:
            return self.args.get(rest[0], " ".join(rest[1:]))
        if command == "dirname" and not rest:
            return os.path.dirname(os.path.realpath(self.where[-1].file)) if self.where else "."
        raise _Refused(
            f"$({_short(text)[1:-1]}): rworld expands $(find PKG), $(arg NAME), "
            "$(env NAME), $(optenv NAME [DEFAULT]), $(eval EXPR) and $(dirname)"
        )

    def eval_name(self, name: str) -> Any:
        """A name in ``$(eval ...)``: an argument (typed), or arg/find/env/optenv/dirname."""
        if name in self.args:
            return _literal(self.args[name])
        functions: dict[str, Callable[..., Any]] = {
            "arg": lambda n: _literal(self.extension(f"arg {n}")),
            "find": lambda p: self.find(str(p)),
            "env": lambda n: self.extension(f"env {n}"),
            "optenv": lambda n, d="": self.args.get(str(n), d),
            "dirname": lambda: self.extension("dirname"),
        }
        if name in functions:
            return _Function(name, functions[name])
        return self.global_name(name)

    # elements

    def nodes(self, children: list[Any], scope: _Scope, macros: _Macros) -> list[Any]:
        out: list[Any] = []
        for child in children:
            if isinstance(child, _Text):
                out.append(_Text(self.count_output(as_text(self.text(child.data, scope)))))
            elif isinstance(child, _El):
                out.extend(self.element(child, scope, macros))
        return out

    def element(self, el: _El, scope: _Scope, macros: _Macros) -> list[Any]:
        self.where.append(el)
        try:
            return self._element(el, scope, macros)
        except _Refused as exc:
            if exc.element is None:  # the innermost element is where it happened
                exc.element, exc.macros = el, list(self.macro_stack)
            raise
        finally:
            self.where.pop()

    def _element(self, el: _El, scope: _Scope, macros: _Macros) -> list[Any]:
        self.tick()
        tag = el.tag
        if not tag.startswith("xacro:"):
            return [self.plain(el, scope, macros)]
        kind = tag[6:]
        if kind == "property":
            self.property(el, scope)
        elif kind == "macro":
            self.macro(el, macros)
        elif kind == "arg":
            name, default = self.required(el, "name"), el.get("default")
            if default is None:
                raise _Refused("xacro:arg needs a default")
            if name not in self.args:
                self.args[name] = as_text(self.text(default, scope))
        elif kind == "include":
            return self.include(el, scope, macros)
        elif kind in ("if", "unless"):
            condition = self.required(el, "value")
            keep = _boolean(self.text(condition, scope), condition)
            if keep == (kind == "if"):
                return self.nodes(el.children, scope, macros)
        elif kind == "insert_block":
            name = self.required(el, "name")
            if scope.has("**" + name):
                block = self.get(scope, "**" + name)
                return self.nodes(block.children, scope, macros)
            if scope.has("*" + name):
                return self.element(self.get(scope, "*" + name), scope, macros)
            raise _Refused(f"undefined block {name!r}")
        elif kind == "element":
            name = as_text(self.text(self.required(el, "xacro:name"), scope))
            if not name:
                raise _Refused("xacro:element with an empty name")
            renamed = _El(
                name,
                [a for a in el.attrs if a[0] != "xacro:name"],
                el.children,
                el.file,
                el.line,
                el.column,
            )
            return self.element(renamed, scope, macros)
        elif kind == "attribute":
            name = as_text(self.text(self.required(el, "name"), scope))
            value = self.text(self.required(el, "value"), scope)
            return [_SetAttribute(name, value)]
        elif kind == "call":
            name = as_text(self.text(self.required(el, "macro"), scope))
            attrs = [a for a in el.attrs if a[0] != "macro"]
            return self.call(
                _El("xacro:" + name, attrs, el.children, el.file, el.line, el.column), scope, macros
            )
        else:
            return self.call(el, scope, macros)
        return []

    def required(self, el: _El, name: str) -> str:
        value = el.get(name)
        if value is None:
            raise _Refused(f"<{el.tag}> needs the attribute {name!r}")
        return value

    def plain(self, el: _El, scope: _Scope, macros: _Macros) -> _El:
        self.elements += 1
        if self.elements > self.limits.elements:
            raise _Refused(f"the expanded document has over {self.limits.elements} elements")
        attrs = [
            (k, self.count_output(as_text(self.text(v, scope))))
            for k, v in el.attrs
            if not k.startswith(("xacro:", "xmlns"))
        ]
        children = []
        for node in self.nodes(el.children, scope, macros):
            if isinstance(node, _SetAttribute):
                attrs = [a for a in attrs if a[0] != node.name]
                attrs.append((node.name, self.count_output(as_text(node.value))))
            else:
                children.append(node)
        return _El(el.tag, attrs, children, el.file, el.line, el.column)

    def property(self, el: _El, scope: _Scope) -> None:
        name = as_text(self.text(self.required(el, "name"), scope))
        if not name.isidentifier() or name.startswith("__"):
            raise _Refused(f"the property name {name!r} is not a plain identifier")
        value, default = el.get("value"), el.get("default")
        remove = _boolean(self.text(el.get("remove") or "false", scope), "remove")
        if sum([value is not None, default is not None, remove]) > 1:
            raise _Refused(f"property {name}: value, default and remove exclude each other")
        if remove:
            s: _Scope | None = scope
            while s is not None:
                s.values.pop(name, None)
                s = s.parent
            return
        if default is not None:
            if scope.has(name):
                return
            value = default
        content: Any = value
        if value is None:
            name, content = "**" + name, el  # a block property
        lazy = _boolean(self.text(el.get("lazy_eval") or "true", scope), "lazy_eval")
        target, where = scope, el.get("scope")
        if where == "global":
            target, lazy = scope.top(), False
        elif where == "parent":
            if scope.parent is None:
                return
            target, lazy = scope.parent, False
            if not scope.namespace:
                while target.namespace and target.parent is not None:
                    target = target.parent
        if not lazy and isinstance(content, str):
            content = self.text(content, scope)
        self.set(target, name, content, lazy)

    def macro(self, el: _El, macros: _Macros) -> None:
        name = self.required(el, "name").removeprefix("xacro:")
        if name == "call" or "." in name:
            raise _Refused(f"the macro name {name!r} is not allowed")
        params, defaults = [], {}
        rest = el.get("params") or ""
        while rest.strip():
            match = _MACRO_PARAM.match(rest)
            if match:
                param, forward, default, rest = match.groups()
                defaults[param] = (param if forward else None, default or None)
            else:
                param, *more = rest.split(None, 1)
                rest = more[0] if more else ""
            params.append(param)
        macros.table[name] = _Macro(name, el, params, defaults)

    def call(self, el: _El, scope: _Scope, macros: _Macros) -> list[Any]:
        name = el.tag[6:]
        macro, macro_scope, found = self.resolve_macro(name, scope, macros)
        self.calls += 1
        if self.calls > self.limits.macro_calls:
            raise _Refused(f"over {self.limits.macro_calls} macro calls")
        if self.depth >= self.limits.macro_depth:
            raise _Refused(
                f"macros nested over {self.limits.macro_depth} deep "
                f"({' > '.join(self.macro_stack[-5:])} > ...)"
            )
        local = _Scope(macro_scope)
        params = list(macro.params)
        for key, value in el.attrs:
            if key.startswith("xmlns"):
                continue
            if key not in params:
                raise _Refused(
                    f"xacro:{name} has no parameter {key!r} (it takes "
                    f"{', '.join(macro.params) or 'none'})"
                )
            params.remove(key)
            self.set(local, key, self.text(value, scope), lazy=False)
        blocks = [n for n in self.nodes(el.children, scope, macros) if isinstance(n, _El)]
        for param in [p for p in params if p.startswith("*")]:
            if not blocks:
                raise _Refused(f"xacro:{name}: not enough blocks for {param}")
            params.remove(param)
            local.values[param] = blocks.pop(0)
        if blocks:
            raise _Refused(f"xacro:{name}: an unused block <{blocks[0].tag}>")
        for param in list(params):
            forward, default = macro.defaults.get(param, (None, None))
            if forward is None and default is None:
                continue
            params.remove(param)
            if forward is not None and scope.has(forward):
                value = self.get(scope, forward)
            elif default is not None:
                value = self.text(default, scope)
            else:
                raise _Refused(f"xacro:{name}: no property {forward!r} to forward (^)")
            self.set(local, param, value, lazy=False)
        if params:
            raise _Refused(f"xacro:{name}: parameters not given: {', '.join(params)}")
        self.depth += 1
        self.macro_stack.append(f"xacro:{name} ({el.file}:{el.line})")
        try:
            return self.nodes(macro.body.children, local, _Macros(found))
        finally:
            self.depth -= 1
            self.macro_stack.pop()

    def resolve_macro(
        self, name: str, scope: _Scope, macros: _Macros
    ) -> tuple[_Macro, _Scope, _Macros]:
        try:
            found = macros.find(name)
            if isinstance(found, _Macro):
                return found, scope, macros
        except KeyError:
            pass
        *spaces, last = name.split(".")
        table: Any = macros
        symbols: Any = scope
        try:
            for space in spaces:
                table = table.find(space)
                symbols = self.get(symbols, space)
            found = table.find(last)
        except (KeyError, _Refused):
            raise _Refused(f"unknown macro xacro:{name}") from None
        if not isinstance(found, _Macro) or not isinstance(symbols, _Scope):
            raise _Refused(f"unknown macro xacro:{name}")
        return found, symbols, table

    def include(self, el: _El, scope: _Scope, macros: _Macros) -> list[Any]:
        spec = as_text(self.text(self.required(el, "filename"), scope))
        optional = _boolean(el.get("optional") or "false", "optional")
        namespace = el.get("ns")
        if namespace is not None:
            namespace = as_text(self.text(namespace, scope))
            ns_macros = _Macros()
            macros.table[namespace] = ns_macros
            ns_scope = _Scope(scope, namespace=True)
            scope.values[namespace] = ns_scope
            macros, scope = ns_macros, ns_scope
        current = Path(el.file).parent
        if re.search(r"[*[?]", spec):
            pattern = spec if os.path.isabs(spec) else str(current / spec)
            names = sorted(glob.glob(pattern))[: self.limits.files]
        else:
            names = [spec]
        out: list[Any] = []
        for name in names:
            try:
                path = self.confined(name, "xacro:include of")
            except _Refused:
                if (
                    optional
                    and not (Path(name) if os.path.isabs(name) else current / name).exists()
                ):
                    continue
                raise
            wanted = Path(name) if os.path.isabs(name) else current / name
            root, namespaces = _parse(path, _shown(wanted), self.limits.file_bytes)
            self.namespaces.update(namespaces)
            out.extend(self.nodes(root.children, scope, macros))
        return out


_XML_INVALID = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ufffe\uffff]")


_GLOBALS["math"] = _MATH
_GLOBALS["python"] = _Names({k: v for k, v in _GLOBALS.items() if k in _PYTHON})


def _xacro_names(expander: _Expander) -> _Names:
    def note(*args: Any, **kwargs: Any) -> str:
        where = expander.where[-1] if expander.where else None
        expander.warnings.append(
            Issue(
                where.file if where else "",
                where.line if where else 0,
                where.column if where else 0,
                "xacro",
                " ".join(map(str, args)),
                "warning",
            )
        )
        return ""

    def fatal(*args: Any) -> str:
        raise _Refused("xacro.fatal: " + " ".join(map(str, args)))

    def abs_filename(name: str) -> str:
        current = Path(expander.where[-1].file).parent if expander.where else Path(".")
        return str(name) if os.path.isabs(name) else str(current / name)

    def arg(name: str) -> str:
        return expander.extension(f"arg {name}")

    functions: dict[str, Callable[..., Any]] = {
        "load_yaml": expander.load_yaml, "dotify": lambda d: _wrap(dict(d)), "arg": arg,
        "tokenize": _tokenize, "message": note, "warning": note, "error": note,
        "print_location": lambda *a, **k: "", "fatal": fatal, "abs_filename": abs_filename,
    }  # fmt: skip
    return _Names({name: _Function(f"xacro.{name}", f) for name, f in functions.items()})


def expand_xacro_file(
    path: Path,
    shown: str,
    package_paths: Sequence[Path],
    args: dict[str, str] | None = None,
    limits: XacroLimits | None = None,
) -> XacroExpansion:
    """A xacro file expanded to URDF, as data (module docstring).

    Parameters
    ----------
    path : Path
        The xacro file.
    shown : str
        Its name as the user typed it (for messages).
    package_paths : list of Path
        Folders holding ROS packages: ``$(find PKG)``, and the only places (with the xacro's
        own package) from which includes and YAML files are read.
    args : dict, optional
        ``$(arg NAME)`` values, and the values of ``$(env NAME)`` / ``$(optenv NAME)``.
    limits : XacroLimits, optional

    Returns
    -------
    XacroExpansion

    Raises
    ------
    UserError
        Anything refused or wrong, located at the file and line of its element.
    """
    limits = limits or XacroLimits()
    given = [Path(os.path.abspath(p)) for p in package_paths]  # $(find): as the user sees them
    roots = [Path(os.path.realpath(p)) for p in package_paths]  # what a file must resolve into
    own = Path(os.path.realpath(path))
    expander = _Expander(given, dict(args or {}), [*roots, _package_root(own)], limits)
    names = _xacro_names(expander)
    expander.builtins = {"xacro": names, **{k: names[k] for k in ("load_yaml", "dotify")}}
    expander.deadline = time.monotonic() + limits.seconds
    try:
        if own.stat().st_size > limits.file_bytes:
            raise _Refused(
                f"{shown} has {own.stat().st_size} bytes; rworld reads xacro files "
                f"up to {limits.file_bytes}"
            )
        root, expander.namespaces = _parse(own, shown, limits.file_bytes)
        root = _El(root.tag, root.attrs, root.children, shown, root.line, root.column)
        expanded = expander.element(root, _Scope(), _Macros())
    except _Refused as exc:
        raise _located(exc, shown) from None
    except RecursionError:
        raise _located(_Refused("the xacro nests too deeply"), shown) from None
    documents = [e for e in expanded if isinstance(e, _El)]
    if len(documents) != 1:
        raise UserError(f"{shown}: xacro: the root element expanded to nothing")
    document = documents[0]
    text, origins = _serialise(document, expander.namespaces)
    return XacroExpansion(text.encode("utf-8"), expander.warnings, origins)


def _located(exc: _Refused, shown: str) -> UserError:
    message, el = str(exc), exc.element
    if el is None:
        return UserError(f"{shown}: xacro: {message}")
    chain = "".join(f"; in {m}" for m in reversed(exc.macros[-3:]))
    issue = Issue(el.file, el.line, el.column, f"<{el.tag}>", f"xacro: {message}{chain}")
    return UserError(f"{shown}: xacro: {message}", [issue])

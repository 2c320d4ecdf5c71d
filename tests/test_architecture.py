"""The house rules, checked: one direction of imports between rooms, lint, format and types.

docs/architecture.md: ``model/`` at the bottom; ``schema/`` (files) and the calculation rooms
above it, side by side, never importing each other; ``api/`` above both; ``cli/`` on top.
"""

from __future__ import annotations

import ast
import subprocess
import sys

import pytest

from tests.conftest import REPO

PACKAGE = REPO / "rworld_cli"
CALCULATION = {
    "world",
    "kinematics",
    "dynamics",
    "motion",
    "sensing",
    "calibration",
    "planning",
    "simulate",
    "collision",
    "vision",
}
# shared utilities every room may use: they know no room
COMMON = {"errors", "units", "spatial", "codegen", "kernels", "cache", "fileio", "jsonvalues"}


def room_of(module: str) -> str:
    """'rworld_cli.schema.loader' -> 'schema'; top-level modules are their own room."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def is_module(package: str, name: str) -> bool:
    base = REPO.joinpath(*package.split("."))
    return (base / f"{name}.py").is_file() or (base / name).is_dir()


def imports() -> dict[str, set[str]]:
    """module -> the rworld_cli modules it imports (relative imports resolved)."""
    out = {}
    for path in PACKAGE.rglob("*.py"):
        rel = path.relative_to(REPO).with_suffix("")
        parts = list(rel.parts)
        module = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        package = module if parts[-1] == "__init__" else module.rsplit(".", 1)[0]
        found = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package.split(".")[: len(package.split(".")) - node.level + 1]
                    target = ".".join(base + ([node.module] if node.module else []))
                else:
                    target = node.module or ""
                if target.startswith("rworld_cli"):
                    found.add(target)
                    if node.module is None or target.count(".") == 0:  # from .. import spatial
                        found |= {
                            f"{target}.{a.name}" for a in node.names if is_module(target, a.name)
                        }
            elif isinstance(node, ast.Import):
                found |= {a.name for a in node.names if a.name.startswith("rworld_cli")}
        out[module] = found
    return out


ALLOWED = {
    "model": {"model"} | COMMON,
    # meshes, bounding boxes, winding numbers, distances: below collision and sensing both
    "geometry": {"geometry", "model"} | COMMON,
    "schema": {"schema", "model"} | COMMON,
    "world": {"world", "model"} | COMMON,
    **{room: CALCULATION | {"model", "geometry"} | COMMON for room in CALCULATION - {"world"}},
    # robot-language writers over resolved programs: text from plain data, no files
    "export": {"export", "model", "kinematics"} | COMMON,
    # the viewer page: text from the scene's bytes and panel data, its vendored assets
    "viewer": {"viewer"} | COMMON,
    "api": {"api", "schema", "model", "export", "viewer", "geometry"} | CALCULATION | COMMON,
    "cli": {"cli", "api", "errors", "units", ""},  # units: for showing arcsec
}


def test_rooms_import_in_one_direction():
    wrong = []
    for module, targets in imports().items():
        room = room_of(module)
        if room not in ALLOWED:
            continue
        for target in targets:
            if room_of(target) not in ALLOWED[room] and target != "rworld_cli":
                wrong.append(f"{module} imports {target}")
    assert not wrong, "\n".join(sorted(wrong))


def test_collision_does_not_import_sensing():
    """Collision and sensing are siblings: what both need is in ``geometry``."""
    for module, targets in imports().items():
        if room_of(module) == "collision":
            assert not {t for t in targets if room_of(t) == "sensing"}, module


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The import cycles among modules (strongly connected components of two or more)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in graph:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_no_import_cycles_between_modules():
    """No module imports one that (in any number of steps) imports it back, counting the
    imports inside functions too: a cycle makes the order of imports matter and hides which
    module is the lower one."""
    graph = {m: {t for t in ts if t != m} for m, ts in imports().items()}
    cycles = _cycles(graph)
    assert not cycles, cycles


def test_calculation_rooms_never_read_files():
    """The calculation rooms take plain data: no file format (schema/), no task (api/), no CLI."""
    for module, targets in imports().items():
        if room_of(module) in CALCULATION:
            assert not {t for t in targets if room_of(t) in ("schema", "api", "cli")}, module


def test_the_api_serves_exactly_the_names_it_shows_type_checkers():
    """``rworld_cli.api`` loads its names on first use (``_LAZY``); the imports under
    ``TYPE_CHECKING`` are what type checkers and readers see: the two say the same names from
    the same modules, and each name resolves."""
    import rworld_cli.api as api

    tree = ast.parse((PACKAGE / "api" / "__init__.py").read_text())
    guarded = next(
        node
        for node in tree.body
        if isinstance(node, ast.If) and getattr(node.test, "id", "") == "TYPE_CHECKING"
    )
    shown = {
        alias.asname or alias.name: ("." * node.level + (node.module or ""), alias.name)
        for node in guarded.body
        if isinstance(node, ast.ImportFrom)
        for alias in node.names
    }
    assert shown == api._LAZY
    for name in api.__all__:
        assert getattr(api, name) is not None, name


def test_world_knows_no_kinematics():
    for module, targets in imports().items():
        if room_of(module) == "world":
            assert not {t for t in targets if room_of(t) in ("kinematics", "dynamics", "schema")}, (
                module
            )


def run(*args):
    return subprocess.run([sys.executable, "-m", *args], cwd=REPO, capture_output=True, text=True)


@pytest.mark.parametrize(
    "tool",
    [
        ("ruff", "check", "rworld_cli", "tests", "bench", "docs"),
        ("ruff", "format", "--check", "rworld_cli", "tests", "bench", "docs"),
    ],
)
def test_lint_and_format_are_clean(tool):
    result = run(*tool)
    assert result.returncode == 0, result.stdout + result.stderr


def test_types_check_on_the_typed_rooms():
    """mypy on model/, spatial, kinematics, dynamics and api/ (pyproject.toml [tool.mypy])."""
    result = run("mypy")
    assert result.returncode == 0, result.stdout + result.stderr

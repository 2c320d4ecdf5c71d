"""URDF files: read a robot description with every problem located, and write one.

The reader keeps what rworld uses - links with their inertials and geometry, joints with their
origins, axes, limits and damping - as plain data in SI units, and reports each problem with
the file, the line and the column of the element that holds it.  It checks the tree (one root,
no link with two parents, joints naming existing links) but not what an import needs of it: the
chain, supported joint types on it, meshes that exist.  That is :mod:`.urdf_cell`'s work.

Why lxml: it is the XML library ROS tools and yourdfpy build on, and it keeps the source line
of every element (``sourceline``), which the standard library's ElementTree does not.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import spatial
from ..errors import Issue, UserError, did_you_mean
from ..fileio import atomic_write_text
from ..model.cell import Inertial
from .loader import INERTIA_ENTRIES, inertia_entries, inertia_matrix, inertia_problem
from .xacro import XacroExpansion, expand_xacro_file
from .xmlsafe import xml_parser
from .yamlio import comment_text

JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
MOVING = ("revolute", "continuous", "prismatic")
_XACRO_NS = "http://www.ros.org/wiki/xacro"
_DECIMAL = re.compile(r"[+-]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?", re.ASCII)
MAX_MAGNITUDE = 1e12  # as in cell files (schema/loader.py)
_XACRO_SUBSTITUTION = re.compile(r"\$\{|\$\((find|arg|env|optenv|eval|dirname|cwd)\b")


@dataclass(frozen=True)
class UrdfGeometry:
    """One ``<collision>`` or ``<visual>`` shape of a link.

    Attributes
    ----------
    kind : {"box", "cylinder", "sphere", "mesh"}
    T_link_geometry : ndarray, shape (4, 4)
        The element's ``<origin>`` [m].
    size : tuple of float
        Box edges (x, y, z); cylinder (radius, length); sphere (radius,) [m].
    mesh_file : Path or None
        The resolved mesh file (``None`` when it could not be found; see ``problem``).
    mesh_scale : ndarray, shape (3,)
    filename : str
        The mesh's ``filename`` attribute as written.
    problem : str
        Why the mesh cannot be used ('' when it can).
    line, column : int
    """

    kind: str
    T_link_geometry: np.ndarray
    size: tuple = ()
    mesh_file: Path | None = None
    mesh_scale: np.ndarray = field(default_factory=lambda: np.ones(3))
    filename: str = ""
    problem: str = ""
    line: int = 0
    column: int = 0


@dataclass(frozen=True)
class UrdfLink:
    """A ``<link>``: mass properties in the link frame (``None`` when it has no inertial)."""

    name: str
    inertial: Inertial | None = None
    collisions: tuple[UrdfGeometry, ...] = ()
    visuals: tuple[UrdfGeometry, ...] = ()
    line: int = 0
    column: int = 0

    @property
    def geometry(self) -> tuple[UrdfGeometry, ...]:
        """Collision shapes, or the visual ones for a link that has none."""
        return self.collisions or self.visuals


@dataclass(frozen=True)
class UrdfJoint:
    """A ``<joint>``, SI; limits are ``inf`` where the file gives none (or 0 for velocity and
    effort, which URDF writers use for "unknown")."""

    name: str
    type: str
    parent: str
    child: str
    origin: np.ndarray  # (4, 4) T_parent_joint
    axis: np.ndarray  # (3,) unit, joint frame
    lower: float = -np.inf
    upper: float = np.inf
    velocity: float = np.inf
    effort: float = np.inf
    damping: float = 0.0
    friction: float = 0.0
    mimic: bool = False
    line: int = 0
    column: int = 0


@dataclass(frozen=True)
class UrdfRobot:
    """A URDF robot: its links, its joints (by name, in file order) and its root link."""

    name: str
    file: str
    links: dict[str, UrdfLink]
    joints: dict[str, UrdfJoint]
    root: str
    comment: str = ""
    expansion: XacroExpansion | None = None  # a xacro's: where each element came from

    def located(self, issues: Sequence[Issue]) -> list[Issue]:
        """``issues`` about this robot moved from its xacro expansion to the vendor's file and
        line the element came from (as they are for a URDF file)."""
        if self.expansion is None:
            return list(issues)
        return [self.expansion.source_of(i, self.file) for i in issues]

    def child_joints(self, link: str) -> list[UrdfJoint]:
        return [j for j in self.joints.values() if j.parent == link]

    def parent_joint(self, link: str) -> UrdfJoint | None:
        for j in self.joints.values():
            if j.child == link:
                return j
        return None


# --------------------------------------------------------------------------- reading


class _Reader:
    def __init__(self, text: str, shown: str, base_dir: Path, package_paths: list[Path]):
        self.lines = text.splitlines()
        self.shown = shown
        self.base_dir = base_dir
        self.package_paths = package_paths
        self.issues: list[Issue] = []

    def where(self, el) -> tuple[int, int]:
        line = int(el.sourceline or 0)
        column = 1
        if 0 < line <= len(self.lines):
            at = self.lines[line - 1].find(f"<{el.tag}")
            column = at + 1 if at >= 0 else 1
        return line, column

    def err(self, el, location: str, message: str, severity: str = "error") -> None:
        line, column = self.where(el)
        self.issues.append(Issue(self.shown, line, column, location, message, severity))  # type: ignore[arg-type]

    def numbers(self, el, attr: str, count: int, location: str, default=None):
        raw = el.get(attr)
        if raw is None:
            if default is None:
                self.err(el, location, f"<{el.tag}> needs '{attr}'")
            return default
        tokens = raw.split()
        # XML's decimal numbers only: Python's float() also takes '1_0', Arabic-Indic digits
        # and 'infinity', which no URDF tool writes or reads the same
        if not all(_DECIMAL.fullmatch(t) for t in tokens):
            self.err(el, location, f'{attr}="{raw}" is not {count} decimal number(s)')
            return default
        values = [float(x) for x in tokens]
        if len(values) != count or not all(np.isfinite(values)):
            self.err(el, location, f'{attr}="{raw}" must be {count} finite number(s)')
            return default
        if any(abs(v) > MAX_MAGNITUDE for v in values):
            self.err(
                el,
                location,
                f'{attr}="{raw}": a magnitude above {MAX_MAGNITUDE:g} is a typo, not data',
            )
            return default
        return values

    def origin(self, parent, location: str) -> np.ndarray:
        el = parent.find("origin")
        if el is None:
            return np.eye(4)
        xyz = self.numbers(el, "xyz", 3, location + ".origin", default=[0.0, 0.0, 0.0])
        rpy = self.numbers(el, "rpy", 3, location + ".origin", default=[0.0, 0.0, 0.0])
        return spatial.make_transform(spatial.rpy_to_matrix(rpy), xyz)

    # ------------------------------------------------------------------ links
    def link(self, el) -> UrdfLink | None:
        name = el.get("name")
        if not name:
            self.err(el, "link", "<link> needs a 'name'")
            return None
        loc = f"link[{name}]"
        inertial = None
        iel = el.find("inertial")
        if iel is not None:
            inertial = self.inertial(iel, loc + ".inertial")
        collisions = tuple(
            g for c in el.findall("collision") if (g := self.geometry(c, loc)) is not None
        )
        visuals = tuple(g for c in el.findall("visual") if (g := self.geometry(c, loc)) is not None)
        line, column = self.where(el)
        return UrdfLink(name, inertial, collisions, visuals, line, column)

    def inertial(self, el, loc: str) -> Inertial | None:
        T = self.origin(el, loc)
        mel = el.find("mass")
        mass = 0.0
        if mel is None:
            self.err(el, loc, "<inertial> needs <mass value=...>")
        else:
            value = self.numbers(mel, "value", 1, loc + ".mass")  # required, as URDF says
            mass = value[0] if value else 0.0
            if mass < 0:
                self.err(mel, loc + ".mass", f"mass {mass:g} kg is negative")
        I = np.zeros((3, 3))
        iel = el.find("inertia")
        if iel is None:
            self.err(el, loc, "<inertial> needs <inertia ixx=... iyy=... izz=...>")
        else:
            entries = {key: self.numbers(iel, key, 1, loc + ".inertia") for key in INERTIA_ENTRIES}
            I = inertia_matrix({key: v[0] if v else 0.0 for key, v in entries.items()})
            problem = inertia_problem(I)
            if problem is not None:
                self.err(iel, loc + ".inertia", problem)
        R = T[:3, :3]  # the inertia is given in the rotated <origin> frame at the centre of mass
        return Inertial(float(mass), T[:3, 3].copy(), R @ I @ R.T)

    def geometry(self, el, loc: str) -> UrdfGeometry | None:
        loc = f"{loc}.{el.tag}"
        T = self.origin(el, loc)
        gel = el.find("geometry")
        shape = None if gel is None else next(iter(gel), None)
        while shape is not None and not isinstance(shape.tag, str):  # comments
            shape = shape.getnext()
        if shape is None:
            self.err(el, loc, f"<{el.tag}> needs a <geometry> with a box, cylinder, sphere or mesh")
            return None
        line, column = self.where(shape)
        kind = shape.tag
        if kind == "box":
            size = self.numbers(shape, "size", 3, loc + ".box")
            if size is None:
                return None
            if min(size) <= 0:
                self.err(shape, loc + ".box", f"box size {size} must be positive")
                return None
            return UrdfGeometry("box", T, tuple(size), line=line, column=column)
        if kind == "cylinder":
            r = self.numbers(shape, "radius", 1, loc + ".cylinder")
            h = self.numbers(shape, "length", 1, loc + ".cylinder")
            if r is None or h is None:
                return None
            if r[0] <= 0 or h[0] <= 0:
                self.err(shape, loc + ".cylinder", "cylinder radius and length must be positive")
                return None
            return UrdfGeometry("cylinder", T, (r[0], h[0]), line=line, column=column)
        if kind == "sphere":
            r = self.numbers(shape, "radius", 1, loc + ".sphere")
            if r is None:
                return None
            if r[0] <= 0:
                self.err(shape, loc + ".sphere", "sphere radius must be positive")
                return None
            return UrdfGeometry("sphere", T, (r[0],), line=line, column=column)
        if kind == "mesh":
            filename = shape.get("filename")
            if not filename:
                self.err(shape, loc + ".mesh", "<mesh> needs a 'filename'")
                return None
            scale = self.numbers(shape, "scale", 3, loc + ".mesh", default=[1.0, 1.0, 1.0])
            path, problem = self.resolve(filename)
            if problem.startswith("mesh file name"):  # malformed, said even where unused
                self.err(shape, loc + ".mesh", problem, "warning")
            return UrdfGeometry(
                "mesh",
                T,
                mesh_file=path,
                mesh_scale=np.array(scale, dtype=float),
                filename=filename,
                problem=problem,
                line=line,
                column=column,
            )
        self.err(shape, loc, f"unknown geometry <{kind}>; URDF has box, cylinder, sphere, mesh")
        return None

    def resolve(self, filename: str) -> tuple[Path | None, str]:
        """A mesh's file: ``package://PKG/REST`` under a package path, ``file://`` absolute, or
        relative to the URDF's folder."""
        if filename.startswith("package://"):
            rest = filename[len("package://") :]
            package, _, inner = rest.partition("/")
            if not package or not inner or ".." in Path(inner).parts:
                return None, (
                    f"mesh file name '{filename[:120]}': a package:// URL names a package and a "
                    "file inside it (package://PKG/meshes/link.stl), with no '..'"
                )
            tried = []
            for root in self.package_paths:
                for candidate in (root / package / inner, root / inner):
                    if candidate is root / inner and root.name != package:
                        continue
                    tried.append(candidate)
                    try:
                        if candidate.is_file():
                            return candidate, ""
                    except (OSError, ValueError):  # a name too long: no file has it
                        continue
            if not self.package_paths:
                return None, (
                    f"no such mesh file: '{filename}' names ROS package '{package}'; give the "
                    "folder that holds it with --package-path DIR"
                )
            return None, (
                f"no such mesh file: '{filename}' (package '{package}' looked for in "
                f"{', '.join(str(p) for p in self.package_paths)})"
            )
        path = Path(filename[len("file://") :]) if filename.startswith("file://") else None
        if path is None:
            path = self.base_dir / filename
        try:
            if path.is_file():
                return path, ""
        except (OSError, ValueError) as exc:  # a name too long, a NUL: no file has it
            return None, f"cannot use mesh file name '{filename[:80]}': {exc.__class__.__name__}"
        return None, f"no such mesh file: {path}"

    # ------------------------------------------------------------------ joints
    def joint(self, el) -> UrdfJoint | None:
        name = el.get("name")
        if not name:
            self.err(el, "joint", "<joint> needs a 'name'")
            return None
        loc = f"joint[{name}]"
        kind = el.get("type")
        if kind not in JOINT_TYPES:
            self.err(
                el,
                loc + ".type",
                f"unsupported joint type '{kind}'; URDF joints are {', '.join(JOINT_TYPES)}",
            )
            return None
        ends = {}
        for end in ("parent", "child"):
            e = el.find(end)
            if e is None or not e.get("link"):
                self.err(el, loc, f"<joint> needs <{end} link=...>")
                return None
            ends[end] = (e.get("link"), e)
        origin = self.origin(el, loc)
        axis = np.array([1.0, 0.0, 0.0])  # URDF's default
        ael = el.find("axis")
        if ael is not None:
            values = self.numbers(ael, "xyz", 3, loc + ".axis", default=[1.0, 0.0, 0.0])
            norm = float(np.linalg.norm(values))
            if norm < 1e-12:
                if kind in MOVING:
                    self.err(ael, loc + ".axis", "the joint axis is zero; it needs a direction")
                    return None
            else:
                axis = np.array(values) / norm
        lower, upper, velocity, effort = -np.inf, np.inf, np.inf, np.inf
        lel = el.find("limit")
        if lel is not None:
            if kind in ("revolute", "prismatic"):
                lo = self.numbers(lel, "lower", 1, loc + ".limit", default=[0.0])[0]
                hi = self.numbers(lel, "upper", 1, loc + ".limit", default=[0.0])[0]
                if not lo < hi:
                    self.err(lel, loc + ".limit", f"lower {lo:g} must be below upper {hi:g}")
                lower, upper = lo, hi
            v = self.numbers(lel, "velocity", 1, loc + ".limit", default=[0.0])[0]
            f = self.numbers(lel, "effort", 1, loc + ".limit", default=[0.0])[0]
            velocity = v if v > 0 else np.inf
            effort = f if f > 0 else np.inf
        elif kind in ("revolute", "prismatic"):
            self.err(el, loc, f"a {kind} joint needs <limit lower upper effort velocity>")
        damping = friction = 0.0
        del_ = el.find("dynamics")
        if del_ is not None:
            damping = self.numbers(del_, "damping", 1, loc + ".dynamics", default=[0.0])[0]
            friction = self.numbers(del_, "friction", 1, loc + ".dynamics", default=[0.0])[0]
        line, column = self.where(el)
        return UrdfJoint(
            name,
            kind,
            ends["parent"][0],
            ends["child"][0],
            origin,
            axis,
            lower,
            upper,
            velocity,
            effort,
            max(damping, 0.0),
            max(friction, 0.0),
            el.find("mimic") is not None,
            line,
            column,
        )


def expand_xacro(
    path: Path, shown: str, package_paths: Sequence[Path], args: dict[str, str] | None = None
) -> bytes:
    """A xacro file expanded to URDF as data, never as code (:mod:`.xacro`): ``$(find PKG)``
    from ``package_paths``, ``$(arg NAME)`` / ``$(env NAME)`` from ``args``, includes and YAML
    files only from the package paths and the xacro's own package.

    Raises
    ------
    UserError
        Anything refused or wrong, at the file and line of its element.
    """
    return expand_xacro_file(path, shown, package_paths, args).urdf


def read_urdf(
    path: str | Path,
    package_paths: Sequence[str | Path] | None = None,
    xacro_args: dict[str, str] | None = None,
) -> tuple[UrdfRobot, list[Issue]]:
    """Read a URDF file, or a xacro file expanded (:func:`expand_xacro`).

    Parameters
    ----------
    path : path
        The ``.urdf`` file, or a ``.xacro`` / ``.urdf.xacro`` file.
    package_paths : list of path, optional
        Folders that hold ROS packages, for ``package://`` mesh names and xacro's
        ``$(find PKG)``.
    xacro_args : dict, optional
        xacro's ``$(arg NAME)`` values.

    Returns
    -------
    robot : UrdfRobot
    warnings : list of Issue

    Raises
    ------
    UserError
        Every problem found, located (file:line:col), at once.
    """
    shown = str(path)
    path = Path(path)
    if not path.is_file():
        raise UserError(f"no such URDF file: {shown}")
    if not (path.suffix == ".xacro" or ".xacro" in path.suffixes):
        return _read_document(path.read_bytes(), shown, path, package_paths)
    packages = [Path(p) for p in package_paths or []]
    expansion = expand_xacro_file(path, shown, packages, xacro_args)
    shown = f"{shown} (as xacro expands it)"
    try:
        robot, issues = _read_document(expansion.urdf, shown, path, package_paths)
    except UserError as exc:  # each problem at the vendor's file and line
        raise UserError(str(exc), [expansion.source_of(i, shown) for i in exc.issues]) from None
    robot = dataclasses.replace(robot, expansion=expansion)
    return robot, robot.located(issues) + list(expansion.warnings)


def _read_document(
    data: bytes, shown: str, path: Path, package_paths: Sequence[str | Path] | None
) -> tuple[UrdfRobot, list[Issue]]:
    from lxml import etree

    try:  # the bytes as they are: the XML declaration's encoding holds (UTF-8 without one)
        root = etree.fromstring(data, xml_parser(remove_comments=False))
    except etree.XMLSyntaxError as exc:
        line, column = exc.position if exc.position else (0, 0)
        message = re.sub(r", line \d+, column \d+$", "", str(exc.msg))
        raise UserError(
            f"invalid: {shown}: malformed XML",
            [Issue(shown, line, max(column, 1), "(xml)", f"malformed XML: {message}")],
        ) from None
    encoding = root.getroottree().docinfo.encoding or "utf-8"
    text = data.decode(encoding, errors="replace")  # for columns in messages
    reader = _Reader(text, shown, path.parent, [Path(p) for p in package_paths or []])
    if root.tag != "robot":
        reader.err(root, "(root)", f"the root element is <{root.tag}>; a URDF file has <robot>")
        raise UserError(f"invalid: {shown}", reader.issues)
    # xacro is recognised on the parsed tree: elements in its namespace, or substitutions in
    # attribute values - never words in comments (xacro's output keeps them)
    macro = next(
        (
            el
            for el in root.iter()
            if isinstance(el.tag, str)
            and (
                el.tag.startswith("{" + _XACRO_NS + "}")
                or any(_XACRO_SUBSTITUTION.search(v) for v in el.attrib.values())
            )
        ),
        None,
    )
    if macro is not None:
        reader.err(
            macro,
            "(root)",
            "this file holds xacro macros (xacro:... elements or ${...} / $(...) expressions); "
            "name it FILE.xacro (or FILE.urdf.xacro) and rworld expands it",
        )
        raise UserError(f"invalid: {shown}", reader.issues)
    links: dict[str, UrdfLink] = {}
    for el in root.findall("link"):
        link = reader.link(el)
        if link is None:
            continue
        if link.name in links:
            reader.err(
                el,
                f"link[{link.name}]",
                f"a second link '{link.name}' (first at line {links[link.name].line})",
            )
            continue
        links[link.name] = link
    joints: dict[str, UrdfJoint] = {}
    parent_of: dict[str, UrdfJoint] = {}
    for el in root.findall("joint"):
        joint = reader.joint(el)
        if joint is None:
            continue
        loc = f"joint[{joint.name}]"
        if joint.name in joints:
            reader.err(
                el, loc, f"a second joint '{joint.name}' (first at line {joints[joint.name].line})"
            )
            continue
        bad = False
        for end in ("parent", "child"):
            link = getattr(joint, end)
            if link not in links:
                reader.err(
                    el.find(end),
                    f"{loc}.{end}",
                    f"joint '{joint.name}' names a missing link '{link}'"
                    + did_you_mean(link, links),
                )
                bad = True
        if bad:
            continue
        if joint.child in parent_of:
            first = parent_of[joint.child]
            reader.err(
                el,
                loc,
                f"link '{joint.child}' is the child of joint '{first.name}' (line {first.line}) "
                f"and of '{joint.name}': a closed loop; rworld takes kinematic trees",
            )
            continue
        joints[joint.name] = joint
        parent_of[joint.child] = joint
    roots = [name for name in links if name not in parent_of]
    if links and len(roots) != 1 and not reader.issues:
        if not roots:
            reader.err(root, "(root)", "every link has a parent joint: the joints form a loop")
        else:
            second = links[roots[1]]
            reader.issues.append(
                Issue(
                    shown,
                    second.line,
                    second.column,
                    f"link[{second.name}]",
                    f"the URDF has {len(roots)} roots ({', '.join(roots)}): link "
                    f"'{second.name}' is not the child of any joint; a robot is one tree",
                )
            )
    if not links:
        reader.err(root, "(root)", "the robot has no <link>")
    if not reader.issues:  # a loop that does not reach the root
        for name in links:
            seen = {name}
            node = name
            while node in parent_of:
                node = parent_of[node].parent
                if node in seen:
                    j = parent_of[name]
                    reader.issues.append(
                        Issue(
                            shown,
                            j.line,
                            j.column,
                            f"joint[{j.name}]",
                            f"link '{name}' is in a loop",
                        )
                    )
                    break
                seen.add(node)
    errors = [i for i in reader.issues if i.severity == "error"]
    if errors:
        raise UserError(f"invalid: {shown}: {len(errors)} error(s)", reader.issues)
    return UrdfRobot(root.get("name") or path.stem, shown, links, joints, roots[0]), reader.issues


# --------------------------------------------------------------------------- writing


def _fmt(values) -> str:
    return " ".join(repr(float(v)) if v != 0 else "0" for v in np.atleast_1d(values))


def urdf_text(robot: UrdfRobot, mesh_names: dict[Path, str] | None = None) -> str:
    """The robot as URDF text (links, then joints in chain order).

    ``mesh_names`` maps mesh files to the ``filename`` to write (default: the path as is).
    """
    from lxml import etree

    mesh_names = mesh_names or {}
    root = etree.Element("robot", name=robot.name)
    if robot.comment:
        text = comment_text(robot.comment).replace("--", "- -")  # XML: no control characters
        root.append(etree.Comment(" " + text + " "))

    def origin(parent, T: np.ndarray) -> None:
        if np.allclose(T, np.eye(4), atol=0.0, rtol=0.0):
            return
        etree.SubElement(
            parent,
            "origin",
            xyz=_fmt(T[:3, 3]),
            rpy=_fmt(spatial.matrix_to_rpy(T[:3, :3])),
        )

    def geometry(parent, tag: str, g: UrdfGeometry) -> None:
        el = etree.SubElement(parent, tag)
        origin(el, g.T_link_geometry)
        gel = etree.SubElement(el, "geometry")
        if g.kind == "box":
            etree.SubElement(gel, "box", size=_fmt(g.size))
        elif g.kind == "cylinder":
            etree.SubElement(gel, "cylinder", radius=_fmt(g.size[0]), length=_fmt(g.size[1]))
        elif g.kind == "sphere":
            etree.SubElement(gel, "sphere", radius=_fmt(g.size[0]))
        else:
            assert g.mesh_file is not None
            attrs = {"filename": mesh_names.get(g.mesh_file, str(g.mesh_file))}
            if not np.allclose(g.mesh_scale, 1.0):
                attrs["scale"] = _fmt(g.mesh_scale)
            etree.SubElement(gel, "mesh", **attrs)

    for link in robot.links.values():
        el = etree.SubElement(root, "link", name=link.name)
        if link.inertial is not None:
            iel = etree.SubElement(el, "inertial")
            origin(iel, spatial.make_transform(None, link.inertial.com))
            etree.SubElement(iel, "mass", value=_fmt(link.inertial.mass))
            I = link.inertial.inertia
            etree.SubElement(iel, "inertia", **{k: _fmt(v) for k, v in inertia_entries(I).items()})
        for g in link.visuals:
            geometry(el, "visual", g)
        for g in link.collisions:
            geometry(el, "collision", g)
    for joint in robot.joints.values():
        el = etree.SubElement(root, "joint", name=joint.name, type=joint.type)
        origin(el, joint.origin)
        etree.SubElement(el, "parent", link=joint.parent)
        etree.SubElement(el, "child", link=joint.child)
        if joint.type in MOVING:
            etree.SubElement(el, "axis", xyz=_fmt(joint.axis))
            limits = {}
            if joint.type != "continuous":
                limits["lower"], limits["upper"] = _fmt(joint.lower), _fmt(joint.upper)
            # URDF requires effort and velocity; 0 stands for "not given" (read back as unlimited)
            limits["effort"] = _fmt(joint.effort if np.isfinite(joint.effort) else 0.0)
            limits["velocity"] = _fmt(joint.velocity if np.isfinite(joint.velocity) else 0.0)
            etree.SubElement(el, "limit", **limits)
            if joint.damping or joint.friction:
                etree.SubElement(
                    el, "dynamics", damping=_fmt(joint.damping), friction=_fmt(joint.friction)
                )
    etree.indent(root, space="  ")
    return '<?xml version="1.0"?>\n' + etree.tostring(root, encoding="unicode") + "\n"


def write_urdf(
    path: str | Path, robot: UrdfRobot, mesh_names: dict[Path, str] | None = None
) -> None:
    """Write :func:`urdf_text` to ``path`` atomically."""
    atomic_write_text(path, urdf_text(robot, mesh_names))


@dataclass
class JointLimitsFile:
    """A vendor's joint-limits file as read (:func:`read_joint_limits`).

    Attributes
    ----------
    limits : dict
        Joint name -> the limits it states, SI: ``velocity`` [rad/s or m/s], ``acceleration``
        [rad/s^2 or m/s^2], ``effort`` [N m or N].
    marks : dict
        Joint name -> (file, line, column) of its name: where a warning about it points.
    form : str
        "ros" (``joint_limits:``, MoveIt's and ros2_control's), "lists" (a driver's
        ``joint_names`` with ``maximum_velocities`` ...), or "urdf" (each joint's ``limit:``,
        as franka_description gives them).
    """

    limits: dict[str, dict[str, float]]
    marks: dict[str, tuple[str, int, int]]
    form: str


# a driver's list-style limits file (ros2_kortex): each list beside joint_names, its kind
_LIST_KEYS = {
    "maximum_velocities": "velocity",
    "maximum_accelerations": "acceleration",
    "maximum_efforts": "effort",
}
_ARG = re.compile(r"\$\(arg\s+([A-Za-z_][A-Za-z0-9_]*)\)")


def read_joint_limits(path: str | Path, args: dict[str, str] | None = None) -> JointLimitsFile:
    """A vendor's joint-limits file as it ships, in any of three forms (:class:`JointLimitsFile`
    ``form``): ROS's ``joint_limits.yaml`` (MoveIt's, ros2_control's: each limit only where
    its ``has_*_limits`` is true; xacro's ``!degrees`` and ``!radians`` tags read, as UR's
    files use them), a driver's lists (``joint_names`` and ``maximum_velocities``,
    ``maximum_accelerations``, ``maximum_efforts``; ``$(arg NAME)`` in a name taken from
    ``args``, else empty: ros2_kortex's ``$(arg prefix)joint_1``), or each joint's ``limit:``
    mapping (franka_description's ``velocity`` and ``effort``).  Position limits are the
    URDF's; these files' are not read.

    Raises
    ------
    UserError
        Not one of the forms, a value that is not a finite number above 0, lists of other
        lengths than the names: every one located.
    """
    from .yamlio import read_yaml

    doc = read_yaml(path, str(path), ros_units=True)
    data = doc.data if isinstance(doc.data, dict) else {}
    out: dict[str, dict[str, float]] = {}
    marks: dict[str, tuple[str, int, int]] = {}
    issues: list[Issue] = []

    def number(value, where, what: str) -> float | None:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            issues.append(doc.issue(where, f"{what} is not a number"))
        elif not (math.isfinite(value) and value > 0):
            issues.append(doc.issue(where, f"{what} {value!r} is not a number above 0"))
        else:
            return float(value)
        return None

    def mark(name: str, where) -> None:
        line, column = doc.position(where, prefer="key")
        marks[name] = (doc.file, line, column)

    if isinstance(data.get("joint_limits"), dict):
        form = "ros"
        for joint, entry in data["joint_limits"].items():
            mark(str(joint), ("joint_limits", joint))
            if not isinstance(entry, dict):
                issues.append(doc.issue(("joint_limits", joint), "a joint's limits are a mapping"))
                continue
            values = {}
            for kind in ("velocity", "acceleration", "effort"):
                if entry.get(f"has_{kind}_limits") is not True:
                    continue
                where = ("joint_limits", joint, f"max_{kind}")
                if f"max_{kind}" not in entry:
                    issues.append(doc.issue(where, f"has_{kind}_limits is true: give max_{kind}"))
                    continue
                value = number(entry[f"max_{kind}"], where, f"max_{kind}")
                if value is not None:
                    values[kind] = value
            out[str(joint)] = values
    elif isinstance(data.get("joint_names"), list):
        form = "lists"
        names = []
        for k, raw in enumerate(data["joint_names"]):
            if not isinstance(raw, str):
                issues.append(doc.issue(("joint_names", k), "a joint name is text"))
                continue
            name = _ARG.sub(lambda m: (args or {}).get(m.group(1), ""), raw)
            names.append(name)
            mark(name, ("joint_names", k))
            out[name] = {}
        lists = [key for key in _LIST_KEYS if key in data]
        if not lists:
            issues.append(
                doc.issue(
                    ("joint_names",), "no limits beside the names: give " + ", ".join(_LIST_KEYS)
                )
            )
        for key in lists:
            values = data[key]
            if not isinstance(values, list) or len(values) != len(data["joint_names"]):
                count = len(values) if isinstance(values, list) else "not a list"
                issues.append(
                    doc.issue(
                        (key,),
                        f"{len(data['joint_names'])} joint_names, {count} {key}: one each",
                    )
                )
                continue
            for k, (name, value) in enumerate(zip(names, values, strict=False)):
                got = number(value, (key, k), f"{key}[{k}]")
                if got is not None:
                    out[name][_LIST_KEYS[key]] = got
    elif data and all(
        isinstance(v, dict) and isinstance(v.get("limit"), dict) for v in data.values()
    ):
        form = "urdf"
        for joint, entry in data.items():
            mark(str(joint), (joint,))
            values = {}
            for kind in ("velocity", "effort"):
                if kind in entry["limit"]:
                    value = number(entry["limit"][kind], (joint, "limit", kind), kind)
                    if value is not None:
                        values[kind] = value
            out[str(joint)] = values
    else:
        issue = doc.issue(
            (),
            "not a joint-limits file: expected 'joint_limits:' (ROS, MoveIt's or "
            "ros2_control's joint_limits.yaml), 'joint_names:' with 'maximum_velocities:' or "
            "'maximum_accelerations:' (a driver's lists), or each joint's 'limit:' mapping",
        )
        raise UserError(issue.format(), [issue])
    if issues:
        raise UserError(issues[0].format(), issues)
    return JointLimitsFile(out, marks, form)

"""Contact logs: what a robot controller recorded of the probe program's contacts - and, with
:data:`CAPTURE`, of a program's images (``capture:`` steps: the same reports, ``rworld capture
K/N`` and the camera for the feature, no ``dir``; KRL's ``RWV_K``; FANUC's and INFORM's from
``--capture-register``), for ``rworld captures --from-log``.

``rworld export program`` writes each ``probe:`` as a contact report in the controller's own
means (``docs/export.md``, contact reports); this module reads them back, one reader per
language, into :class:`LoggedContact` - the TCP pose the controller reported, in SI, in the
frame it reported it in, with the log's ``file:line`` - for ``rworld measure --from-log``.

The reports carry the same fields in every language::

    rworld contact K/N program=P step=S line=FILE:LINE feature=F tcp=T frame=base unit=mm
    dir=dx,dy,dz <the pose, in the language's form>

- ``urscript``: the controller's log (``textmsg``), any text around the line (time stamps,
  the log's own columns) ignored; the pose ``pose=p[x, y, z, rx, ry, rz]`` in m and the
  rotation vector [rad], the TCP in the base frame.
- ``rapid``: the file the program wrote (``HOME:rworld_<program>.log``), ``x= y= z=`` in mm
  and ``q=q1,q2,q3,q4`` (w, x, y, z), the search point in the work object.
- ``krl``: the program's ``.dat`` as the controller keeps it (its values saved as they are
  assigned): each ``DECL E6POS RWC_K={X, Y, Z, A, B, C, ...}`` (mm, deg,
  ``R = Rz(A) Ry(B) Rx(C)``) after its ``; rworld contact`` line, and ``RWC_COUNT``, the
  contacts recorded.
- ``drl``: the teach pendant's log (``tp_log``), any text around the lines ignored; a
  ``tp_log`` line holds 256 bytes, so one report is several lines, each beginning with its
  ``rworld contact K/N``: the fields, then ``posx=[x, y, z, a, b, c]`` as DRL prints
  ``get_current_posx`` (mm; ZYZ deg: ``R = Rz(a) Ry(b) Rz(c)``), the TCP in the moves'
  reference frame (``DR_BASE`` or the user frame).
- ``val3``: the controller's log (``logMsg``), any text around the lines ignored; a VAL3
  string holds 128 characters, so one report is several lines as DRL's, the point last:
  ``point=x,y,z,rx,ry,rz`` (``toString`` of ``here(tool, frame)``: mm; deg,
  ``R = Rx(rx) Ry(ry) Rz(rz)``), the TCP in ``world`` or the user frame.
- ``sunrise``: the application's log (``getLogger().info``), any text around the line
  ignored; one line a report, the pose ``pose=x,y,z,A,B,C`` (``getCurrentCartesianPosition``
  of the tool's motion frame in the targets' frame: mm; rad, ``R = Rz(A) Ry(B) Rx(C)``), each
  value as Java prints a double.
- ``fanuc``: ``POSREG.VA`` (the position registers as the controller lists them), register
  ``first + K - 1`` holding contact K (X, Y, Z mm; W, P, R deg: ``R = Rz(R) Ry(P) Rx(W)``);
  the fields are not in the controller's output: they are the exported program's.
- ``inform``: the controller's saved variable data (``VAR.DAT``) or a saved job that lists the
  position variables, in the job data format's form: ``///TOOL n``, ``///USER n``,
  ``///POSTYPE BASE|ROBOT|USER``, ``///RECTAN``, ``///RCONF ...`` set what the ``P<n>=X,Y,Z,
  Rx,Ry,Rz`` lines after them hold (mm; deg, ``R = Rz(Rz) Ry(Ry) Rx(Rx)``); variable
  ``first + K - 1`` holds contact K; its frame (``postype``, ``user``) and tool number
  (``tool_number``) are the fields, the others the exported program's.  A pulse-type variable
  (``///PULSE``) is refused: the export stores XYZ type.

Several runs in one log (a UR log, an appended RAPID file): the last complete run is taken
(a report ``1/N`` starts a run) and the earlier ones named in :attr:`ContactLog.notes`.

**A log cannot lie** (issue 58): every value is the whole token up to its delimiter (a space,
``,`` in a list, ``]`` or ``}``) and must be an ASCII decimal number as the controller writes
it, finite and of a plausible size - ``417,775`` (a decimal comma), ``0x10``, ``1_000``,
``nan``, ``1e999`` or Arabic-Indic digits are refused, never read as their first digits; a key
given twice is refused; a report's ``K/N`` must count from 1 to N; the file is read up to
:data:`MAX_LOG_BYTES`.  Every refusal names the file, line and column.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import spatial
from ..errors import Issue, UserError

LANGUAGES = ("urscript", "rapid", "krl", "fanuc", "inform", "drl", "val3", "sunrise")
MARK = "rworld contact"
NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?", re.ASCII)  # a whole token
MAX_LOG_BYTES = 64 * 1024 * 1024  # a UR log of months; larger: trim it to the run
MAX_VALUE = 1e7  # |coordinate| in mm (10 km) or |angle| in deg; a log value past it is a fault
MAX_CONTACTS = 100_000
UNITS = {"m": 1.0, "mm": 1e-3}
FIELDS = ("program", "step", "line", "feature", "tcp", "frame", "unit", "dir")


@dataclass(frozen=True)
class ReportKind:
    """What a kind of report starts with and holds: a probe's contact, or the robot's pose
    at a capture's image (``rworld capture K/N ... camera=C``, no ``dir``; KRL keeps it in
    ``RWV_K`` = ``$POS_ACT``)."""

    noun: str  # "contact" | "capture"
    mark: str
    fields: tuple[str, ...]
    krl: str  # the .dat's variables: RWC_K, RWC_COUNT


CONTACT = ReportKind("contact", MARK, FIELDS, "RWC")
CAPTURE = ReportKind(
    "capture",
    "rworld capture",
    ("program", "step", "line", "camera", "tcp", "frame", "unit"),
    "RWV",
)


@dataclass
class LoggedContact:
    """One contact as the controller reported it.

    Attributes
    ----------
    number, total : int
        The contact's number in its program (1-based) and how many the program records
        (``total`` 0: the log does not say).
    T_frame_tcp : ndarray, shape (4, 4)
        The TCP pose at the contact in the reported frame [m].
    fields : dict of str
        The report's fields (``program``, ``step``, ``line``, ``feature``, ``tcp``, ``frame``,
        ``unit``, ``dir``); empty where the controller's output has none (FANUC).
    where : str
        ``file:line`` in the log.
    """

    number: int
    total: int
    T_frame_tcp: np.ndarray
    fields: dict[str, str]
    where: str


@dataclass
class ContactLog:
    contacts: list[LoggedContact]
    notes: list[str] = field(default_factory=list)
    count: int | None = None  # KRL: the contacts the program says it recorded


def _fail(path: str, line: int, message: str, column: int = 1):
    issue = Issue(path, line, column, "contact log", message)
    raise UserError(issue.format(), [issue])


def _rotvec(v: np.ndarray) -> np.ndarray:
    angle = float(np.linalg.norm(v))
    return spatial.axis_rotation(v / angle, angle) if angle > 0 else np.eye(3)


def _euler_zyx(z: float, y: float, x: float) -> np.ndarray:
    """``R = Rz(z) Ry(y) Rx(x)`` of angles in degrees."""
    return spatial.rpy_to_matrix(np.radians([x, y, z]))


def _number(token: str, path: str, line: int, what: str) -> float:
    """One value: the whole token, an ASCII decimal number, finite, |x| <= MAX_VALUE."""
    token = token.strip()
    if not NUMBER.fullmatch(token):
        _fail(
            path,
            line,
            f"{what}: '{token[:40]}' is not a decimal number (as the controller "
            "writes one: digits, one '.', an exponent; no ',' '_' or hex)",
        )
    value = float(token)
    if not abs(value) <= MAX_VALUE:  # written so that NaN fails too
        _fail(path, line, f"{what}: {token[:40]} is not a plausible value (|x| <= {MAX_VALUE:g})")
    return value


def _numbers(text: str, count: int, path: str, line: int, what: str) -> np.ndarray:
    """``count`` values separated by commas, each a whole token (:func:`_number`)."""
    tokens = text.split(",")
    if len(tokens) != count:
        _fail(path, line, f"{what}: {count} numbers expected, found {len(tokens)} ('{text[:80]}')")
    return np.array([_number(t, path, line, f"{what}[{i}]") for i, t in enumerate(tokens)])


def _pairs(items: list[tuple[str, str]], path: str, line: int, what: str) -> dict[str, str]:
    """``key=value`` pairs as a dict, each key once."""
    out: dict[str, str] = {}
    for key, value in items:
        if key in out:
            _fail(path, line, f"{what}: '{key}' given twice")
        out[key] = value
    return out


def _head(text: str, path: str, line: int, kind: ReportKind) -> tuple[int, int, int, str]:
    """(where the mark starts, K, N, the rest after 'rworld contact K/N') of a report line."""
    mark = kind.mark
    start = text.index(mark)
    head = re.match(rf"{mark} (\d{{1,6}})/(\d{{1,6}})\s", text[start:], re.ASCII)
    if head is None:
        _fail(path, line, f"'{mark}' without its 'K/N' count", start + 1)
    k, total = int(head.group(1)), int(head.group(2))
    if not 1 <= k <= total <= MAX_CONTACTS:
        _fail(path, line, f"{kind.noun} {k}/{total}: a report counts 1 to N", start + 1)
    return start, k, total, text[start + head.end() :]


def _report(
    text: str, path: str, line: int, kind: ReportKind
) -> tuple[int, int, dict[str, str], str]:
    """(K, N, fields, the rest after the fields) of a report line from its mark on."""
    start, k, total, rest = _head(text, path, line, kind)
    fields = _pairs(re.findall(r"(\w+)=(\S+)", rest, re.ASCII), path, line, "report")
    missing = [f for f in kind.fields if f not in fields]
    if missing:
        _fail(path, line, f"{kind.noun} report without {', '.join(missing)}", start + 1)
    if fields["unit"] not in UNITS:
        _fail(
            path, line, f"unit={fields['unit']}: the reports give m or mm", text.index("unit=") + 1
        )
    return k, total, fields, rest


def _urscript(lines: list[str], path: str, kind: ReportKind) -> list[LoggedContact]:
    out = []
    for n, text in enumerate(lines, start=1):
        if kind.mark not in text:
            continue
        k, total, fields, rest = _report(text, path, n, kind)
        found = re.search(r"pose=\s*p\[([^\]]*)\]", rest)
        if found is None:
            _fail(path, n, f"a URScript {kind.noun} report ends in 'pose=p[x, y, z, rx, ry, rz]'")
        v = _numbers(found.group(1), 6, path, n, "the pose")
        scale = UNITS[fields["unit"]]
        if not np.linalg.norm(v[3:]) <= 2 * np.pi:
            _fail(
                path,
                n,
                f"the pose's rotation vector is {np.linalg.norm(v[3:]):.6g} rad long: no "
                "controller reports a turn of over 2 pi",
            )
        R = _rotvec(v[3:])
        out.append(
            LoggedContact(k, total, spatial.make_transform(R, v[:3] * scale), fields, f"{path}:{n}")
        )
    return out


def _sunrise(lines: list[str], path: str, kind: ReportKind) -> list[LoggedContact]:
    out = []
    for n, text in enumerate(lines, start=1):
        if kind.mark not in text:
            continue
        k, total, fields, rest = _report(text, path, n, kind)
        found = re.search(r"\bpose=(\S*)\s*$", rest)
        if found is None:
            _fail(path, n, f"a Sunrise {kind.noun} report ends in 'pose=x,y,z,A,B,C' (mm, rad)")
        v = _numbers(found.group(1), 6, path, n, "the pose")
        if not np.all(np.abs(v[3:]) <= 2 * np.pi):
            _fail(path, n, "the pose's A, B, C are radians: no controller reports over 2 pi")
        R = _euler_zyx(*np.degrees(v[3:]))
        out.append(
            LoggedContact(
                k,
                total,
                spatial.make_transform(R, v[:3] * UNITS[fields["unit"]]),
                fields,
                f"{path}:{n}",
            )
        )
    return out


def _zyz_degrees(v: np.ndarray) -> np.ndarray:
    """DRL's posx angles a, b, c [deg]: ``R = Rz(a) Ry(b) Rz(c)``."""
    z, y = np.array([0.0, 0.0, 1.0]), np.array([0.0, 1.0, 0.0])
    R = spatial.axis_rotation(z, np.radians(v[0])) @ spatial.axis_rotation(y, np.radians(v[1]))
    return R @ spatial.axis_rotation(z, np.radians(v[2]))


def _xyz_degrees(v: np.ndarray) -> np.ndarray:
    """VAL3's rx, ry, rz [deg]: ``R = Rx(rx) Ry(ry) Rz(rz)`` (about x, the new y, the new z)."""
    x, y, z = np.eye(3)
    R = spatial.axis_rotation(x, np.radians(v[0])) @ spatial.axis_rotation(y, np.radians(v[1]))
    return R @ spatial.axis_rotation(z, np.radians(v[2]))


# the reports split over several log lines: the pose's key, its text, and its angles
_SPLIT_POSES = {
    "drl": ("posx", r"\s*posx=\s*\[([^\]]*)\]\s*$", _zyz_degrees),
    "val3": ("point", r"\s*point=\s*(\S*)\s*$", _xyz_degrees),
}


def _split_reports(
    lines: list[str], path: str, language: str, kind: ReportKind
) -> list[LoggedContact]:
    """Reports whose fields take several log lines (DRL's tp_log, VAL3's logMsg), each
    beginning with its 'rworld contact K/N', the pose on the last: x, y, z (the report's
    unit) and three angles in degrees (:data:`_SPLIT_POSES`)."""
    key, pattern, rotation = _SPLIT_POSES[language]
    out = []
    gathered: dict[str, str] = {}  # the fields of the report under way
    at = None  # its (K, N) and first line
    for n, text in enumerate(lines, start=1):
        if kind.mark not in text:
            continue
        start, k, total, rest = _head(text, path, n, kind)
        if at is not None and at[:2] != (k, total):
            _fail(path, n, f"{kind.noun} {at[0]}/{at[1]} of line {at[2]} has no {key}= line")
        if at is None:
            at = (k, total, n)
        found = re.match(pattern, rest)
        if found is None:
            for name, value in re.findall(r"(\w+)=(\S+)", rest, re.ASCII):
                if name in gathered:
                    _fail(path, n, f"report: '{name}' given twice")
                gathered[name] = value
            continue
        missing = [f for f in kind.fields if f not in gathered]
        if missing:
            _fail(path, at[2], f"{kind.noun} report without {', '.join(missing)}", start + 1)
        if gathered["unit"] not in UNITS:
            _fail(path, at[2], f"unit={gathered['unit']}: the reports give m or mm")
        v = _numbers(found.group(1), 6, path, n, key)
        T = spatial.make_transform(rotation(v[3:]), v[:3] * UNITS[gathered["unit"]])
        out.append(LoggedContact(k, total, T, dict(gathered), f"{path}:{at[2]}"))
        gathered, at = {}, None
    if at is not None:
        _fail(path, at[2], f"{kind.noun} {at[0]}/{at[1]} has no {key}= line (the log ends first)")
    return out


def _rapid(lines: list[str], path: str, kind: ReportKind) -> list[LoggedContact]:
    out = []
    for n, text in enumerate(lines, start=1):
        if kind.mark not in text:
            continue
        k, total, fields, rest = _report(text, path, n, kind)
        # x=, y=, z= and q= are fields of the report like the others
        absent = [key for key in ("x", "y", "z", "q") if key not in fields]
        if absent:
            _fail(
                path, n, f"a RAPID {kind.noun} report ends in 'x= y= z=' (mm) and 'q=q1,q2,q3,q4'"
            )
        p = np.array([_number(fields[c], path, n, c) for c in "xyz"]) * UNITS[fields["unit"]]
        q = _numbers(fields["q"], 4, path, n, "q")
        norm = float(np.linalg.norm(q))
        if not np.isfinite(norm) or abs(norm - 1.0) > 1e-3:
            _fail(path, n, f"q={fields['q']} is not a unit quaternion (norm {norm:.6g})")
        T = spatial.make_transform(spatial.quat_to_matrix(q / norm), p)
        out.append(LoggedContact(k, total, T, fields, f"{path}:{n}"))
    return out


def _krl(lines: list[str], path: str, kind: ReportKind) -> tuple[list[LoggedContact], int | None]:
    out, count, report = [], None, None
    RWC = kind.krl  # the variables' prefix: RWC_K, RWC_COUNT (contacts), RWV_K (captures)
    for n, text in enumerate(lines, start=1):
        stripped = text.strip()
        if stripped.startswith(";") and kind.mark in stripped:
            report = (n, *_report(stripped, path, n, kind))
            continue
        found = re.match(rf"DECL\s+INT\s+{RWC}_COUNT\s*=\s*(\S+)\s*$", stripped, re.I | re.ASCII)
        if found:
            value = _number(found.group(1), path, n, f"{RWC}_COUNT")
            if not (value == int(value) and 0 <= value <= MAX_CONTACTS):
                _fail(path, n, f"{RWC}_COUNT = {found.group(1)}: not a count of {kind.noun}s")
            count = int(value)
            continue
        found = re.match(
            rf"DECL\s+E6POS\s+{RWC}_(\d{{1,6}})\s*=\s*\{{(.*)\}}\s*$", stripped, re.I | re.ASCII
        )
        if not found:
            continue
        k = int(found.group(1))
        if report is None or report[1] != k:
            _fail(path, n, f"{RWC}_{k} without its '; {kind.mark} {k}/N' line above it")
        items = []
        for item in found.group(2).split(","):
            parts = item.split()
            if len(parts) != 2 or not re.fullmatch(r"[A-Z]\d?", parts[0], re.I | re.ASCII):
                _fail(
                    path,
                    n,
                    f"{RWC}_{k}: '{item.strip()[:40]}' is not 'NAME value' (an E6POS component)",
                )
            items.append((parts[0].upper(), parts[1]))
        values = _pairs(items, path, n, f"{RWC}_{k}")
        absent = [c for c in "XYZABC" if c not in values]
        if absent:
            _fail(path, n, f"{RWC}_{k} has no {', '.join(absent)}")
        v = {c: _number(x, path, n, f"{RWC}_{k}.{c}") for c, x in values.items()}  # all of them
        _, _, total, fields, _ = report
        scale = UNITS[fields["unit"]]
        xyz = np.array([v["X"], v["Y"], v["Z"]]) * scale
        T = spatial.make_transform(_euler_zyx(v["A"], v["B"], v["C"]), xyz)
        out.append(LoggedContact(k, total, T, fields, f"{path}:{n}"))
        report = None
    return out, count


def _fanuc(lines: list[str], path: str, first: int) -> list[LoggedContact]:
    """POSREG.VA: ``[g,i] = 'comment'`` then ``Group: g  Config: ...``, ``X: Y: Z:`` and
    ``W: P: R:`` lines (mm, deg); a joint register (``J1 =``) or ``Uninitialized`` is no
    contact."""
    registers: dict[int, tuple[int, dict[str, float] | str]] = {}
    current: int | None = None
    for n, text in enumerate(lines, start=1):
        head = re.match(r"\s*\[(\d{1,6}),(\d{1,6})\]\s*=", text, re.ASCII)
        if head:
            if int(head.group(1)) != 1:
                current = None  # another motion group
                continue
            current = int(head.group(2))
            if current in registers:
                _fail(path, n, f"PR[{current}] listed twice")
            registers[current] = (n, "Uninitialized" if "Uninitialized" in text else {})
            continue
        if current is None or isinstance(registers[current][1], str):
            continue
        values = registers[current][1]
        assert isinstance(values, dict)
        if re.search(r"\bJ1\s*=", text):
            registers[current] = (registers[current][0], "joint")
            continue
        for key, value in re.findall(r"\b([XYZWPR])\s*:\s*(\S*)", text, re.ASCII):
            if key in values:
                _fail(path, n, f"PR[{current}]: '{key}' given twice")
            values[key] = _number(value, path, n, f"PR[{current}].{key}")
    if not registers:
        _fail(path, 1, "no position registers: POSREG.VA lists '[*POSREG*]$POSREG' entries")
    out = []
    k = 1
    while first + k - 1 in registers:
        n, values = registers[first + k - 1]
        if isinstance(values, str) or len(values) < 6:
            what = values if isinstance(values, str) else "incomplete"
            if k == 1 or what == "Uninitialized":
                break
            _fail(path, n, f"PR[{first + k - 1}] ({what}): a contact register holds X..R")
        assert isinstance(values, dict)
        if all(v == 0.0 for v in values.values()):  # cleared by the program, never reached
            break
        T = spatial.make_transform(
            _euler_zyx(values["R"], values["P"], values["W"]),
            np.array([values[c] for c in "XYZ"]) * 1e-3,
        )
        out.append(LoggedContact(k, 0, T, {}, f"{path}:{n}"))
        k += 1
    return out


def _inform(lines: list[str], path: str, first: int, count: int | None) -> list[LoggedContact]:
    """Position variables in the job data format: the ``///`` lines before a ``P<n>=`` line
    say its type, frame and tool.  ``count`` variables from ``first`` on are read (None: up to
    the first that is not an XYZ-type position); the first that reads zero ends them."""
    state: dict[str, str] = {}
    variables: dict[int, tuple[int, str, dict[str, str]]] = {}
    for n, text in enumerate(lines, start=1):
        stripped = text.strip()
        head = re.fullmatch(r"///(TOOL|USER|POSTYPE)\s+(\S+)", stripped, re.ASCII)
        if head:
            key, value = head.group(1).lower(), head.group(2).upper()
            if key != "postype" and not re.fullmatch(r"\d{1,3}", value, re.ASCII):
                _fail(path, n, f"///{head.group(1)} {head.group(2)}: not a frame number")
            state[key] = value
            if key == "postype" and value != "USER":
                state.pop("user", None)  # a user number belongs to USER positions
            continue
        if stripped in ("///RECTAN", "///PULSE", "///ANGLE"):
            state["kind"] = stripped[3:].lower()
            continue
        if re.fullmatch(r"//[A-Z]+.*", stripped, re.ASCII) and not stripped.startswith("///"):
            state = {}  # a new section (//POS, //INST, //VAR ...): its own types
            continue
        found = re.fullmatch(r"P(\d{3,5})\s*=(.*)", stripped, re.ASCII)
        if not found:
            continue
        number = int(found.group(1))
        if number in variables:
            _fail(path, n, f"P{number:03d} listed twice (line {variables[number][0]} first)")
        variables[number] = (n, found.group(2), dict(state))
    if not variables:
        _fail(path, 1, "no position variables: VAR.DAT lists them as 'P<n>=X,Y,Z,Rx,Ry,Rz'")
    out = []
    k = 1
    while first + k - 1 in variables and (count is None or k <= count):
        number = first + k - 1
        n, text, state = variables[number]
        name = f"P{number:03d}"
        if state.get("kind") != "rectan" or state.get("postype") not in ("BASE", "ROBOT", "USER"):
            if count is None and k > 1:
                break  # the user's own variables after the contacts
            _fail(
                path,
                n,
                f"{name} is a {state.get('postype', 'untyped').lower()} position"
                f"{' (joint pulses)' if state.get('kind') == 'pulse' else ''}: a contact is "
                "kept as an XYZ-type position (///POSTYPE BASE, ROBOT or USER with ///RECTAN)",
            )
        if state["postype"] == "USER" and "user" not in state:
            _fail(path, n, f"{name}: a USER position without its ///USER number above it")
        # X, Y, Z, Rx, Ry, Rz (a 7-axis arm's Re too: the export writes 6-axis jobs only)
        values = _numbers(text, 6, path, n, name)
        if not values.any():  # cleared by the program, never reached
            break
        rx, ry, rz = values[3:]
        T = spatial.make_transform(_euler_zyx(rz, ry, rx), values[:3] * 1e-3)
        fields = {"postype": state["postype"]}
        if "user" in state:
            fields["user"] = state["user"]
        if "tool" in state:
            fields["tool_number"] = state["tool"]
        out.append(LoggedContact(k, 0, T, fields, f"{path}:{n}"))
        k += 1
    return out


def read_contact_log(
    path: str,
    language: str,
    first_register: int = 101,
    count: int | None = None,
    kind: ReportKind = CONTACT,
) -> ContactLog:
    """The contacts a controller recorded, from its log or the file the program wrote.

    Parameters
    ----------
    language : {"urscript", "rapid", "krl", "fanuc", "inform", "drl", "val3", "sunrise"}
    first_register : int
        FANUC: the position register, INFORM: the position variable of contact 1 (``export
        program --contact-register``; a capture's: ``--capture-register``).
    count : int, optional
        INFORM: the contacts the program records (the variables after them are the user's);
        None: up to the first variable that is not an XYZ-type position.
    kind : ReportKind
        :data:`CONTACT` (a probe program's contacts) or :data:`CAPTURE` (the robot's pose at
        each image a program's ``capture:`` steps took).

    Raises
    ------
    UserError
        An unreadable file, a malformed report (at its ``file:line``), no contact at all.
    """
    if language not in LANGUAGES:
        raise UserError(f"--format: contact logs are read for {', '.join(LANGUAGES)}")
    try:
        with Path(path).open("rb") as stream:
            raw = stream.read(MAX_LOG_BYTES + 1)
        if len(raw) > MAX_LOG_BYTES:
            raise UserError(
                f"{path}: over {MAX_LOG_BYTES} bytes; give the part of the log with the "
                f"run (from its '{kind.mark} 1/N' report on)"
            )
    except OSError as exc:
        raise UserError(f"cannot read {path}: {exc.strerror or exc}") from None
    text = raw.decode("utf-8", errors="replace")
    lines = text.splitlines()
    count = None
    if language == "urscript":
        contacts = _urscript(lines, path, kind)
    elif language == "rapid":
        contacts = _rapid(lines, path, kind)
    elif language == "krl":
        contacts, count = _krl(lines, path, kind)
    elif language == "sunrise":
        contacts = _sunrise(lines, path, kind)
    elif language == "inform":
        contacts = _inform(lines, path, first_register, count)
    elif language in _SPLIT_POSES:
        contacts = _split_reports(lines, path, language, kind)
    else:
        contacts = _fanuc(lines, path, first_register)
    mark, noun = kind.mark, kind.noun
    if not contacts:
        where = {
            "urscript": f"no line holds '{mark}' (the program's textmsg reports)",
            "rapid": f"no line holds '{mark}' (the file HOME:rworld_<program>.log)",
            "krl": f"no 'DECL E6POS {kind.krl}_k' with its report line (the program's .dat file)",
            "fanuc": f"PR[{first_register}] holds no {noun}",
            "inform": f"P{first_register:03d} holds no {noun} (not listed, or zero: not reached)",
            "drl": f"no line holds '{mark}' (the teach pendant's log of the tp_log reports)",
            "val3": f"no line holds '{mark}' (the controller's log of the logMsg reports)",
            "sunrise": f"no line holds '{mark}' (the application's log: getLogger().info)",
        }[language]
        raise UserError(f"{path}: no {noun}: {where}")
    notes = []
    if language not in ("krl", "fanuc", "inform"):  # the last run: from the last 1/N on
        starts = [i for i, c in enumerate(contacts) if c.number == 1]
        if not starts or starts[0] != 0:
            first = contacts[0]
            _fail(
                path,
                int(first.where.rsplit(":", 1)[1]),
                f"{noun} {first.number}/{first.total} before any {noun} 1: the log starts in "
                "the middle of a run",
            )
        if len(starts) > 1:
            notes.append(
                f"{len(starts) - 1} earlier run(s) in {path} left out: the {noun}s from "
                f"{contacts[starts[-1]].where} on are read"
            )
            contacts = contacts[starts[-1] :]
    return ContactLog(contacts, notes, count)

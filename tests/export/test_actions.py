"""Every exported action equals the simulated one (issue 44): programs that walk every step kind -
frame and feature level: moves, grasp, release, place, tool changes, guarded moves, probes,
insert, follow, wait, sync - exported in every language; each gripper and tool-changer output,
load change and contact report of the simulation has its statement in the export, in order.

The statements are read with this file's own patterns (no code shared with the writers); the
expected sequence comes from the simulation's events."""

from __future__ import annotations

import functools
import re
import shutil

import pytest

from rworld_cli.api import export_program
from tests.conftest import WORKCELLS
from tests.export.controller_logs import reports_in

# each case's simulation made once a worker for the four languages (tests/conftest.py)
pytestmark = pytest.mark.usefixtures("simulation_once")

FEATURE_STEPS = """device: puma
units: {length: mm, angle: deg}
steps:
  - move: {to: ready}
  - move: {to: {feature: peg.head, standoff: 40}, tcp: gripper}
  - move: {to: {feature: peg.head}, tcp: gripper, motion: linear, speed: 0.2}
  - grasp: {object: peg, tcp: gripper}
  - place: {object: peg.foot, on: plate.top, at: [-20, 30]}
  - move: {to: {feature: peg.head, standoff: 40}, tcp: gripper}
  - move: {to: {feature: peg.head}, tcp: gripper, motion: linear, speed: 0.2}
  - grasp: {object: peg, tcp: gripper}
  - insert: {object: peg.tip, into: plate.hole1, depth: 10}
  - release: peg
  - move: {to: {feature: plate.hole1, standoff: 80}, tcp: gripper, motion: linear}
  - wait: {time: 0.5}
  - follow: {edge: bracket.top_edge, speed: 20mm/s, approach: 30, tcp: gripper}
  - probe: {feature: plate.top, points: 3}
  - move: {to: ready}
"""

TOOL_CHANGES = """device: robot
steps:
  - release: part
  - detach_tool: hand_b
  - attach_tool: {tool: hand_b, at: tool_plate}
  - move: {to: home}
  - wait: {time: 0.25}
"""


@pytest.fixture(scope="module")
def cases(tmp_path_factory):
    root = tmp_path_factory.mktemp("actions")
    probing = root / "probing"
    shutil.copytree(WORKCELLS / "probing", probing)
    (probing / "programs" / "every_kind.yaml").write_text(FEATURE_STEPS)
    fig9 = root / "paper_fig9"
    shutil.copytree(WORKCELLS / "paper_fig9", fig9)
    (fig9 / "programs" / "tools.yaml").write_text(TOOL_CHANGES)
    return [
        (probing, str(probing / "programs" / "every_kind.yaml"), "puma"),  # feature level
        (probing, "probe", "puma"),  # frame level: guarded moves and probe: records
        (WORKCELLS / "puma560", "pick_place", "puma"),  # grasp, release, frame level
        (fig9, "transfer", "robot"),  # place on a frame, syncs, a tool change
        (fig9, str(fig9 / "programs" / "tools.yaml"), "robot"),  # release, detach, attach
    ]


@functools.cache  # the same simulation for every language
def _expected(cell, run, device) -> tuple[list[tuple], set[int]]:
    """The simulated actions of ``device`` in order: gripper and tool-changer outputs, contact
    reports; and the indices after which the flange's load changes before a move follows."""
    from rworld_cli.api import export

    # export's own simulation of the run (simulation_once: the one each export then reads)
    loaded, result = export._simulate(str(cell), run, None, None)
    kinds = {
        "grasp": ("gripper", True),
        "release": ("gripper", False),
        "place": ("gripper", False),
        "attach_tool": ("changer", True),
        "detach_tool": ("changer", False),
    }
    actions, loads = [], set()
    events = [e for e in result.events if e.device == device]
    for k, e in enumerate(events):
        if e.kind in kinds:
            actions.append(kinds[e.kind])
            child = e.tree["child"]
            mass = sum(
                o.inertial.mass
                for name, o in loaded.cell.objects.items()
                if name == child or _inside(loaded.cell, name, child)
            )
            moves_after = any(
                x.kind == "move" and "already there" not in x.detail for x in events[k:]
            )
            if mass > 0 and moves_after and e.kind in ("grasp", "release", "place"):
                loads.add(len(actions) - 1)
        elif e.kind == "probe":
            actions.append(("contact", e.reading["feature"]))
    assert actions, "the case has actions to check"
    return actions, loads


def _inside(cell, name: str, ancestor: str) -> bool:
    """An object of the cell's initial tree inside ``ancestor`` (an assembly's parts)."""
    node = cell.frames[name].parent if name in cell.frames else None
    while node is not None:
        if node == ancestor:
            return True
        node = cell.frames[node].parent if node in cell.frames else None
    return False


def _statements(fmt: str, files: dict[str, str]) -> list[tuple]:
    """The export's actions in order, with ("move",) and ("load",) between them."""
    text = "\n".join(v for k, v in sorted(files.items()) if not k.endswith(".dat"))
    dat = next((v for k, v in files.items() if k.endswith(".dat")), "")
    features = iter(
        [re.search(r"feature=(\S+)", line).group(1) for line in reports_in(dat or text)]
    )
    out: list[tuple] = []
    said = ""  # FANUC: the comment lines since the last statement
    for line in text.splitlines():
        s = line.strip()
        if fmt == "urscript":
            if found := re.match(r"set_digital_out\((\d+), (True|False)\)", s):
                out.append(
                    ("gripper" if found.group(1) == "1" else "changer", found.group(2) == "True")
                )
            elif s.startswith("set_payload("):
                out.append(("load",))
            elif s.startswith('textmsg("rworld contact'):
                out.append(("contact", next(features)))
            elif re.match(r"move[jl]\(", s):
                out.append(("move",))
        elif fmt == "krl":
            if found := re.match(r"\$OUT\[(\d+)\] = (TRUE|FALSE)", s):
                out.append(
                    ("gripper" if found.group(1) == "1" else "changer", found.group(2) == "TRUE")
                )
            elif s.startswith("$LOAD = "):
                out.append(("load",))
            elif re.match(r"RWC_\d+ = \$POS_INT", s):
                out.append(("contact", next(features)))
            elif re.match(r"(PTP|LIN) ", s):
                out.append(("move",))
        elif fmt == "rapid":
            if found := re.match(r"SetDO do_(\d+), ([01]);", s):
                out.append(
                    ("gripper" if found.group(1) == "1" else "changer", found.group(2) == "1")
                )
            elif s.startswith("GripLoad "):
                out.append(("load",))
            elif s.startswith('Write rworld_log, "rworld contact'):
                out.append(("contact", next(features)))
            elif re.match(r"(MoveAbsJ|MoveL|SearchL) ", s):
                out.append(("move",))
        else:  # FANUC TP: "  12:  DO[1]=ON ;", comments wrapped at 32 characters
            body = re.sub(r"^\s*\d+:\s*", "", line).rstrip(" ;")
            if body.startswith("!"):
                said += " " + body[1:]
                continue
            if found := re.match(r"PR\[\d+\]=LPOS$", body):
                feature = re.search(r"contact \d+/\d+ (\S+): PR\[", said)
                out.append(("contact", feature.group(1)))
            said = ""
            if found := re.match(r"DO\[(\d+)\]=(ON|OFF)", body):
                out.append(
                    ("gripper" if found.group(1) == "1" else "changer", found.group(2) == "ON")
                )
            elif body == "PAYLOAD[1]":
                out.append(("load",))
            elif re.match(r"[JL] P\[", body):
                out.append(("move",))
    return out


@pytest.mark.parametrize("fmt", ["urscript", "krl", "rapid", "fanuc"])
def test_every_simulated_action_has_its_statement_in_order(cases, tmp_path, fmt):
    for k, (cell, run, device) in enumerate(cases):
        out = tmp_path / f"case{k}"
        export_program(str(cell), run, fmt, str(out), device=device)
        files = {p.name: p.read_text() for p in out.iterdir()}
        statements = _statements(fmt, files)
        actions = [s for s in statements if s[0] not in ("move", "load")]
        expected, loads = _expected(cell, run, device)
        assert actions == expected, (cell.name, run, fmt)
        # a load change (a part of some mass grasped or let go) is written before the next move
        positions = [i for i, s in enumerate(statements) if s[0] not in ("move", "load")]
        for n in loads:
            following = statements[positions[n] + 1 :]
            before_move = following[
                : next((i for i, s in enumerate(following) if s == ("move",)), None)
            ]
            assert ("load",) in before_move, (cell.name, run, fmt, expected[n])

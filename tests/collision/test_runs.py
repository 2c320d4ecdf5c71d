"""Collision and clearance along runs: the guarantee between samples, allowed contacts, output.

A slider cell is the closed-form truth: a 40 mm cube on a prismatic joint travels 1 m along x
at 2 m/s, sampled every 100 ms (20 cm between samples), past a 2 mm plate standing across its
path.  The cube passes through the plate exactly when their y ranges overlap.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from rworld_cli.api import simulate_run
from rworld_cli.errors import UserError
from tests.conftest import WORKCELLS

CELL = """\
name: slider
units: {{length: mm, angle: deg}}
pose_files: [poses.yaml]
devices:
  - name: slider
    dof: 1
    dh: standard
    joints:
      - name: x
        type: prismatic
        limits: {{position: [0, 1000], velocity: 2000, acceleration: {acc}, effort: 1000}}
    links:
      - {{name: carriage, mass: 1, geometry: {{box: [40, 40, 40]}}}}
    tcps: [{{name: tip}}]
    home: [0]
    positions: {{far: [1000]}}
objects:
  - name: plate
    mass: 1
    geometry: {{box: [2, 100, 100]}}
{extra}
"""
POSES = """\
units: {{length: mm, angle: deg}}
poses:
  slider: {{xyz: [0, 0, 0], rpy: [0, 90, 0]}}
  slider.tip: {{xyz: [0, 0, 0]}}
  plate: {{xyz: [{x}, {y}, 0]}}
"""
PROGRAM = """\
device: slider
steps:
  - move: {{to: far{touch}}}
"""
RUN = """\
programs: [program.yaml]
dt: {dt}
{extra}
"""


def make_cell(
    root: Path,
    plate_x=500.0,
    plate_y=0.0,
    dt=0.1,
    acc=1e6,
    cell_extra="",
    run_extra="",
    touch="",
) -> Path:
    root.mkdir(parents=True, exist_ok=True)
    (root / "cell.yaml").write_text(CELL.format(acc=acc, extra=cell_extra))
    (root / "poses.yaml").write_text(POSES.format(x=plate_x, y=plate_y))
    (root / "program.yaml").write_text(PROGRAM.format(touch=touch))
    (root / "run.yaml").write_text(RUN.format(dt=dt, extra=run_extra))
    return root


def contacts(root: Path, **kw):
    _, result = simulate_run(str(root), str(root / "run.yaml"), **kw)
    return result, result.collisions.contacts


def test_a_thin_plate_crossed_between_samples_is_caught(tmp_path):
    root = make_cell(tmp_path / "cell", plate_x=550.0)  # samples at x = 0, 200, 400, 600 ...
    result, found = contacts(root)
    assert not result.ok
    [c] = found
    assert {c.contact.a, c.contact.b} == {"plate", "slider.carriage"}
    assert c.contact.collision and c.contact.between_samples
    # the contact instant is found on the exact motion: the cube's faces span x +- 20 mm
    x = np.interp(c.contact.t_worst, result.times, result.devices["slider"].q[:, 0])
    assert 550 - 21 - 1 <= 1000 * x <= 550 + 21 + 1
    assert c.steps[0].where.endswith("program.yaml:3")


def test_seeded_crossings_match_the_closed_form_truth(tmp_path):
    """Random plate positions, some just beside the path: a contact deeper than the tolerance
    is reported exactly when the cube's and the plate's y ranges overlap by more than it."""
    rng = np.random.default_rng(11)
    for k in range(12):
        x = rng.uniform(100, 900)
        gap = rng.choice([-30.0, -5.0, -1.5, 1.5, 4.0, 20.0])  # y gap between them [mm]
        y = 20 + 50 + gap  # cube half 20, plate half 50
        root = make_cell(tmp_path / f"c{k}", plate_x=x, plate_y=y)
        result, found = contacts(root)
        truth = gap < -1.0  # penetrates deeper than the 1 mm tolerance
        assert bool(found) == truth, (x, gap, [c.describe() for c in found])
        if truth:
            assert found[0].contact.depth > 0.001
        elif gap > 0:
            # the clearance column holds the true distance at every sample within 50 mm
            column = result.collisions.clearance["slider"]
            xc = 1000 * result.devices["slider"].q[:, 0]
            true = np.hypot(np.maximum(np.abs(xc - x) - 21, 0), gap) / 1000
            near = np.isfinite(column)
            assert np.array_equal(near, true < 0.05)
            assert np.max(np.abs(column[near] - true[near]), initial=0) < 1e-9


def test_clearance_required_and_violated(tmp_path):
    root = make_cell(tmp_path / "cell", plate_x=500, plate_y=20 + 50 + 8)  # 8 mm beside
    result, found = contacts(root)
    assert result.ok and not found
    result, found = contacts(root, clearance="10mm")
    [c] = found
    assert not c.contact.collision and c.contact.distance == pytest.approx(0.008, abs=1e-9)
    assert "8.0 mm apart" in c.describe()
    # the run file may require it too
    root = make_cell(tmp_path / "cell2", plate_y=78, run_extra="clearance: 10mm")
    assert len(contacts(root)[1]) == 1


def test_allowed_contacts_and_touch_steps(tmp_path):
    allowed = (
        "allowed_contacts:\n"
        "  - {between: [slider, plate], reason: the carriage pushes the plate over}\n"
    )
    root = make_cell(tmp_path / "a", plate_x=550, cell_extra=allowed)
    assert contacts(root)[1] == []
    # touching allows contact, not depth: the cube goes up to 21 mm deep into the 2 mm plate
    root = make_cell(tmp_path / "b", plate_x=550, touch=", touch: [plate]")
    [c] = contacts(root)[1]
    assert c.contact.collision and 0.015 < c.contact.depth <= 0.021 + 1e-9
    root = make_cell(tmp_path / "c", plate_x=550, touch=", touch: {plate: 25mm}")
    assert contacts(root)[1] == []
    # a bare depth takes the program's length unit, which it must state
    root = make_cell(tmp_path / "d", plate_x=550, touch=", touch: {plate: 15}")
    with pytest.raises(UserError) as refused:
        contacts(root)
    assert "program.yaml:3:" in "\n".join(refused.value.lines())
    assert "needs the file's units.length" in "\n".join(refused.value.lines())
    (root / "program.yaml").write_text(
        (root / "program.yaml").read_text() + "units: {length: mm, angle: deg}\n"
    )
    assert contacts(root)[1][0].contact.depth > 0.015


def _puma_with(tmp_path, drop_z: str | None = None, drop_program=False) -> Path:
    cell = tmp_path / "puma560"
    shutil.copytree(WORKCELLS / "puma560", cell)
    if drop_z is not None:
        poses = cell / "poses.yaml"
        poses.write_text(
            poses.read_text().replace("table.drop: {xyz: [-0.1, -0.3, 0.05]", drop_z, 1)
        )
    if drop_program:  # no linear approach: the grasp happens 100 mm above the workpiece
        program = cell / "programs" / "pick_place.yaml"
        lines = program.read_text().splitlines(keepends=True)
        program.write_text("".join(x for x in lines if "speed: 0.5, touch: [workpiece]" not in x))
    return cell


@pytest.mark.parametrize("depth", [20, 50])
def test_a_part_set_down_into_the_table_fails_with_its_depth(cli, tmp_path, depth):
    """The issue's case: table.drop lower by 20 or 50 mm, and the set-down move is a touch."""
    z = 0.05 - depth / 1000
    cell = _puma_with(tmp_path, f"table.drop: {{xyz: [-0.1, -0.3, {z:.3f}]")
    out = cli(["check", str(cell), "pick_place"])
    assert out.exit_code == 1, out.output
    assert "collision: table with workpiece" in out.output
    assert (
        f"depth {depth}.0 mm" in out.output
        and "puma step 6 (move to table.drop (linear))" in out.output
    )
    assert f"place: workpiece is {depth}.0 mm deep inside table" in out.output
    assert "pick_place.yaml:15" in out.output
    data = json.loads(cli(["check", str(cell), "pick_place", "--json"]).stdout)
    [place] = data["collisions"]["handling"]
    assert place["kind"] == "place" and place["depth"] == pytest.approx(depth / 1000, abs=1e-6)


def test_a_part_placed_in_the_air_and_a_grasp_from_afar_fail(cli, tmp_path):
    cell = _puma_with(tmp_path, "table.drop: {xyz: [-0.1, -0.3, 0.35]")
    out = cli(["check", str(cell), "pick_place"])
    assert out.exit_code == 1
    assert "place: workpiece floats 300.0 mm away from table" in out.output
    cell = _puma_with(tmp_path / "b", drop_program=True)
    out = cli(["check", str(cell), "pick_place"])
    assert out.exit_code == 1
    assert "grasp: workpiece is 100.0 mm from the TCP puma.probe" in out.output
    assert "puma step 3 (grasp workpiece)" in out.output


def test_a_long_contact_is_one_span_when_the_run_ends_just_after_a_tick(tmp_path):
    """The merge gap is the clock's step, not its smallest difference (the end instant)."""
    root = make_cell(tmp_path / "probe", plate_x=1000)
    (root / "program.yaml").write_text(
        "device: slider\nsteps:\n  - move: {to: far}\n  - wait: {time: 1}\n"
    )
    end = simulate_run(str(root), str(root / "run.yaml"), collisions=False)[1].cycle_time
    dt = end / 40.0001  # the last tick 2.5e-6 of the run before its end
    root = make_cell(tmp_path / "cell", plate_x=1000, dt=f"{dt!r}")
    (root / "program.yaml").write_text(
        "device: slider\nsteps:\n  - move: {to: far}\n  - wait: {time: 1}\n"
    )
    result, found = contacts(root)
    assert result.times[-1] - result.times[-2] < 1e-5
    [c] = found
    assert c.contact.t_end == pytest.approx(end) and c.contact.t_end - c.contact.t_start > 0.9


def test_bad_names_and_lengths_are_located(cli, tmp_path):
    root = make_cell(
        tmp_path / "a",
        cell_extra="allowed_contacts:\n  - {between: [slider, plait], reason: x}\n",
    )
    out = cli(["check", str(root), str(root / "run.yaml")])
    assert out.exit_code == 2
    assert (
        "cell.yaml:22:24:" in out.output and "unknown object, device or link 'plait'" in out.output
    )
    assert "did you mean 'plate'" in out.output
    root = make_cell(tmp_path / "b", touch=", touch: [slider.carrige]")
    out = cli(["check", str(root), str(root / "run.yaml")])
    assert (
        out.exit_code == 2 and "program.yaml:3:" in out.output and "slider.carriage" in out.output
    )
    root = make_cell(tmp_path / "c", run_extra="clearance: -2mm")
    out = cli(["check", str(root), str(root / "run.yaml")])
    assert out.exit_code == 2 and "run.yaml:3:" in out.output and "at least 0" in out.output
    out = cli(["check", str(root.parent / "a"), str(root / "run.yaml"), "--clearance", "ten"])
    assert out.exit_code == 2


def test_the_issue_case_drives_through_the_table(cli, tmp_path):
    """The approach 150 mm below the grasp frame, through the workpiece and the table."""
    cell = tmp_path / "puma560"
    shutil.copytree(WORKCELLS / "puma560", cell)
    program = cell / "programs" / "pick_place.yaml"
    text = program.read_text()
    program.write_text(
        text.replace(
            "offset: {xyz: [0, 0, -100]}}   # 100 mm above", "offset: {xyz: [0, 0, 150]}}  #", 1
        )
    )
    out = cli(["check", str(cell), "pick_place"])
    assert out.exit_code == 1
    assert "collision: table with puma.link6" in out.output
    assert "puma step 2 (move to workpiece.grasp)" in out.output
    assert "pick_place.yaml:10" in out.output
    data = json.loads(cli(["check", str(cell), "pick_place", "--json"]).stdout)
    assert data["ok"] is False and data["collisions"]["collisions"]
    first = data["collisions"]["collisions"][0]
    assert first["steps"][0]["where"].endswith("pick_place.yaml:10") and first["depth"] > 0.05
    picture = tmp_path / "first.png"
    out = cli(["render", str(cell), "--run", "pick_place", "-o", str(picture)])
    assert out.exit_code == 0 and picture.read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize(
    "cell, run",
    [("puma560", "pick_place"), ("puma560", "probe"), ("paper_fig9", "transfer")],
)
def test_shipped_programs_are_collision_free(cli, cell, run):
    out = cli(["check", str(WORKCELLS / cell), run])
    assert out.exit_code == 0, out.output
    assert "no collisions" in out.output


def test_simulate_writes_collisions_and_clearance_columns(cli, tmp_path):
    root = make_cell(tmp_path / "cell", plate_x=550)
    out = cli(["simulate", str(root), str(root / "run.yaml"), "-o", str(tmp_path / "out")])
    assert out.exit_code == 0  # simulate reports; check is the gate
    report = json.loads((tmp_path / "out" / "collisions.json").read_text())
    assert report["collisions"][0]["between_samples"] is True
    assert report["tolerance"] == 0.001
    header = (tmp_path / "out" / "timeline_slider.csv").read_text().splitlines()[0]
    assert header.endswith(",clearance")
    nothing = cli(["render", str(WORKCELLS / "puma560"), "--run", "pick_place", "-o", "x.png"])
    assert nothing.exit_code == 2 and "no collision or clearance violation" in nothing.output


def test_clearance_command(cli):
    out = cli(["clearance", str(WORKCELLS / "puma560"), "--json"])
    assert out.exit_code == 0
    data = json.loads(out.stdout)
    pairs = data["pairs"]
    assert [p["distance"] for p in pairs] == sorted(p["distance"] for p in pairs)
    adjacent = {(p["a"], p["b"]): p["allowed"] for p in pairs}
    assert adjacent[("puma", "puma.link1")] == "adjacent links of puma"
    assert adjacent[("table", "workpiece")] == "workpiece rests on table"
    base_link2 = next(p for p in pairs if (p["a"], p["b"]) == ("puma", "puma.link2"))
    assert base_link2["distance"] == pytest.approx(0.010, abs=1e-9)  # 120 mm arm, 110 mm base
    # a state where the arm is in the table fails
    low = cli(
        ["clearance", str(WORKCELLS / "puma560"), "--joints", "puma=0.56,0.3,-2.91,0,-0.53,-3.1"]
    )
    assert low.exit_code == 1 and "overlap" in low.output
    need = cli(["clearance", str(WORKCELLS / "puma560"), "--clearance", "15mm"])
    assert need.exit_code == 1


def test_nearest_pairs_per_step_with_closest_points(tmp_path):
    root = make_cell(tmp_path / "cell", plate_x=410, plate_y=20 + 50 + 8)  # 8 mm beside
    result, _ = contacts(root)
    [step] = result.collisions.nearest_steps
    assert step["device"] == "slider" and step["where"].endswith("program.yaml:3")
    [pair] = step["pairs"]
    assert {pair["a"], pair["b"]} == {"plate", "slider.carriage"}
    # the closest sample: the cube at x = 400 mm, beside the plate, 8 mm away in y
    x = 1000 * np.interp(pair["t"], result.times, result.devices["slider"].q[:, 0])
    want = np.hypot(max(abs(x - 410) - 21, 0), 8) / 1000
    assert want == pytest.approx(0.008)
    assert pair["distance"] == pytest.approx(want, abs=1e-9)
    gap = np.linalg.norm(np.subtract(pair["point_a"], pair["point_b"]))
    assert gap == pytest.approx(pair["distance"], abs=1e-9)


def test_the_shipped_colliding_example_fails(cli):
    out = cli(["check", str(WORKCELLS / "puma560"), "through_table"])
    assert out.exit_code == 1
    assert "collision: table with puma.link6" in out.output
    assert "through_table.yaml:11" in out.output


def test_touch_steps_let_the_example_keep_a_clearance(cli):
    """pick_place marks the moves where touching is the point; everything else keeps 5 mm."""
    out = cli(["check", str(WORKCELLS / "puma560"), "pick_place", "--clearance", "5mm"])
    assert out.exit_code == 0, out.output

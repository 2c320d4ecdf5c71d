"""Programs on the example cells: step types, parallel timing, limits, errors, numbers vs
programs.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from rworld_cli.dynamics import DeviceDynamics
from rworld_cli.errors import UserError
from rworld_cli.schema.programs import load_run
from rworld_cli.simulate.engine import simulate
from tests.conftest import WORKCELLS


@pytest.fixture(scope="module")
def fig9(example_run):
    return example_run("paper_fig9", "transfer")[1]


@pytest.fixture(scope="module")
def puma(example_run):
    return example_run("puma560", "pick_place")[1]


def copy_cell(tmp_path: Path, name: str) -> Path:
    target = tmp_path / name
    shutil.copytree(WORKCELLS / name, target)
    return target


def write_run(cell: Path, programs: dict[str, str], name: str = "test") -> Path:
    for fname, text in programs.items():
        (cell / "programs" / fname).write_text(text)
    run = cell / "runs" / f"{name}.yaml"
    run.write_text(
        "programs: [" + ", ".join(f"../programs/{f}" for f in programs) + "]\ndt: 0.01\n"
    )
    return run


def event(result, device, kind, detail_part=""):
    return next(
        e
        for e in result.events
        if e.device == device and e.kind == kind and detail_part in e.detail
    )


# ---------------------------------------------------------------- parallel execution


def test_devices_run_in_parallel_and_end_at_different_times(fig9):
    ends = {d: tl.cycle_time for d, tl in fig9.devices.items()}
    assert ends["hand_a"] < ends["hand_b"] < ends["robot"] < ends["conveyor"]
    assert fig9.cycle_time == ends["conveyor"]
    # the hands move while the robot holds still between its syncs
    open_a = event(fig9, "hand_a", "move", "open")
    sync_robot = [
        e
        for e in fig9.events
        if e.device == "robot" and e.kind == "sync" and "hand_a_open" in e.detail
    ][0]
    assert sync_robot.t == pytest.approx(open_a.t + 0.346, abs=1e-3)


def test_sync_meets_at_the_latest_arrival(fig9):
    arrived = [e for e in fig9.events if e.kind == "sync" and "arrived" in e.detail]
    assert {e.device for e in arrived} == {"conveyor", "robot"}
    assert all(
        e.t == pytest.approx(2.5) for e in arrived
    )  # the conveyor's 1 m move takes 2.5 s; the robot waited
    robot_first_move = event(fig9, "robot", "move")
    assert robot_first_move.t == pytest.approx(2.5)


def test_serial_dependency_waits_for_the_other_device_to_finish(fig9):
    last_move = [e for e in fig9.events if e.device == "conveyor" and e.kind == "move"][-1]
    assert last_move.t == pytest.approx(fig9.devices["robot"].cycle_time)


def test_uniform_clock_for_all_devices(fig9):
    t = fig9.times
    assert t[0] == 0.0 and t[-1] == pytest.approx(fig9.cycle_time)
    np.testing.assert_allclose(np.diff(t)[:-1], fig9.dt)
    for tl in fig9.devices.values():
        assert tl.q.shape[0] == len(t) == tl.tau.shape[0] == tl.tcp.shape[0]


# ---------------------------------------------------------------- affixment events


def test_conveyor_carries_robot_and_hands(fig9):
    conveyor_q = fig9.devices["conveyor"].q[:, 0]
    robot_tcp_x = fig9.devices["hand_a"].tcp[:, 0, 3]
    before = fig9.times < 2.5  # the robot is still, only the conveyor moves
    shift = robot_tcp_x[before] - robot_tcp_x[0]
    np.testing.assert_allclose(shift, conveyor_q[before] - conveyor_q[0], atol=1e-9)


def test_placed_objects_stay_where_they_were_put(fig9):
    from rworld_cli.schema.loader import load_cell
    from rworld_cli.world.tree import World

    placed = event(fig9, "robot", "place", "part")
    assert {k: placed.tree[k] for k in ("child", "parent", "type", "kind")} == {
        "child": "part",
        "parent": "table",
        "type": "non_rigid",
        "kind": "rests_on",
    }
    k = np.searchsorted(fig9.times, placed.t)
    # at that instant hand_a's TCP is at the slot (the linear move ended there)
    world = World(load_cell("workcells/paper_fig9").cell)
    world.set_joints("conveyor", fig9.devices["conveyor"].q[k])
    np.testing.assert_allclose(
        fig9.devices["hand_a"].tcp[k], world.T_world("table.slot_part"), atol=1e-6
    )


def test_tool_change_leaves_the_hand_and_the_robot_moves_on(fig9):
    change = event(fig9, "robot", "detach_tool")
    assert change.tree["child"] == "hand_a" and change.tree["parent"] is None
    after = fig9.times > change.t + 0.01
    tcp = fig9.devices["hand_a"].tcp[after]
    # hand_a's TCP no longer follows the robot: it stays put for the rest of the run
    np.testing.assert_allclose(tcp - tcp[0], 0.0, atol=1e-12)


def test_payload_changes_the_torques_at_the_grasp(puma):
    from rworld_cli.schema.loader import load_cell
    from rworld_cli.world.tree import World

    grasp = event(puma, "puma", "grasp")
    tl = puma.devices["puma"]
    k = np.searchsorted(puma.times, grasp.t) + 5  # lifting
    cell = load_cell("workcells/puma560").cell
    world = World(cell)
    T_grip = np.linalg.inv(grasp.tree["T_world_parent"]) @ np.array(
        grasp.tree["T_world_child"]
    )  # as the event recorded it
    world.attach("workpiece", "puma.probe", "rigid", "grasp", T_parent_child=T_grip)
    world.set_joints("puma", tl.q[k])
    bare = DeviceDynamics(cell.devices["puma"]).inverse(tl.q[k], tl.qd[k], tl.qdd[k], cell.gravity)
    loaded = DeviceDynamics(cell.devices["puma"], link_loads=world.carried_loads("puma")).inverse(
        tl.q[k], tl.qd[k], tl.qdd[k], cell.gravity
    )
    np.testing.assert_allclose(tl.tau[k], loaded, atol=1e-9)
    assert np.abs(loaded - bare).max() > 1.0  # 1.2 kg at the probe shows


def test_examples_stay_within_limits(fig9, puma):
    assert fig9.ok and puma.ok
    for result in (fig9, puma):
        for name in result.devices:
            peaks = result.peak_ratios(name)
            assert max(peaks["torque"]) <= 1 and max(peaks["velocity"]) <= 1 + 1e-6


# ---------------------------------------------------------------- sensing in programs


def test_guarded_move_stops_where_the_probe_touches():
    result = simulate(load_run("workcells/puma560", "workcells/puma560/runs/probe.yaml"))
    guard = event(result, "puma", "guard")
    assert "triggered" in guard.detail and guard.reading["objects"] == ["workpiece"]
    from rworld_cli.schema.loader import load_cell
    from rworld_cli.world.tree import World

    world = World(load_cell("workcells/puma560").cell)
    top = world.T_world("workpiece.grasp")[2, 3]  # the grasp frame sits on the top face
    world.set_joints("puma", guard.reading["q"])  # where the guard stopped the arm
    height = world.T_world("puma.probe")[2, 3] - top
    # the 10 mm touch cube ahead of the probe meets the face at the 1 um touching tolerance:
    # the guard latches the contact instant between clock samples (bisection to 1 ns)
    assert height == pytest.approx(0.01 + 1e-6, abs=1e-9)
    assert guard.reading["point"] == pytest.approx(world.T_world("probe_tip")[:3, 3], abs=1e-12)
    sense = event(result, "puma", "sense")
    assert sense.t == pytest.approx(guard.t) and sense.reading["active"]
    assert [e.t for e in result.events] == sorted(e.t for e in result.events)


def test_guarded_move_without_trigger_runs_to_its_end(tmp_path):
    cell = copy_cell(tmp_path, "puma560")
    run = write_run(
        cell,
        {
            "g.yaml": "device: puma\nsteps:\n  - move: {to: ready, until: probe_tip}\n  - sense: "
            "probe_tip\n"
        },
    )
    result = simulate(load_run(str(cell), str(run)))
    assert "did not trigger" in event(result, "puma", "guard").detail
    assert not event(result, "puma", "sense").reading["active"]


# ---------------------------------------------------------------- failures


def test_overload_is_detected_and_check_fails(cli, tmp_path):
    cell = copy_cell(tmp_path, "puma560")
    text = (
        (cell / "cell.yaml")
        .read_text()
        .replace("  - name: workpiece\n    mass: 1.2", "  - name: workpiece\n    mass: 60.0")
    )
    (cell / "cell.yaml").write_text(text)
    result = cli(["check", str(cell), "pick_place"])
    assert result.exit_code == 1, result.output
    assert "torque" in result.stderr and "violation: puma j2" in result.stderr
    data = json.loads(cli(["check", str(cell), "pick_place", "--json"]).stdout)
    assert data["ok"] is False
    v = next(v for v in data["violations"] if v["joint"] == "j2")
    assert v["kind"] == "torque" and abs(v["peak"]) > v["limit"] and v["step_text"]


def test_unreachable_target_names_the_step(tmp_path):
    cell = copy_cell(tmp_path, "puma560")
    run = write_run(
        cell,
        {
            "far.yaml": "device: puma\nsteps:\n  - move: {to: ready}\n  - move: {to: table.drop, "
            "offset: {xyz: [0, 0, -3]}}\nunits: {length: m, angle: rad}\n"
        },
    )
    with pytest.raises(
        UserError,
        match=r"far.yaml:4: puma step 2 \(move to table.drop\): 'table.drop' is unreachable .* mm "
        r".* away",
    ):
        simulate(load_run(str(cell), str(run)))


def test_linear_move_out_of_the_workspace_names_the_fraction(tmp_path):
    cell = copy_cell(tmp_path, "puma560")
    run = write_run(
        cell,
        {
            "line.yaml": "device: puma\nsteps:\n  - move: {to: ready}\n"
            "  - move: {to: table.drop, offset: {xyz: [0, 0, -2.5]}, motion: linear, "
            "position_only: true}\nunits: {length: m, angle: rad}\n"
        },
    )
    with pytest.raises(
        UserError, match=r"step 2 .*linear.*: the line leaves the workspace at \d+% of the path"
    ):
        simulate(load_run(str(cell), str(run)))


def test_deadlock_is_reported(tmp_path):
    cell = copy_cell(tmp_path, "paper_fig9")
    run = write_run(
        cell,
        {
            "a.yaml": "device: hand_a\nsteps:\n  - sync: one\n  - sync: two\n",
            "b.yaml": "device: hand_b\nsteps:\n  - sync: two\n  - sync: one\n",
        },
    )
    with pytest.raises(
        UserError,
        match="deadlock: the programs wait for each other: hand_a at step 1 .*hand_b at step 1",
    ):
        simulate(load_run(str(cell), str(run)))


def test_release_and_attach_tool_steps(tmp_path):
    cell = copy_cell(tmp_path, "paper_fig9")
    run = write_run(
        cell,
        {
            "r.yaml": "device: robot\nsteps:\n  - release: part\n  - detach_tool: hand_b\n"
            "  - attach_tool: {tool: hand_b, at: tool_plate}\n  - move: {to: home}\n"
        },
    )
    result = simulate(load_run(str(cell), str(run)))
    kinds = [e.kind for e in result.events if e.device == "robot"]
    assert kinds[:3] == ["release", "detach_tool", "attach_tool"]
    tree = result.events[2].tree
    assert (tree["child"], tree["parent"], tree["type"], tree["kind"]) == (
        "hand_b",
        "robot.tool_plate",
        "rigid",
        "tool",
    )
    # after the tool change hand_b's TCP is the robot's active TCP and it reached the target
    assert result.devices["robot"].tcp_names[-1][1] == "hand_b.tcp"


def test_wait_time_delays_the_next_step(tmp_path):
    cell = copy_cell(tmp_path, "paper_fig9")
    run = write_run(
        cell,
        {
            "w.yaml": "device: hand_a\nsteps:\n  - wait: {time: 0.75}\n  - move: {to: open}\n  - "
            "wait: {time: 0.25}\n"
        },
    )
    result = simulate(load_run(str(cell), str(run)))
    move = event(result, "hand_a", "move")
    assert move.t == pytest.approx(0.75)
    assert result.devices["hand_a"].cycle_time == pytest.approx(0.75 + 0.346 + 0.25, abs=1e-3)
    q = result.devices["hand_a"].q[:, 0]
    assert q[result.times < 0.75].max() == pytest.approx(0.04) and q[-1] == pytest.approx(0.055)


def test_grasp_of_an_object_held_elsewhere_is_refused(tmp_path):
    cell = copy_cell(tmp_path, "paper_fig9")
    run = write_run(
        cell, {"g.yaml": "device: robot\nsteps:\n  - grasp: {object: part, tcp: hand_b.tcp}\n"}
    )
    with pytest.raises(UserError, match="'part' is already held by 'hand_a.tcp'"):
        simulate(load_run(str(cell), str(run)))


@pytest.mark.parametrize(
    "program, message",
    [
        (
            "device: robt\nsteps:\n  - sync: x\n",
            "g.yaml:1:9: device: unknown device 'robt' (did you mean 'robot'?)",
        ),
        (
            "device: robot\nsteps:\n  - move: {to: table.slot_prt}\n",
            "g.yaml:3:16: steps[0].move.to: 'table.slot_prt' is not a frame or a position of "
            "'robot' (did you mean 'table.slot_part'?)",
        ),
        (
            "device: robot\nsteps:\n  - grasp: prt\n",
            "g.yaml:3:12: steps[0].grasp.object: unknown object or sensor 'prt' (did you mean "
            "'part'?)",
        ),
        (
            "device: robot\nsteps:\n  - move: {to: home, speed: 2}\n",
            "g.yaml:3:29: steps[0].move.speed: must be <= 1.0, got 2",
        ),
        (
            "device: robot\nsteps:\n  - wait: {for: hand_a}\n",
            "no program of this run drives 'hand_a'",
        ),
        (
            "device: robot\nsteps:\n  - move: {to: home}\n    grasp: part\n",
            "a step does exactly one thing",
        ),
        ("device: robot\nsteps: []\n", "steps: expected at least 1 value, got 0"),
        (
            "device: robot\nsteps:\n  - sense: pad_x\n",
            "g.yaml:3:12: steps[0].sense: unknown sensor 'pad_x' (did you mean 'pad_a'?)",
        ),
        (
            "device: robot\nsteps:\n  - move: {to: home, until: bumpr}\n",
            "steps[0].move.until: unknown sensor 'bumpr' (did you mean 'bumper'?)",
        ),
    ],
)
def test_program_errors_are_located(tmp_path, cli, program, message):
    cell = copy_cell(tmp_path, "paper_fig9")
    run = write_run(cell, {"g.yaml": program})
    result = cli(["simulate", str(cell), str(run)])
    assert result.exit_code == 2, result.output
    assert message in result.stderr, result.stderr
    assert "Traceback" not in result.output


# ---------------------------------------------------------------- numbers, not programs


def test_changing_numbers_moves_the_program_but_not_its_file(tmp_path):
    """Calibration changes numbers: the same program file goes somewhere else."""
    cell = copy_cell(tmp_path, "puma560")
    program = cell / "programs" / "pick_place.yaml"
    digest = hashlib.sha256(program.read_bytes()).hexdigest()
    run = cell / "runs" / "pick_place.yaml"
    before = simulate(load_run(str(cell), str(run)))
    poses = (
        (cell / "poses.yaml")
        .read_text()
        .replace("table.drop: {xyz: [-0.1, -0.3, 0.05]", "table.drop: {xyz: [-0.05, -0.32, 0.05]")
    )
    (cell / "poses.yaml").write_text(poses)
    after = simulate(load_run(str(cell), str(run)))
    assert hashlib.sha256(program.read_bytes()).hexdigest() == digest
    placed_before = np.array(event(before, "puma", "place").tree["T_world_child"])
    placed_after = np.array(event(after, "puma", "place").tree["T_world_child"])
    # the workpiece lands exactly where the changed number says (the table is not rotated)
    np.testing.assert_allclose(
        placed_after[:3, 3] - placed_before[:3, 3], [0.05, -0.02, 0.0], atol=1e-6
    )
    np.testing.assert_allclose(placed_after[:3, :3], placed_before[:3, :3], atol=1e-6)


# ---------------------------------------------------------------- CLI


def test_simulate_writes_timelines_events_summary_and_plots(cli, tmp_path):
    out = tmp_path / "out"
    result = cli(["simulate", "workcells/paper_fig9", "transfer", "-o", str(out), "--plot"])
    assert result.exit_code == 0, result.output
    for name in ("conveyor", "robot", "hand_a", "hand_b"):
        lines = (out / f"timeline_{name}.csv").read_text().splitlines()
        assert lines[0].startswith("t,step,q1")
        assert (out / f"plot_{name}.png").read_bytes()[:4] == b"\x89PNG"
    timeline = json.loads((out / "timeline.json").read_text())
    assert len(timeline["t"]) == len(timeline["devices"]["robot"]["q"]) == len(lines) - 1
    assert timeline["devices"]["robot"]["active_tcp"][0]["tcp"] == "robot.tool_plate"
    summary = json.loads((out / "summary.json").read_text())
    assert summary["ok"] and summary["devices"]["robot"]["steps"] == 19
    events = json.loads((out / "events.json").read_text())
    assert any(e["kind"] == "detach_tool" for e in events)


def test_simulate_json_and_check_pass_on_examples(cli):
    data = json.loads(cli(["simulate", "workcells/puma560", "pick_place", "--json"]).stdout)
    assert data["ok"] and data["cycle_time"] > 0 and set(data["devices"]) == {"puma"}
    for cell, run in (("workcells/puma560", "pick_place"), ("workcells/paper_fig9", "transfer")):
        result = cli(["check", cell, run])
        assert result.exit_code == 0, result.output
        assert result.stdout.startswith("ok: ")


def test_plot_needs_an_output_directory(cli):
    result = cli(["simulate", "workcells/puma560", "pick_place", "--plot"])
    assert result.exit_code == 2 and "-o DIR" in result.output


def test_unknown_run_name_lists_the_cells_runs(cli):
    result = cli(["check", "workcells/puma560", "pick_plce"])
    assert result.exit_code == 2
    assert "no run 'pick_plce'" in result.stderr and "did you mean 'pick_place'" in result.stderr
    assert "pick_place, probe, through_table" in result.stderr


def test_step_numbers_are_one_based_in_json_and_whole_in_csv(cli, tmp_path):
    """Text, JSON and CSV name a step by the same number."""
    out = tmp_path / "out"
    result = cli(["simulate", str(WORKCELLS / "puma560"), "pick_place", "-o", str(out)])
    assert result.exit_code == 0, result.output
    events = json.loads((out / "events.json").read_text())
    grasp = next(e for e in events if e["kind"] == "grasp")
    assert grasp["step"] == 4 and "grasp workpiece" in grasp["detail"]  # the 4th step
    assert {e["step"] for e in events if e["step"] is not None} == set(range(1, 10))
    rows = (out / "timeline_puma.csv").read_text().splitlines()[1:]
    steps = [row.split(",")[1] for row in rows]
    assert all(s.isdigit() for s in steps) and set(steps) <= {str(k) for k in range(10)}
    data = json.loads(cli(["check", str(WORKCELLS / "puma560"), "through_table", "--json"]).stdout)
    first = data["collisions"]["collisions"][0]["steps"][0]
    assert (
        first["step"] >= 1
        and f"step {first['step']} "
        in cli(["check", str(WORKCELLS / "puma560"), "through_table"]).output
    )


def test_every_step_kind_of_the_program_format_has_its_method():
    """The scheduler's table (simulate.engine.STEP_METHODS) against the program format's step
    kinds: a kind the files accept and nothing runs would be a silent gap."""
    from rworld_cli.schema.program import STEP_KINDS
    from rworld_cli.simulate.engine import STEP_METHODS

    assert set(STEP_METHODS) == set(STEP_KINDS)
    assert all(callable(method) for method in STEP_METHODS.values())

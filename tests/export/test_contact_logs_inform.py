"""The calibration loop through a Yaskawa controller's position variables (issue 62): the GP12
from ROS-Industrial's ``motoman_gp12_support`` as it ships (``tests/data/probe_robots/gp12``)
in a probing cell (``tests.calibration.probe_cells``), its program of feature probes exported
as an INFORM job that keeps each contact in a position variable (``GETS PXn $PX001``), the
variables as the controller saves them (``controller_logs.inform_var_dat``: the job data
format's lines, scipy's rotations, no rworld code) for the simulated contacts on a cell whose
plate a calibration moved, read back by ``rworld measure --from-log --format inform``: the
simulated loop's points to 1e-9 m, the job exported in the robot's frame and in a user frame.

The GP12 was the robot on which the probing first met a wrist singularity: at 65 % of its
reach its forearm stands upright over the plate, so an upright stylus holds axis B at 0.1 deg
and the line into a hole flips the wrist; the probing now refuses a line past a Jacobian
condition number of 1000 and tilts the stylus (``probing.SMALL_TILTS``)."""

from __future__ import annotations

import re

import numpy as np
import pytest

from rworld_cli.calibration.probe_run import probe_run
from rworld_cli.schema.loader import load_cell
from rworld_cli.schema.measurements import load_measurements
from rworld_cli.schema.programs import load_run
from rworld_cli.simulate.engine import simulate
from tests.calibration.probe_cells import calibrated_copy, probe_cell
from tests.export import controller_logs
from tests.export.controller_logs import Reported
from tests.export.test_contact_logs import _tcp_poses

DEVICE = "motoman_gp12"


@pytest.fixture(scope="module")
def gp12_loop(tmp_path_factory):
    from rworld_cli.api import simulate_probe_measurements

    root = tmp_path_factory.mktemp("gp12_loop")
    cell = probe_cell("gp12", root / "gp12", "zero")
    truth = calibrated_copy(cell)
    program = cell / "programs" / "features.yaml"
    run = load_run(str(cell), str(program))
    result = simulate(run, collisions=False)
    probed = probe_run(result, run, load_cell(str(truth)).cell)
    simulated = root / "simulated.yaml"
    simulate_probe_measurements(str(cell), str(truth), str(program), str(simulated), 0.0)
    return cell, program, run, result, probed, simulated


@pytest.mark.parametrize("frame", [None, "plate"])
def test_a_gp12s_position_variables_give_the_simulated_loops_points(
    cli, gp12_loop, tmp_path, frame
):
    cell, program, run, result, probed, simulated = gp12_loop
    out = tmp_path / "exported"
    args = ["export", "program", str(cell), str(program), "--format", "inform", "-o", str(out)]
    exported = cli(args + (["--frame", frame] if frame else []))
    assert exported.exit_code == 0, exported.output
    job = next(out.glob("*.JBI")).read_text()
    assert re.findall(r"GETS PX(\d+) \$PX001", job) == [str(n) for n in range(101, 113)]
    tools = controller_logs.inform_contact_tools(job)
    # $PX001: in the controller's base frame, the package's 'base' (the robot's coordinates,
    # 450 mm above base_link on the GP12)
    poses = _tcp_poses(run, result, probed, f"{DEVICE}.base", DEVICE)
    assert len(poses) == len(tools) == 12
    log = tmp_path / "VAR.DAT"
    log.write_text(
        controller_logs.inform_var_dat([Reported("", T) for T in poses], 101, tools=tools)
    )
    read = tmp_path / "from_log.yaml"
    back = cli(
        ["measure", "--from-log", str(log), "--cell", str(cell), "--run", str(program)]
        + ["--format", "inform", "-o", str(read)]
        + (["--frame", frame] if frame else [])
    )
    assert back.exit_code == 0, back.output
    nominal = load_cell(str(cell)).cell
    a = load_measurements([str(simulated)], nominal).measurements
    b = load_measurements([str(read)], nominal).measurements
    assert sorted(a) == sorted(b) and len(a) == 4
    for name in a:
        assert np.abs(a[name].points - b[name].points).max() < 1e-9, name


def test_the_gp12s_probing_keeps_off_its_wrist_singularity(gp12_loop):
    """Every state of the simulated program keeps the Jacobian's condition number of the
    probe under 1000 on the probing lines (the upright stylus held 4e5 where the line failed),
    and the stylus over the plate stands tilted, not upright."""
    from rworld_cli.kinematics.jacobian import ToolMount, tool_pose_and_jacobian
    from rworld_cli.world.tree import World

    cell, program, run, result, probed, simulated = gp12_loop
    world = World(run.cell)
    mount = ToolMount(*world.mount_of(DEVICE, f"{DEVICE}.probe"))
    device = run.cell.devices[DEVICE]
    probes = [e for e in result.events if e.device == DEVICE and e.kind == "probe"]
    assert len(probes) == 12
    worst = 0.0
    for event in probes:
        search = result.resolved[DEVICE][event.reading["guard_move"]].move
        for q in (search.q_start, search.q_planned):
            T, J = tool_pose_and_jacobian(device, np.asarray(q), mount)
            s = np.linalg.svd(J, compute_uv=False)
            worst = max(worst, s[0] / s[-1])
    assert worst < 1000.0, worst
    stylus = [
        result.resolved[DEVICE][e.reading["guard_move"]].move.T_base_planned[:3, 2] for e in probes
    ]
    assert min(abs(float(z[2])) for z in stylus) < 0.999  # some search with the stylus tilted

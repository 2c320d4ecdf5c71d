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
and a line across a hole passes the wrist's singularity; the probing now follows a line whose
Jacobian condition number passes 1000 again every 0.1 mm and refuses it where that fails or a
joint turns faster than a wrist can (``probing.LINE_CONDITION``)."""

from __future__ import annotations

import re

import numpy as np
import pytest

from tests.calibration.probe_cells import simulated_loop
from tests.export import controller_logs
from tests.export.controller_logs import Reported
from tests.export.test_contact_logs import _tcp_poses, assert_read_back_is_the_loop

# the program's simulation made once a worker for the same files (tests/conftest.py)
pytestmark = pytest.mark.usefixtures("simulation_once")

DEVICE = "motoman_gp12"


@pytest.fixture(scope="module")
def gp12_loop(tmp_path_factory):
    return simulated_loop("gp12", tmp_path_factory.mktemp("gp12_loop"))


def test_a_gp12s_position_variables_give_the_simulated_loops_points(cli, gp12_loop, tmp_path):
    """The job exported in the plate's user frame (the Puma's tests take the robot's frame
    too): its variables, in the controller's base frame, read back through it."""
    frame = "plate"
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
    assert_read_back_is_the_loop(
        cli, cell, program, log, "inform", simulated, tmp_path, "--frame", frame
    )


def test_a_line_through_the_gp12s_wrist_singularity_is_refused_as_the_simulator_does(gp12_loop):
    """The line that stalled the simulator (the upright stylus 11 mm across hole1 from B =
    -0.1 deg, the wrist upright on its way): the probing's 4 mm check passed it; followed again
    every 0.1 mm it is refused as passing a singularity (a joint turns 17 deg a mm), and the
    simulator refuses it as one (a wrist axis would turn at hundreds of times its top
    speed)."""
    from rworld_cli.calibration.probing import SINGULAR, ProbeRig
    from rworld_cli.kinematics.jacobian import tool_pose
    from rworld_cli.motion.linear import PathError, linear_move

    cell, program, run, *_ = gp12_loop
    rig = ProbeRig(run.cell, DEVICE, f"{DEVICE}.probe", "probe_ball")
    q0 = np.array([0.0, 0.8675, -0.7013, 0.0002, -0.002, -np.pi / 2])
    T_a = tool_pose(rig.dev, q0, rig.mount)
    T_b = T_a.copy()
    T_b[:3, 3] += [-0.00465, -0.00997, 0.0]
    T_world_base = np.linalg.inv(rig.T_base_world)
    why = rig._line(T_world_base @ T_a, T_world_base @ T_b, q0, "hole1's line", False)
    assert why is not None and SINGULAR in why, why
    with pytest.raises(PathError) as caught:
        linear_move(rig.dev, rig.mount, 0.0, q0, T_b, 0.004, speed=0.04)
    assert caught.value.reason == "singular", caught.value.detail

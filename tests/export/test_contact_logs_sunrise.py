"""The calibration loop through a KUKA Sunrise application (issue 62): the LBR iiwa 14 from its
vendor package in a probing cell (``tests.calibration.probe_cells``), its program of feature
probes exported as a Sunrise class that logs each contact (``getLogger().info``, the pose of
``getCurrentCartesianPosition``), a stand-in controller log (``controller_logs.sunrise_log``,
Java's double text, no rworld code) of the simulated contacts on a cell whose plate a
calibration moved, read back by ``rworld measure --from-log``: the simulated loop's points to
1e-9 m, in the robot's frame and in a user frame."""

from __future__ import annotations

import numpy as np
import pytest

from tests.calibration.probe_cells import simulated_loop
from tests.export import controller_logs
from tests.export.controller_logs import Reported, reports_in
from tests.export.test_contact_logs import _tcp_poses, assert_read_back_is_the_loop

# the program's simulation made once a worker for the same files (tests/conftest.py)
pytestmark = pytest.mark.usefixtures("simulation_once")

DEVICE = "kuka_lbr_iiwa_14_r820"


@pytest.fixture(scope="module")
def iiwa_loop(tmp_path_factory):
    return simulated_loop("iiwa14", tmp_path_factory.mktemp("iiwa_loop"))


@pytest.mark.parametrize("frame", [None, "plate"])
def test_a_sunrise_log_gives_the_simulated_loops_points(cli, iiwa_loop, tmp_path, frame):
    cell, program, run, result, probed, simulated = iiwa_loop
    out = tmp_path / "exported"
    args = ["export", "program", str(cell), str(program), "--format", "sunrise", "-o", str(out)]
    exported = cli(args + (["--frame", frame] if frame else []))
    assert exported.exit_code == 0, exported.output
    java = next(out.glob("*.java")).read_text()
    assert "getCurrentCartesianPosition(" in java and "not recorded" not in java
    poses = _tcp_poses(run, result, probed, frame, DEVICE)
    fields = reports_in(java)
    assert len(fields) == len(poses) == 12
    assert all(f"frame={frame or 'base'} " in f for f in fields)
    log = tmp_path / "sunrise.log"
    log.write_text(
        controller_logs.sunrise_log(java, [Reported(f, T) for f, T in zip(fields, poses)])
    )
    assert_read_back_is_the_loop(cli, cell, program, log, "sunrise", simulated, tmp_path)


def _robot_frame_log(cli, iiwa_loop, tmp_path) -> str:
    """The stand-in log of the program exported without a user frame."""
    cell, program, run, result, probed, _ = iiwa_loop
    out = tmp_path / "exported"
    args = ["export", "program", str(cell), str(program), "--format", "sunrise", "-o", str(out)]
    assert cli(args).exit_code == 0
    java = next(out.glob("*.java")).read_text()
    poses = _tcp_poses(run, result, probed, None, DEVICE)
    return controller_logs.sunrise_log(
        java, [Reported(f, T) for f, T in zip(reports_in(java), poses)]
    )


def test_a_sunrise_pose_in_degrees_is_refused(cli, iiwa_loop, tmp_path):
    """A, B, C are radians: a log whose angles run past 2 pi (degrees written by another
    program) is refused at its line, nothing read."""
    from rworld_cli.errors import UserError
    from rworld_cli.schema.contactlog import read_contact_log

    text = _robot_frame_log(cli, iiwa_loop, tmp_path)
    lines = text.splitlines()
    head, pose = lines[3].rsplit("pose=", 1)
    values = pose.split(",")
    values[3] = "179.5"
    lines[3] = head + "pose=" + ",".join(values)
    log = tmp_path / "degrees.log"
    log.write_text("\n".join(lines) + "\n")
    with pytest.raises(UserError, match=r"degrees\.log:4:.*radians"):
        read_contact_log(str(log), "sunrise")


def test_a_sunrise_log_fuzz_refuses_every_lie(cli, iiwa_loop, tmp_path):
    """Each pose value of a real log replaced as Java never prints a double (issue 58's
    mutations: a decimal comma, hex, NaN, Infinity-like overflow, trailing text ...) is refused
    at its line; replaced as it may print one (a plus sign, a trailing zero) the same pose."""
    from rworld_cli.errors import UserError
    from rworld_cli.schema.contactlog import read_contact_log
    from tests.export.test_contact_logs import KEPT, REFUSED

    text = _robot_frame_log(cli, iiwa_loop, tmp_path)
    log = tmp_path / "sunrise.log"
    log.write_text(text)
    truth = [c.T_frame_tcp for c in read_contact_log(str(log), "sunrise").contacts]
    lines = text.splitlines()
    kinds = list(REFUSED) + list(KEPT)
    count = 0
    for k in range(72):
        row = 1 + k % 12
        head, pose = lines[row].rsplit("pose=", 1)
        values = pose.split(",")
        which = (k // 12) % 6
        kind = kinds[k % len(kinds)]
        new = (REFUSED | KEPT)[kind](values[which])
        if kind in KEPT and new == values[which]:
            continue
        values[which] = new
        mutated = tmp_path / f"m{k}.log"
        edited = lines.copy()
        edited[row] = head + "pose=" + ",".join(values)
        mutated.write_text("\n".join(edited) + "\n")
        count += 1
        if kind in REFUSED:
            with pytest.raises(UserError) as caught:
                read_contact_log(str(mutated), "sunrise")
            assert caught.value.issues[0].line == row + 1
        else:
            read = [c.T_frame_tcp for c in read_contact_log(str(mutated), "sunrise").contacts]
            assert all(np.allclose(a, b, atol=1e-12, rtol=0) for a, b in zip(read, truth))
    assert count >= 60

"""Robot kinematic calibration (``rworld calibrate-robot``): a UR5 from Universal Robots'
description whose true joint frames are off by lengths of 0.5 mm and angles of 0.05 deg (and
its tool by 0.5 mm), measured by a simulated laser tracker (0.02 mm) at random joint states."""

from __future__ import annotations

import hashlib
import json
import shutil
from importlib.metadata import distribution
from pathlib import Path

import numpy as np
import pytest
import yaml

from rworld_cli import spatial
from rworld_cli.api import import_urdf
from rworld_cli.schema.loader import load_cell
from rworld_cli.world.tree import World
from tests.conftest import urdf_without_meshes

SHARE = Path(str(distribution("example-robot-data").locate_file("cmeel.prefix/share")))
UR5 = SHARE / "example-robot-data" / "robots" / "ur_description" / "urdf" / "ur5_robot.urdf"
SIGMA = 0.02  # mm


@pytest.fixture(scope="module")
def cells(tmp_path_factory):
    """The nominal UR5 cell with a tracker reflector 'tip' on tool0, and a truth cell: the same
    with an overlay of perturbed joint frames and tip."""
    folder = tmp_path_factory.mktemp("robotcal")
    urdf = urdf_without_meshes(UR5, folder / "ur5.urdf")
    nominal = folder / "ur5"
    import_urdf(str(urdf), str(nominal), overlap_states=0)
    cell = yaml.safe_load((nominal / "cell.yaml").read_text())
    cell["devices"][0]["tcps"].append({"name": "tip", "parent": "tool0"})
    (nominal / "cell.yaml").write_text(yaml.safe_dump(cell, sort_keys=False))
    poses = yaml.safe_load((nominal / "poses.yaml").read_text())
    poses["poses"]["ur5.tip"] = {"xyz": [0.02, 0.01, 0.1]}
    (nominal / "poses.yaml").write_text(yaml.safe_dump(poses, sort_keys=False))
    truth = folder / "truth"
    shutil.copytree(nominal, truth)
    rng = np.random.default_rng(7)
    dev = load_cell(str(nominal)).cell.devices["ur5"]
    lines = ["units: {length: mm, angle: deg}", "joints:"]
    for j in dev.joints:
        E = np.eye(4)
        E[:3, :3] = spatial.rpy_to_matrix(rng.normal(0, np.radians(0.05), 3))
        E[:3, 3] = rng.normal(0, 0.5e-3, 3)
        T = j.origin @ E
        xyz = ", ".join(repr(float(v) * 1000) for v in T[:3, 3])
        rpy = ", ".join(repr(float(v)) for v in np.degrees(spatial.matrix_to_rpy(T[:3, :3])))
        lines.append(f"  ur5.{j.name}: {{xyz: [{xyz}], rpy: [{rpy}]}}")
    tip = np.array([0.02, 0.01, 0.1]) + rng.normal(0, 0.5e-3, 3)
    lines += ["poses:", f"  ur5.tip: {{xyz: [{', '.join(repr(float(v) * 1000) for v in tip)}]}}"]
    (truth / "truth.yaml").write_text("\n".join(lines) + "\n")
    text = (truth / "cell.yaml").read_text()
    (truth / "cell.yaml").write_text(
        text.replace("pose_files:\n- poses.yaml", "pose_files:\n- poses.yaml\n- truth.yaml")
    )
    assert load_cell(str(truth)).cell.pose_files[-1].name == "truth.yaml"
    return nominal, truth


def _with_overlay(cell: Path, overlay: Path, folder: Path) -> Path:
    """A copy of ``cell`` with ``overlay`` listed last in its pose files."""
    shutil.copytree(cell, folder)
    shutil.copy(overlay, folder / "cal.yaml")
    text = (folder / "cell.yaml").read_text()
    (folder / "cell.yaml").write_text(
        text.replace("pose_files:\n- poses.yaml", "pose_files:\n- poses.yaml\n- cal.yaml")
    )
    return folder


def _pick_cell(cell: Path, folder: Path) -> Path:
    """A copy of ``cell`` with a frame 'target' and ``programs/pick.yaml``: the tip 80 mm over
    the target (a joint move), then onto it (linear); joint accelerations 10 rad/s^2."""
    shutil.copytree(cell, folder)
    data = yaml.safe_load((folder / "cell.yaml").read_text())
    for joint in data["devices"][0]["joints"]:
        joint["limits"]["acceleration"] = 10.0
    data["frames"] = [{"name": "target"}]
    (folder / "cell.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    poses = yaml.safe_load((folder / "poses.yaml").read_text())
    poses["poses"]["target"] = {"xyz": [0.35, 0.25, 0.3], "rpy": [3.1, 0.1, 0.4]}
    (folder / "poses.yaml").write_text(yaml.safe_dump(poses, sort_keys=False))
    (folder / "programs").mkdir()
    (folder / "programs" / "pick.yaml").write_text(
        "device: ur5\nunits: {length: mm, angle: deg}\nsteps:\n"
        "  - move: {to: target, tcp: tip, offset: {xyz: [0, 0, -80]}}\n"
        "  - move: {to: target, tcp: tip, motion: linear, speed: 0.3}\n"
    )
    return folder


def _states(cell, count: int, seed: int) -> np.ndarray:
    dev = cell.devices["ur5"]
    lo, hi = dev.limit_array("lower"), dev.limit_array("upper")
    rng = np.random.default_rng(seed)
    return rng.uniform(np.maximum(lo, -np.pi), np.minimum(hi, np.pi), (count, dev.dof))


def _tip(cell, Q: np.ndarray) -> np.ndarray:
    world = World(cell)
    out = []
    for q in Q:
        world.set_joints("ur5", q)
        out.append(world.T_world("ur5.tip")[:3, 3])
    return np.array(out)


def _observe(truth_dir: Path, path: Path, count: int, seed: int, hold: int | None = None) -> None:
    """A tracker file: the truth robot's tip at random joint states (joint ``hold`` kept at 0),
    in mm, with noise."""
    truth = load_cell(str(truth_dir)).cell
    Q = _states(truth, count, seed)
    if hold is not None:
        Q[:, hold] = 0.0
    points = _tip(truth, Q) * 1000 + np.random.default_rng(seed + 100).normal(0, SIGMA, (count, 3))
    lines = [
        "units: {length: mm, angle: deg}",
        "device: ur5",
        "instrument: laser tracker (simulated)",
        f"sigma: {SIGMA}",
        "target: ur5.tip",
        "frame: world",
        "observations:",
    ]
    for q, p in zip(Q, points):
        joints = ", ".join(f"{v:.9f}" for v in np.degrees(q))
        lines.append(f"  - {{joints: [{joints}], point: [{', '.join(f'{v:.6f}' for v in p)}]}}")
    path.write_text("\n".join(lines) + "\n")


def _digest(folder: Path) -> dict:
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


def test_the_calibrated_robot_is_the_true_one_at_the_bound(cells, tmp_path, cli):
    nominal, truth_dir = cells
    fit, check = tmp_path / "tracker.yaml", tmp_path / "check.yaml"
    _observe(truth_dir, fit, 50, 1)
    _observe(truth_dir, check, 200, 2)
    before = _digest(nominal)
    out = tmp_path / "cal.yaml"
    result = cli(
        ["calibrate-robot", str(nominal), str(fit), "--validate", str(check), "-o", str(out)]
        + ["--folds", "5", "--json"]
    )
    assert result.exit_code == 0, result.output
    report = json.loads(result.output)
    # a 6R arm measured in position: 4 x 6 + 6 - 3 = 27 identifiable parameters of 39
    assert report["identified"] == 27 and report["parameters"] == 39
    assert len(report["unidentifiable"]) == 12
    validation = report["validation_mm"]
    assert validation["before"]["rms"] > 1.0  # the nominal robot: millimetres off
    # after: the instrument's own noise (sqrt(3) x 0.02 mm) and the estimate's error
    noise = np.sqrt(3) * SIGMA
    expected = np.hypot(noise, validation["predicted_rms_of_the_estimate"])
    assert validation["after"]["rms"] < 1.15 * expected, validation
    # 5-fold cross-validation on the fit's own 50 points: held-out errors near the validation's
    cross = report["cross_validation_mm"]
    assert cross["folds"] == 5 and cross["before"]["rms"] > 1.0
    assert cross["after"]["rms"] < 1.6 * validation["after"]["rms"], (cross, validation)
    assert _digest(nominal) == before  # the cell's own files untouched
    # the overlay, listed last, makes every command use the calibrated robot: its tip where the
    # truth robot's is, to the bound of the estimate (no instrument noise here)
    calibrated = _with_overlay(nominal, out, tmp_path / "calibrated")
    truth = load_cell(str(truth_dir)).cell
    Q = _states(truth, 300, 9)
    error = np.linalg.norm(_tip(load_cell(str(calibrated)).cell, Q) - _tip(truth, Q), axis=1)
    rms = float(np.sqrt(np.mean(error**2))) * 1000
    predicted = validation["predicted_rms_of_the_estimate"]
    print(f"calibrated vs truth: rms {rms:.4f} mm, predicted {predicted:.4f} mm")  # pytest -s
    assert rms < 1.3 * predicted and rms < 0.03, (rms, predicted)
    # the CLI's forward kinematics too: the calibrated cell's answer is not the nominal one
    answers = []
    for folder in (nominal, calibrated):
        fk = cli(["kinematics", "fk", str(folder), "--q", "0,-1,1,0,1,0", "--json"])
        assert fk.exit_code == 0, fk.output
        answers.append(fk.output)
    assert answers[0] != answers[1]


def test_a_joint_never_moved_is_reported_not_invented(cells, tmp_path):
    """Wrist 3 held at 0 in every observation: its zero cannot be told from the tip's offset."""
    from rworld_cli.api import calibrate_robot

    nominal, truth_dir = cells
    path = tmp_path / "held.yaml"
    _observe(truth_dir, path, 40, 3, hold=5)
    result = calibrate_robot(str(nominal), [str(path)], dry_run=True)
    assert result.identified < 27 and not result.written
    assert any("wrist_3_joint" in u for u in result.unidentifiable), result.unidentifiable


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda t: t.replace("units: {length: mm, angle: deg}\n", ""), "units"),
        (lambda t: t.replace("device: ur5", "device: ur6"), "unknown device 'ur6'"),
        (lambda t: t.replace("target: ur5.tip", "target: ur5.tipp"), "unknown frame 'ur5.tipp'"),
        (lambda t: t.replace("{joints: [", "{joints: [0, ", 1), "7 value(s) for the 6 joint(s)"),
        (lambda t: t.replace("angle: deg", "angle: rad"), "beyond the joint limits"),
        (lambda t: t.replace("length: mm", "length: m"), "do not fit 'ur5'"),
    ],
)
def test_bad_observations_are_located_and_nothing_is_written(cells, tmp_path, cli, edit, message):
    nominal, truth_dir = cells
    path = tmp_path / "bad.yaml"
    _observe(truth_dir, path, 30, 4)
    path.write_text(edit(path.read_text()))
    out = tmp_path / "cal.yaml"
    result = cli(["calibrate-robot", str(nominal), str(path), "-o", str(out)])
    assert result.exit_code == 2, result.output
    assert message in result.output, result.output
    assert not out.exists()


def test_csv_observations_read_as_the_yaml_ones(cells, tmp_path):
    from rworld_cli.schema.robotobs import read_observations

    nominal, truth_dir = cells
    path = tmp_path / "t.yaml"
    _observe(truth_dir, path, 10, 5)
    cell = load_cell(str(nominal)).cell
    obs, _ = read_observations(str(path), cell)
    names = [j.name for j in cell.devices["ur5"].joints]
    rows = [
        "# device: ur5",
        "# target: ur5.tip",
        "# sigma: 0.02",
        "# units: mm, deg",
        ",".join(names + ["x", "y", "z"]),
    ]
    for q, p in zip(obs.q, obs.points):
        rows.append(",".join(f"{v:.12g}" for v in [*np.degrees(q), *(p * 1000)]))
    csv = tmp_path / "t.csv"
    csv.write_text("\n".join(rows) + "\n")
    again, _ = read_observations(str(csv), cell)
    np.testing.assert_allclose(again.q, obs.q, atol=1e-12)
    np.testing.assert_allclose(again.points, obs.points, atol=1e-12)
    assert again.sigma == pytest.approx(2e-5)
    csv.write_text("\n".join(rows[:3] + rows[4:]) + "\n")  # no units
    from rworld_cli.errors import UserError

    with pytest.raises(UserError) as info:
        read_observations(str(csv), cell)
    assert "rworld never guesses units" in str(info.value.lines()) and "t.csv:4" in str(
        info.value.lines()
    )
    # a row with a field more than the header (issue 45), or one shifted in front: at its line
    extra = rows[:6] + [rows[6] + ",1.5"] + rows[7:]
    shifted = rows[:7] + ["0," + rows[7]] + rows[8:]
    for bad, line in ((extra, 7), (shifted, 8)):
        csv.write_text("\n".join(bad) + "\n")
        with pytest.raises(UserError) as info:
            read_observations(str(csv), cell)
        assert info.value.lines() == [f"{csv}:{line}:1: row: 10 fields where the header names 9"], (
            info.value.lines()
        )


def test_full_poses_identify_the_orientation_too(cells, tmp_path):
    """A 6-DoF tracker probe (pose of the tip frame): 4 x 6 + 6 = 30 of 42 parameters, and the
    calibrated tip's orientation is the truth's as well."""
    from rworld_cli.api import calibrate_robot

    nominal, truth_dir = cells
    truth = load_cell(str(truth_dir)).cell
    Q = _states(truth, 40, 6)
    world = World(truth)
    rng = np.random.default_rng(60)
    lines = [
        "units: {length: mm, angle: deg}",
        "device: ur5",
        "instrument: 6-DoF tracker probe (simulated)",
        f"sigma: {SIGMA}",
        "sigma_angle: 0.002",
        "target: ur5.tip",
        "observations:",
    ]
    for q in Q:
        world.set_joints("ur5", q)
        T = world.T_world("ur5.tip")
        xyz = T[:3, 3] * 1000 + rng.normal(0, SIGMA, 3)
        R = T[:3, :3] @ spatial.rpy_to_matrix(rng.normal(0, np.radians(0.002), 3))
        rpy = np.degrees(spatial.matrix_to_rpy(R))
        joints = ", ".join(f"{v:.9f}" for v in np.degrees(q))
        lines.append(
            f"  - {{joints: [{joints}], pose: {{xyz: [{', '.join(f'{v:.6f}' for v in xyz)}], "
            f"rpy: [{', '.join(f'{v:.9f}' for v in rpy)}]}}}}"
        )
    path = tmp_path / "poses.yaml"
    path.write_text("\n".join(lines) + "\n")
    out = tmp_path / "cal.yaml"
    result = calibrate_robot(str(nominal), [str(path)], output=str(out))
    assert (result.identified, result.parameters) == (30, 42)
    calibrated = _with_overlay(nominal, out, tmp_path / "calibrated")
    mine = World(load_cell(str(calibrated)).cell)
    worst = [0.0, 0.0]
    for q in _states(truth, 50, 10):
        world.set_joints("ur5", q)
        mine.set_joints("ur5", q)
        A, B = world.T_world("ur5.tip"), mine.T_world("ur5.tip")
        worst[0] = max(worst[0], float(np.linalg.norm(A[:3, 3] - B[:3, 3])))
        angle = np.linalg.norm(spatial.rotation_vector(A[:3, :3].T @ B[:3, :3]))
        worst[1] = max(worst[1], float(np.degrees(angle)))
    assert worst[0] < 0.05e-3 and worst[1] < 0.005, worst  # the nominal: mm and 0.1 deg off
    bad = path.read_text().replace("sigma_angle: 0.002\n", "")
    path.write_text(bad)
    from rworld_cli.errors import UserError

    with pytest.raises(UserError) as info:
        calibrate_robot(str(nominal), [str(path)], dry_run=True)
    assert "sigma_angle" in "\n".join(info.value.lines())


def test_compensated_targets_take_a_nominal_controller_to_the_true_pose(cells, tmp_path, cli):
    """export program --compensate on the calibrated cell: joint targets are the calibrated
    IK's, and every Cartesian target is Pinocchio's forward kinematics of the *original* URDF
    (what the nominal controller computes) at those joints - so the controller's own IK puts
    the real robot on the frame.  Without --compensate the targets are the frames themselves."""
    import pinocchio as pin

    from tests.export import readers

    nominal, truth_dir = cells
    # the truth's overlay stands for a calibration
    calibrated = _pick_cell(truth_dir, tmp_path / "calibrated")
    program = calibrated / "programs" / "pick.yaml"
    out = tmp_path / "out"
    result = cli(
        ["export", "program", str(calibrated), str(program), "--format", "urscript"]
        + ["-o", str(out), "--compensate", "--json"]
    )
    assert result.exit_code == 0, result.output
    moved = json.loads(result.output)["compensated"]
    # only the linear move's Cartesian target changed: the joint move's joint target did not
    # (issue 44: listing it as moved was wrong)
    assert len(moved) == 1 and 0.3 < moved[0]["moved_mm"] < 20, moved
    assert "(linear)" in moved[0]["step"]
    # an INFORM job without the controller's pulses per degree writes the joint move as a
    # Cartesian position too: both targets moved, by their Cartesian shifts
    inform = cli(
        ["export", "program", str(calibrated), str(program), "--format", "inform"]
        + ["-o", str(tmp_path / "jobs"), "--compensate", "--json"]
    )
    assert inform.exit_code == 0, inform.output
    shifts = json.loads(inform.output)["compensated"]
    assert len(shifts) == 2 and all(0.3 < m["moved_mm"] < 20 for m in shifts), shifts
    assert all(m["joints_deg"] == 0.0 for m in shifts)
    [(_, q), (_, target)] = readers.urscript((out / "pick.script").read_text())
    model = pin.buildModelFromUrdf(str(UR5))
    data = model.createData()
    from rworld_cli.schema.programs import load_run
    from rworld_cli.simulate.engine import simulate

    run = simulate(load_run(str(calibrated), str(program)), collisions=False)
    q_linear = [r.move.q_goal for r in run.resolved["ur5"] if r.move is not None][1]
    pin.framesForwardKinematics(model, data, q_linear)
    base = data.oMf[model.getFrameId("base")].homogeneous
    flange = data.oMf[model.getFrameId("tool0")].homogeneous
    tip = np.eye(4)
    tip[:3, 3] = World(load_cell(str(calibrated)).cell).T("ur5.tool0", "ur5.tip")[:3, 3]
    expected = np.linalg.solve(base, flange @ tip)  # the nominal controller's pose at q
    assert np.abs(target[:3, 3] - expected[:3, 3]).max() < 1e-8
    # and the calibrated robot at those joints is on the frame
    world = World(load_cell(str(calibrated)).cell)
    world.set_joints("ur5", q_linear)
    frame = world.T_world("target")
    assert np.linalg.norm(world.T_world("ur5.tip")[:3, 3] - frame[:3, 3]) < 1e-7
    uncalibrated = tmp_path / "uncalibrated"  # the same cell without the robot's overlay
    shutil.copytree(calibrated, uncalibrated)
    text = (uncalibrated / "cell.yaml").read_text()
    (uncalibrated / "cell.yaml").write_text(text.replace("- truth.yaml\n", ""))
    plain = cli(
        ["export", "program", str(uncalibrated), str(uncalibrated / "programs" / "pick.yaml")]
        + ["--format", "urscript", "-o", str(tmp_path / "x"), "--compensate"]
    )
    assert plain.exit_code == 2 and "nothing to compensate" in plain.output


def test_planned_poses_beat_random_ones_and_the_program_checks(tmp_path, cli):
    """plan-robot-calibration on the Puma: collision-free poses whose predicted error is below
    that of as many random ones; the program visits them and 'rworld check' passes it; the
    template reads back as observations of those poses."""
    from tests.conftest import WORKCELLS

    cell = tmp_path / "puma"
    shutil.copytree(WORKCELLS / "puma560", cell)
    program, template = cell / "programs" / "calibration.yaml", tmp_path / "obs.yaml"
    result = cli(
        ["plan-robot-calibration", str(cell), "--device", "puma", "--poses", "15"]
        + ["--target", "probe", "--program", str(program), "-o", str(template), "--json"]
    )
    assert result.exit_code == 0, result.output
    plan = json.loads(result.output)
    assert plan["poses"] == 15 and plan["rejected"] > 0
    assert plan["predicted_rms_mm"] < plan["random_same_count_rms_mm"]
    check = cli(["check", str(cell), str(program)])
    assert check.exit_code == 0, check.output
    from rworld_cli.schema.robotobs import read_observations

    obs, _ = read_observations(str(template), load_cell(str(cell)).cell)
    np.testing.assert_allclose(obs.q, np.array(plan["joints"]), atol=1e-7)
    world = World(load_cell(str(cell)).cell)
    world.set_joints("puma", obs.q[0])
    np.testing.assert_allclose(obs.points[0], world.T_world("puma.probe")[:3, 3], atol=1e-6)
    bad = cli(["plan-robot-calibration", str(cell), "--device", "pumaa", "--poses", "5"])
    assert bad.exit_code == 2 and "did you mean 'puma'" in bad.output


def _with_artefact(folder: Path) -> None:
    """A calibration artefact on the table: a 25 mm sphere on a post and a block's three faces."""
    cell = yaml.safe_load((folder / "cell.yaml").read_text())
    cell["objects"] = [
        {
            "name": "artefact",
            "features": [
                {"name": "ball", "point": [0.0, 0.0, 0.15]},
                {"name": "top", "plane": {"point": [0.1, 0, 0.05], "normal": [0, 0, 1]}},
                {"name": "front", "plane": {"point": [0.15, 0, 0], "normal": [1, 0, 0]}},
                {"name": "side", "plane": {"point": [0.1, 0.05, 0], "normal": [0, 1, 0]}},
            ],
        }
    ]
    (folder / "cell.yaml").write_text(yaml.safe_dump(cell, sort_keys=False))
    poses = yaml.safe_load((folder / "poses.yaml").read_text())
    poses["poses"]["artefact"] = {"xyz": [0.35, 0.15, 0.0]}
    (folder / "poses.yaml").write_text(yaml.safe_dump(poses, sort_keys=False))


def _touches(truth, count: int, seed: int, ball: float, sigma: float) -> list[dict]:
    """Where the truth robot's ball (radius ``ball``) touches the artefact: the ball centre put
    at its contact distance (plus the trigger's noise) by the truth robot's IK."""
    from rworld_cli.kinematics.inverse import solve_ik
    from rworld_cli.kinematics.jacobian import ToolMount

    world = World(truth)
    dev = truth.devices["ur5"]
    mount = ToolMount(*world.mount_of("ur5", "ur5.tip"))
    T_base = world.T_world("ur5")
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < count:
        name = ["ball", "top", "front", "side"][len(out) % 4]
        f = truth.features[f"artefact.{name}"]
        T = world.T_world("artefact")
        gap = ball + rng.normal(0, sigma)
        if name == "ball":
            u = rng.normal(size=3)
            u[2] = abs(u[2]) + 0.3
            u /= np.linalg.norm(u)
            centre = T[:3, :3] @ f.point + T[:3, 3] + (0.025 + gap) * u
        else:
            n = T[:3, :3] @ f.direction
            spread = rng.uniform(-0.04, 0.04, 3)
            spread -= (spread @ n) * n
            centre = T[:3, :3] @ f.point + T[:3, 3] + spread + gap * n
        target = np.eye(4)
        target[:3, 3] = np.linalg.solve(T_base, np.r_[centre, 1.0])[:3]
        seed_q = rng.uniform(-1.5, 1.5, dev.dof)
        result = solve_ik(dev, target, mount, seed_q, position_only=True)
        if result.success:
            out.append({"joints": np.degrees(result.q), "feature": f"artefact.{name}"})
    return out


def test_self_calibration_by_touching_an_artefact(cells, tmp_path):
    """Input (c): the robot's own 5 mm ball touching a sphere and three faces of a known
    artefact, the residual the gap to the surface.  The calibrated robot's ball is where the
    truth's is, near the artefact, far better than the nominal one."""
    from rworld_cli.api import calibrate_robot

    nominal_dir, truth_dir = cells
    nominal, truth = tmp_path / "nominal", tmp_path / "truth"
    shutil.copytree(nominal_dir, nominal)
    shutil.copytree(truth_dir, truth)
    for folder in (nominal, truth):
        _with_artefact(folder)
    truth_cell = load_cell(str(truth)).cell
    lines = [
        "units: {length: mm, angle: deg}",
        "device: ur5",
        "instrument: touch-trigger ball probe",
        "sigma: 0.01",
        "target: ur5.tip",
        "probe_radius: 2.5",
        "contacts:",
    ]
    for t in _touches(truth_cell, 160, 3, 0.0025, 1e-5):
        joints = ", ".join(f"{v:.9f}" for v in t["joints"])
        radius = ", radius: 25" if t["feature"] == "artefact.ball" else ""
        lines.append(f"  - {{joints: [{joints}], feature: {t['feature']}{radius}}}")
    path = tmp_path / "touches.yaml"
    path.write_text("\n".join(lines) + "\n")
    out = tmp_path / "cal.yaml"
    check_path = tmp_path / "check.yaml"
    lines = lines[:7]
    for t in _touches(truth_cell, 40, 4, 0.0025, 1e-5):
        joints = ", ".join(f"{v:.9f}" for v in t["joints"])
        radius = ", radius: 25" if t["feature"] == "artefact.ball" else ""
        lines.append(f"  - {{joints: [{joints}], feature: {t['feature']}{radius}}}")
    check_path.write_text("\n".join(lines) + "\n")
    result = calibrate_robot(str(nominal), [str(path)], output=str(out), validate=[str(check_path)])
    assert result.after["rms"] < 2e-5 < result.before["rms"], (result.before, result.after)
    # the gaps on contacts not used in the fit: at the trigger's noise (0.01 mm)
    assert result.validation_after["rms"] < 1.5e-5 < result.validation_before["rms"]
    text = (nominal / "cell.yaml").read_text()
    (nominal / "cell.yaml").write_text(
        text.replace("pose_files:\n- poses.yaml", "pose_files:\n- poses.yaml\n- cal.yaml")
    )
    shutil.copy(out, nominal / "cal.yaml")
    check = [np.radians(t["joints"]) for t in _touches(truth_cell, 40, 9, 0.0025, 0.0)]
    mine, theirs = World(load_cell(str(nominal)).cell), World(truth_cell)
    plain = World(load_cell(str(nominal_dir)).cell)
    errors, before = [], []
    for q in check:
        for w in (mine, theirs, plain):
            w.set_joints("ur5", q)
        errors.append(
            np.linalg.norm(mine.T_world("ur5.tip")[:3, 3] - theirs.T_world("ur5.tip")[:3, 3])
        )
        before.append(
            np.linalg.norm(plain.T_world("ur5.tip")[:3, 3] - theirs.T_world("ur5.tip")[:3, 3])
        )
    rms, rms_before = np.sqrt(np.mean(np.square(errors))), np.sqrt(np.mean(np.square(before)))
    print(
        f"ball near the artefact: nominal {rms_before * 1000:.3f} mm, calibrated "
        f"{rms * 1000:.4f} mm, identified {result.identified} of {result.parameters}"
    )
    assert rms < 0.1 * rms_before and rms < 0.05e-3, (rms, rms_before)


PLANES = ["plate.top", "plate.front", "bracket.base_top", "bracket.upright_face", "bracket.side"]


def _recorded_touches(truth, contacts: Path, sigma: float, seed: int) -> None:
    """Fill a planned contacts file as the truth robot would: each touch's guarded move runs
    along the nominal approach line (joint direction ``J+ (-n)`` at the planned contact) until
    the truth ball meets the plane (plus the trigger's noise); its joint values go in."""
    from rworld_cli.kinematics.jacobian import ToolMount, jacobian

    doc = yaml.safe_load(contacts.read_text())
    world = World(truth)
    dev = truth.devices["puma"]
    mount = ToolMount(*world.mount_of("puma", "puma.probe"))
    R_base = np.linalg.inv(world.T_world("puma"))[:3, :3]
    q = np.radians([c["joints"] for c in doc["contacts"]])
    planes = []
    for c in doc["contacts"]:
        f = truth.features[c["feature"]]
        T = world.T_world(f.owner)
        planes.append((T[:3, :3] @ f.direction, T[:3, :3] @ f.point + T[:3, 3]))
    n = np.array([p[0] for p in planes])
    x0 = np.array([p[1] for p in planes])
    Jv = jacobian(dev, q, mount)[:, :3, :]
    dq = np.einsum("kij,kj->ki", np.linalg.pinv(Jv), -n @ R_base.T)  # 1 m of ball travel
    rng = np.random.default_rng(seed)
    want = doc["probe_radius"] / 1000 + rng.normal(0, sigma, len(q))

    def gap(t):
        Q = q + t[:, None] * dq
        p = world.T_world_frames(["puma.probe"], {"puma": Q})["puma.probe"][:, :3, 3]
        return np.einsum("ki,ki->k", n, p - x0) - want

    lo, hi = np.full(len(q), -0.01), np.full(len(q), 0.01)  # the ball 10 mm either side
    assert np.all(gap(lo) > 0) and np.all(gap(hi) < 0)
    for _ in range(60):
        mid = (lo + hi) / 2
        above = gap(mid) > 0
        lo, hi = np.where(above, mid, lo), np.where(above, hi, mid)
    recorded = np.degrees(q + ((lo + hi) / 2)[:, None] * dq)
    for c, joints in zip(doc["contacts"], recorded, strict=True):
        c["joints"] = [round(float(v), 9) for v in joints]
    contacts.write_text(yaml.safe_dump(doc, sort_keys=False))


def test_planned_touches_self_calibrate_the_robot(tmp_path, cli):
    """plan-robot-calibration --instrument probe on the probing cell: touches of the Puma's ball
    on five known faces.  The chosen touches predict less than twice as many random ones and
    no less than the optimal design's bound; the program checks; the contacts template, filled
    by a truth Puma off its DH table, calibrates the robot so that its ball is where the
    truth's is near the parts."""
    from rworld_cli.api import calibrate_robot
    from tests.calibration.test_probing import CELL, robot_truth

    cell = tmp_path / "probing"
    shutil.copytree(CELL, cell)
    program, contacts, check = cell / "touches.yaml", tmp_path / "touches.yaml", tmp_path / "v.yaml"
    options = ["--device", "puma", "--instrument", "probe", "--sigma", "0.005mm"]
    options += [x for f in PLANES for x in ("--feature", f)]
    result = cli(
        ["plan-robot-calibration", str(cell), "--poses", "30", "--candidates", "500"]
        + options
        + ["--program", str(program), "-o", str(contacts), "--json"]
    )
    assert result.exit_code == 0, result.output
    plan = json.loads(result.output)
    print(
        f"30 touches predict {plan['predicted_rms_mm']:.4f} mm; 30 random "
        f"{plan['random_same_count_rms_mm']:.4f}, 60 random "
        f"{plan['random_double_count_rms_mm']:.4f}, bound {plan['best_possible_rms_mm']:.4f} mm"
    )
    assert plan["instrument"] == "probe" and set(plan["features"]) <= set(PLANES)
    assert plan["best_possible_rms_mm"] <= plan["predicted_rms_mm"]
    assert plan["predicted_rms_mm"] < plan["random_double_count_rms_mm"]
    checked = cli(["check", str(cell), str(program)])
    assert checked.exit_code == 0, checked.output
    validation = cli(
        ["plan-robot-calibration", str(cell), "--poses", "30", "--candidates", "500"]
        + options
        + ["--seed", "7", "-o", str(check)]
    )
    assert validation.exit_code == 0, validation.output
    truth = load_cell(str(robot_truth(tmp_path / "truth", parts_moved=False))).cell
    _recorded_touches(truth, contacts, 5e-6, 1)
    _recorded_touches(truth, check, 5e-6, 2)
    out = tmp_path / "cal.yaml"
    fit = calibrate_robot(str(cell), [str(contacts)], output=str(out), validate=[str(check)])
    print(
        f"gaps on 30 other touches: {fit.validation_before['rms'] * 1000:.4f} mm before, "
        f"{fit.validation_after['rms'] * 1000:.4f} mm after; identified {fit.identified}"
    )
    assert fit.validation_before["rms"] > 0.1e-3  # the robot's error shows in the gaps
    assert fit.validation_after["rms"] < 3 * 5e-6  # and falls to the trigger's noise


@pytest.mark.parametrize(
    "extra, message",
    [
        ([], "name them with --feature"),
        (["--feature", "plate.hole1"], "'plate.hole1' is a circle"),
        (["--feature", "plate.tpo"], "did you mean 'plate.top'"),
        (["--feature", "puma.probe"], "unknown feature 'puma.probe'"),
    ],
)
def test_touch_planning_refuses_what_it_cannot_touch(tmp_path, cli, extra, message):
    from tests.calibration.test_probing import CELL

    program = tmp_path / "touches.yaml"
    result = cli(
        ["plan-robot-calibration", str(CELL), "--device", "puma", "--poses", "5"]
        + ["--instrument", "probe", "--program", str(program)]
        + extra
    )
    assert result.exit_code == 2, result.output
    assert message in result.output
    assert not program.exists()


def test_a_program_for_a_robot_without_acceleration_limits_is_refused_before_planning(
    tmp_path, cli
):
    """An imported robot without --joint-limits: said once, before the planning, not per move
    at a temporary file's lines after it."""
    from tests.conftest import WORKCELLS

    cell = tmp_path / "cell"
    shutil.copytree(WORKCELLS / "puma560", cell)
    text = (cell / "cell.yaml").read_text()
    lines = [line for line in text.splitlines() if "acceleration: " not in line]
    (cell / "cell.yaml").write_text("\n".join(lines) + "\n")
    result = cli(
        ["plan-robot-calibration", str(cell), "--device", "puma", "--poses", "5"]
        + ["--program", str(tmp_path / "p.yaml"), "-o", str(tmp_path / "o.yaml")]
    )
    assert result.exit_code == 2, result.output
    assert result.output.count("acceleration limit") == 1
    assert "import it with --joint-limits" in result.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cell"]

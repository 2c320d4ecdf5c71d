"""Joint compliance under gravity (issue 46): ``calibrate-robot --model compliance`` recovers a
simulated truth's compliance and brings held-out error down to the instrument's noise where the
geometric model cannot; the overlay's ``compliance:`` reaches the export, whose compensated
joint commands put the yielding arm on the simulated joints.  Gravity torques of the truth and
of every check come from Pinocchio on Universal Robots' URDF, not from rworld's dynamics."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml

from rworld_cli.schema.loader import load_cell
from tests.calibration.test_robot_calibration import (
    UR5,
    _pick_cell,
    _states,
    _tip,
    _with_overlay,
)
from tests.calibration.test_robot_calibration import cells as cells  # noqa: F401 (a fixture)

# the truth's compliance [rad/(N m)]: shoulder pan and the last two wrists hold no torque
# against gravity on this arm (a vertical axis; masses on the axes), so theirs is 0
TRUE_COMPLIANCE = np.array([0.0, 5e-6, 8e-6, 1.5e-5, 0.0, 0.0])
NOISE = 0.02  # [mm] per coordinate


@pytest.fixture(scope="module")
def gravity():
    """``g(Q)`` (K, 6) [N m]: the holding torques of the original URDF, by Pinocchio."""
    import pinocchio as pin

    model = pin.buildModelFromUrdf(str(UR5))
    data = model.createData()
    return lambda Q: np.array([pin.computeGeneralizedGravity(model, data, q) for q in Q])


def _observe(truth_dir: Path, path: Path, count: int, seed: int, gravity) -> None:
    """A tracker file of the truth's tip at random commanded joints, the arm yielding."""
    truth = load_cell(str(truth_dir)).cell
    Q = _states(truth, count, seed)
    arm = Q + TRUE_COMPLIANCE * gravity(Q)
    points = _tip(truth, arm) * 1000
    points += np.random.default_rng(seed + 100).normal(0, NOISE, (count, 3))
    lines = [
        "units: {length: mm, angle: deg}",
        "device: ur5",
        f"sigma: {NOISE}",
        "target: ur5.tip",
        "frame: world",
        "observations:",
    ]
    for q, p in zip(Q, points):
        joints = ", ".join(f"{v:.9f}" for v in np.degrees(q))
        lines.append(f"  - {{joints: [{joints}], point: [{', '.join(f'{v:.6f}' for v in p)}]}}")
    path.write_text("\n".join(lines) + "\n")


def _calibrate(cli, cell, fit, check, model, out=None) -> dict:
    args = ["calibrate-robot", str(cell), str(fit), "--validate", str(check), "--json"]
    args += ["--model", model] + (["-o", str(out)] if out else ["--dry-run"])
    result = cli(args)
    assert result.exit_code == 0, result.output
    return json.loads(result.output)


def test_compliance_is_recovered_and_held_out_error_falls_to_the_noise(
    cells, gravity, tmp_path, cli
):
    nominal, truth_dir = cells
    fit, check = tmp_path / "fit.yaml", tmp_path / "check.yaml"
    _observe(truth_dir, fit, 60, 1, gravity)
    _observe(truth_dir, check, 200, 2, gravity)
    noise_only = NOISE * np.sqrt(3)  # [mm]: the held-out rms of a perfect model
    geometric = _calibrate(cli, nominal, fit, check, "geometric")
    out = tmp_path / "cal.yaml"
    compliant = _calibrate(cli, nominal, fit, check, "compliance", out)
    assert compliant["model"] == "compliance" and geometric["model"] == "geometric"
    # the geometric model cannot follow the yield: 3x the noise, and it says so
    assert geometric["validation_mm"]["after"]["rms"] > 2.5 * noise_only
    assert geometric["variance_factor"] > 2 and any("sigma" in w for w in geometric["warnings"])
    # with compliance: the noise, the residuals at the stated sigma
    assert compliant["validation_mm"]["after"]["rms"] < 1.15 * noise_only
    assert compliant["variance_factor"] < 1.2
    # joints 2 and 3 identified; joint 4's holding torque (3 N m at most) moves the tip by less
    # than the noise: its compliance is not determined to its typical error and stays nominal
    assert compliant["identified"] == geometric["identified"] + 2
    assert any(u.startswith("+1.00 wrist_1_joint.compliance") for u in compliant["unidentifiable"])
    rows = {r["name"]: r for r in compliant["parameters_identified"]}
    for i, name in enumerate(["shoulder_lift_joint", "elbow_joint"], start=1):
        row = rows[f"{name}.compliance"]
        assert row["unit"] == "mrad/kNm"
        true = TRUE_COMPLIANCE[i] * 1e6
        assert abs(row["correction"] - true) < 3 * row["sigma"] + 1e-9, (name, row, true)
        assert row["sigma"] < 0.15 * true
    # the joints that hold no torque are named and left as the cell gives them
    notes = "\n".join(compliant["notes"])
    for name in ("shoulder_pan_joint", "wrist_2_joint", "wrist_3_joint"):
        assert f"{name} holds at most" in notes
    # the overlay carries it: loaded, the cell's joints have the fitted compliance
    written = yaml.safe_load(out.read_text())["compliance"]
    cell = load_cell(str(_with_overlay(nominal, out, tmp_path / "calibrated"))).cell
    for j in cell.devices["ur5"].joints:
        value = written[f"ur5.{j.name}"]  # deg per kN m
        assert j.compliance == pytest.approx(np.radians(value) / 1000, rel=1e-12, abs=1e-300)
        if f"{j.name}.compliance" in rows:
            fitted = rows[f"{j.name}.compliance"]["correction"] * 1e-6
            assert j.compliance == pytest.approx(fitted, rel=1e-9)


def test_compensated_commands_put_the_yielding_arm_on_its_joints(cells, gravity, tmp_path, cli):
    """A cell whose overlay holds compliance only: export --compensate writes joint commands
    ``q`` with ``q + c g(q)`` (Pinocchio's g) on the simulated arm's joints, Cartesian targets
    the nominal forward kinematics at them; the csv stream likewise at every sample."""
    import pinocchio as pin

    from rworld_cli.schema.programs import load_run
    from rworld_cli.simulate.engine import simulate
    from tests.export import readers

    nominal, _ = cells
    cell_dir = _pick_cell(nominal, tmp_path / "cell")
    deg_per_knm = np.degrees(TRUE_COMPLIANCE) * 1000
    overlay = tmp_path / "stiffness.yaml"
    overlay.write_text(
        "units: {length: mm, angle: deg}\ncompliance:\n"
        + "".join(
            f"  ur5.{name}: {float(value)!r}\n"
            for name, value in zip(
                ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint"]
                + ["wrist_1_joint", "wrist_2_joint", "wrist_3_joint"],
                deg_per_knm,
            )
        )
    )
    cell_dir = _with_overlay(cell_dir, overlay, tmp_path / "compliant")
    program = cell_dir / "programs" / "pick.yaml"
    out = tmp_path / "out"
    result = cli(
        ["export", "program", str(cell_dir), str(program), "--format", "urscript"]
        + ["-o", str(out), "--compensate", "--json"]
    )
    assert result.exit_code == 0, result.output
    moved = json.loads(result.output)["compensated"]
    assert len(moved) == 2 and all(m["joints_deg"] > 1e-3 for m in moved), moved
    run = simulate(load_run(str(cell_dir), str(program)), collisions=False)
    arm = [r.move.q_goal for r in run.resolved["ur5"] if r.move is not None]
    written = readers.urscript((out / "pick.script").read_text())
    model = pin.buildModelFromUrdf(str(UR5))
    data = model.createData()
    tip = np.eye(4)
    tip[:3, 3] = [0.02, 0.01, 0.1]
    (_, q_joint), (_, target) = written  # the joint move's joints, the linear move's pose
    q_linear = _solve_command(arm[1], gravity)
    np.testing.assert_allclose(q_joint + TRUE_COMPLIANCE * gravity([q_joint])[0], arm[0], atol=1e-9)
    pin.framesForwardKinematics(model, data, q_linear)
    base = data.oMf[model.getFrameId("base")].homogeneous
    flange = data.oMf[model.getFrameId("tool0")].homogeneous
    expected = np.linalg.solve(base, flange @ tip)
    assert np.abs(target[:3, 3] - expected[:3, 3]).max() < 1e-8
    # the csv stream: commands at every sample
    csv_out = tmp_path / "csv"
    result = cli(
        ["export", "program", str(cell_dir), str(program), "--format", "csv"]
        + ["-o", str(csv_out), "--compensate"]
    )
    assert result.exit_code == 0, result.output
    table = np.loadtxt(next(csv_out.glob("*.csv")), delimiter=",", comments="#", skiprows=3)
    commands = table[:, 1:7]  # written to 1e-9 rad
    timed = simulate(load_run(str(cell_dir), str(program), 0.008), collisions=False)
    arm_q = timed.devices["ur5"].q
    assert np.abs(commands - arm_q).max() > 1e-4  # the yield is there to compensate
    np.testing.assert_allclose(commands + TRUE_COMPLIANCE * gravity(commands), arm_q, atol=2e-9)


def _solve_command(q_arm: np.ndarray, gravity) -> np.ndarray:
    """``q`` with ``q + c g(q) = q_arm``, by fixed-point iteration on Pinocchio's g."""
    q = q_arm.copy()
    for _ in range(100):
        q = q_arm - TRUE_COMPLIANCE * gravity([q])[0]
    return q


def test_an_overlay_names_a_bad_compliance_at_its_line(tmp_path, cli):
    from tests.conftest import WORKCELLS

    cell = tmp_path / "puma"
    shutil.copytree(WORKCELLS / "puma560", cell)
    data = yaml.safe_load((cell / "cell.yaml").read_text())
    pose_file = data["pose_files"][0]
    overlay = cell / "stiff.yaml"
    overlay.write_text(
        "units: {length: mm, angle: deg}\ncompliance:\n  puma.j2: 0.3\n  puma.j9: 0.1\n"
        "  puma.j3: -0.2\n"
    )
    data["pose_files"] = [pose_file, "stiff.yaml"]
    (cell / "cell.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    result = cli(["validate", str(cell)])
    assert result.exit_code == 2
    assert "stiff.yaml:4" in result.output and "unknown joint 'puma.j9'" in result.output
    assert "stiff.yaml:5" in result.output and "negative compliance" in result.output


def test_compliance_of_an_arm_without_masses_is_refused(cells, gravity, tmp_path, cli):
    nominal, truth_dir = cells
    massless = tmp_path / "massless"
    shutil.copytree(nominal, massless)
    cell = yaml.safe_load((massless / "cell.yaml").read_text())
    for link in cell["devices"][0]["links"]:
        link["mass"] = 0.0
    (massless / "cell.yaml").write_text(yaml.safe_dump(cell, sort_keys=False))
    fit = tmp_path / "fit.yaml"
    _observe(truth_dir, fit, 30, 1, gravity)
    out = tmp_path / "cal.yaml"
    result = cli(
        ["calibrate-robot", str(massless), str(fit), "--model", "compliance", "-o", str(out)]
    )
    assert result.exit_code == 2
    assert "holds no torque against gravity" in result.output
    assert "--model geometric" in result.output
    assert not out.exists()

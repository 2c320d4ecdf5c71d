"""Robot kinematic calibration (``rworld calibrate-robot``) on a UR5 from Universal Robots'
description whose true joint frames are off (lengths 0.5 mm, angles 0.05 deg, the tracker
reflector 0.5 mm), measured by a simulated laser tracker (0.02 mm per coordinate).

Run:  .venv/bin/python bench/robot_calibration.py [--trials 20] [--only compliance]

Also the Puma 560 of workcells/puma560 (standard DH: the errors as a pose before each row).
Printed per robot, over ``--trials`` truths and noise draws, with 50 fitting poses and 200
validation poses each:

1. the nominal model's position error on the validation poses (what the robot would be off
   without calibration);
2. the calibrated model's error against the truth itself (no instrument noise) beside the
   error the estimate's covariance predicts - the Cramer-Rao bound of an efficient estimator,
   evaluated at the same poses: the ratio says how close to the bound the fit is;
3. the identified parameter count, the observability index O1, and the estimate's error in the
   identified subspace against its covariance (chi-square per degree: 1 for an efficient
   estimator);
4. the wall time of the fit for 50 and for 1000 poses;
5. pose selection (``calibration.robotplan``) on 2000 random candidates: N = 10, 20, 30 chosen
   poses against N and 2N random ones and the optimal design's bound, and that bound's
   criterion per identified combination against the random spread's (1: random is optimal);
6. joint compliance (``--model compliance``): truths that also yield under gravity (joints 2,
   3 and 4: 5, 8 and 15 urad/Nm, each times a log-normal factor of spread 0.3), fitted with
   the geometric and with the compliance model on 60 poses: held-out rms against the truth
   and what each fit predicts there, the held-out rms with the instrument's noise, and the
   recovered compliances in their sigmas.
"""

from __future__ import annotations

import argparse
import time
from importlib.metadata import distribution
from pathlib import Path

import numpy as np


def _trial(model, lo, hi, sigma, trials, label) -> None:
    """``trials`` random truths (joint errors 0.5 mm and 0.05 deg, target 0.5 mm), fitted on 50
    poses and compared with the truth on 200 others; the estimate's error in the identified
    subspace against its covariance (a chi-square with as many degrees as identified)."""
    from rworld_cli.calibration.robot import identify
    from rworld_cli.model.measurements import RobotObservations

    n = model.device.dof
    nominal, calibrated, predicted, ranks, o1, chi2 = [], [], [], [], [], []
    for trial in range(trials):
        rng = np.random.default_rng(trial)
        truth = np.concatenate(
            [np.r_[rng.normal(0, 0.5e-3, 3), rng.normal(0, np.radians(0.05), 3)] for _ in range(n)]
            + [rng.normal(0, 0.5e-3, 3)]
        )
        q_fit = rng.uniform(lo, hi, (50, n))
        q_check = rng.uniform(lo, hi, (200, n))
        points = model.points(truth, q_fit) + rng.normal(0, sigma, (50, 3))
        result = identify(model, RobotObservations("r", "tip", "world", q_fit, points, sigma))
        exact = model.points(truth, q_check)
        d0 = np.linalg.norm(model.points(np.zeros_like(truth), q_check) - exact, axis=1)
        d1 = np.linalg.norm(model.points(result.p, q_check) - exact, axis=1)
        nominal.append(np.sqrt(np.mean(d0**2)))
        calibrated.append(np.sqrt(np.mean(d1**2)))
        predicted.append(result.predicted_rms(q_check))
        ranks.append(result.rank)
        o1.append(result.observability)
        # the error of the identifiable combinations: project through the covariance's range
        w, V = np.linalg.eigh(result.covariance)
        keep = w > w.max() * 1e-9
        z = V[:, keep].T @ (result.p - truth)
        # truth's unidentifiable part is not estimated: its projection is what the data hold
        chi2.append(float(np.sum(z**2 / w[keep])) / keep.sum())
    ratio = np.sqrt(np.mean(np.square(calibrated))) / np.sqrt(np.mean(np.square(predicted)))
    print(f"{label}: {trials} truths, 50 poses, tracker sigma {sigma * 1000} mm per coordinate")
    print(f"  nominal model on 200 other poses: rms {np.mean(nominal) * 1000:.3f} mm")
    print(
        f"  calibrated against the truth:     rms {np.mean(calibrated) * 1000:.4f} mm "
        f"(bound {np.mean(predicted) * 1000:.4f} mm, ratio {ratio:.3f})"
    )
    print(
        f"  identified {sorted(set(ranks))} of {len(model.names)}, O1 {np.mean(o1):.4g}; "
        f"chi-square / degrees of the identified error: {np.mean(chi2):.3f} (1 at the bound)"
    )
    for count in (50, 1000):
        rng = np.random.default_rng(99)
        q = rng.uniform(lo, hi, (count, n))
        points = model.points(np.zeros(len(model.names)), q) + rng.normal(0, sigma, (count, 3))
        obs = RobotObservations("r", "tip", "world", q, points, sigma)
        started = time.perf_counter()
        identify(model, obs)
        print(
            f"  fit of {count} poses, {len(model.names)} parameters: "
            f"{time.perf_counter() - started:.3f} s"
        )


def _compliance(model, holding, lo, hi, sigma, trials, label) -> None:
    """Truths with joint frames off and joints 2-4 yielding under gravity, fitted with the
    geometric and the compliance model (section 6 of the module docstring)."""
    import dataclasses

    from rworld_cli.calibration.robot import identify
    from rworld_cli.model.measurements import RobotObservations

    n = model.device.dof
    q_scale = np.random.default_rng(0).uniform(lo, hi, (256, n))
    scale = np.abs(holding(q_scale)).max(axis=0)
    compliant = dataclasses.replace(model, gravity=holding, compliant=(1, 2, 3), torque_scale=scale)
    stiff = dataclasses.replace(model, gravity=None)
    typical = np.array([5e-6, 8e-6, 1.5e-5])  # [rad/(N m)]
    rows: dict[str, list] = {"geometric": [], "compliance": []}
    z_scores: list[float] = []
    identified_joints: list[np.ndarray] = []
    for trial in range(trials):
        rng = np.random.default_rng(1000 + trial)
        c = typical * np.exp(rng.normal(0, 0.3, 3))
        truth = np.concatenate(
            [np.r_[rng.normal(0, 0.5e-3, 3), rng.normal(0, np.radians(0.05), 3)] for _ in range(n)]
            + [rng.normal(0, 0.5e-3, 3), c]
        )
        q_fit = rng.uniform(lo, hi, (60, n))
        q_check = rng.uniform(lo, hi, (200, n))
        points = compliant.points(truth, q_fit) + rng.normal(0, sigma, (60, 3))
        exact = compliant.points(truth, q_check)
        noisy = exact + rng.normal(0, sigma, exact.shape)
        obs = RobotObservations("r", "tip", "world", q_fit, points, sigma)
        for name, fitted_model in (("geometric", stiff), ("compliance", compliant)):
            result = identify(fitted_model, obs)
            at = fitted_model.points(result.p, q_check)
            rms = lambda d: float(np.sqrt(np.mean(np.sum(d**2, axis=1))))  # noqa: E731
            rows[name].append(
                (rms(at - exact), result.predicted_rms(q_check), rms(at - noisy), result.rank)
            )
            if name == "compliance":
                k = compliant.compliance_start + np.arange(3)
                taken = result.sigma[k] > 0  # identified (the others stay nominal)
                z_scores.extend(((result.p[k] - c) / np.where(taken, result.sigma[k], 1))[taken])
                identified_joints.append(taken)
    noise = sigma * np.sqrt(3)
    print(
        f"{label}: joint compliance, {trials} truths (joints 2-4 ~5, 8, 15 urad/Nm and joint "
        f"frames off), 60 poses, 200 held out, sigma {sigma * 1000} mm (held-out noise alone "
        f"{noise * 1000:.4f} mm)"
    )
    for name, values in rows.items():
        a = np.array(values)
        print(
            f"  {name:<10} model: against the truth rms {np.mean(a[:, 0]) * 1000:.4f} mm, "
            f"predicted {np.mean(a[:, 1]) * 1000:.4f} mm; held out with the noise "
            f"{np.mean(a[:, 2]) * 1000:.4f} mm (predicted "
            f"{np.mean(np.hypot(a[:, 1], noise)) * 1000:.4f}); identified "
            f"{sorted({int(r) for r in a[:, 3]})}"
        )
    z = np.array(z_scores)
    counts = np.sum(identified_joints, axis=0)
    print(
        f"  compliance of joints 2, 3, 4 identified in {', '.join(str(int(x)) for x in counts)} "
        f"of {trials} fits; recovered: error / sigma rms {np.sqrt(np.mean(z**2)):.3f} over "
        f"{len(z)} estimates (1 for an efficient estimator), largest {np.abs(z).max():.2f}"
    )


def _plan(model, lo, hi, sigma, label) -> None:
    """Pose selection against random poses and against the best any N poses can do."""
    from rworld_cli.calibration.robotplan import best_possible, information, select_poses

    rng = np.random.default_rng(0)
    n = model.device.dof
    pool = rng.uniform(lo, hi, (2000, n))
    print(f"{label}: pose selection among 2000 random candidates (sigma {sigma * 1000} mm)")
    for count in (10, 20, 30):
        _, f = select_poses(model, pool, count, sigma)
        print(
            f"  N = {count}: chosen {f['predicted'] * 1000:.4f} mm, N random "
            f"{f['random_same'] * 1000:.4f}, 2N random {f['random_double'] * 1000:.4f}, "
            f"best possible {f['best_possible'] * 1000:.4f} mm"
        )
    info = information(model, pool, rng.uniform(lo, hi, (1000, n)))
    print(
        f"  optimal design's criterion per identified combination: "
        f"{best_possible(info) / info.rank:.3f} (random spread: 1)"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--trials", type=int, default=20)
    parser.add_argument("--only", choices=["compliance"], default=None, help="run section 6 alone")
    args = parser.parse_args()
    import tempfile

    from lxml import etree

    from rworld_cli.api import import_urdf
    from rworld_cli.calibration.robot import RobotModel
    from rworld_cli.dynamics.compliance import holding_torques
    from rworld_cli.schema.loader import load_cell
    from rworld_cli.world.tree import World

    share = Path(str(distribution("example-robot-data").locate_file("cmeel.prefix/share")))
    urdf = share / "example-robot-data/robots/ur_description/urdf/ur5_robot.urdf"
    folder = Path(tempfile.mkdtemp())
    tree = etree.parse(str(urdf))
    for el in tree.xpath("//visual | //collision"):
        el.getparent().remove(el)
    tree.write(str(folder / "ur5.urdf"))
    import_urdf(str(folder / "ur5.urdf"), str(folder / "cell"), overlap_states=0)
    sigma = 2e-5
    for label, cell_dir, device, tcp, offset in (
        (
            "UR5 (joint frames, ur_description)",
            folder / "cell",
            "ur5",
            "ur5.tool0",
            [0.02, 0.01, 0.1],
        ),
        (
            "Puma 560 (standard DH, workcells/puma560)",
            Path("workcells/puma560"),
            "puma",
            "puma.probe",
            [0, 0, 0],
        ),
    ):
        cell = load_cell(str(cell_dir)).cell
        dev = cell.devices[device]
        world = World(cell)
        link, T_link_tcp = world.mount_of(device, tcp)
        tip = T_link_tcp @ np.r_[offset, 1.0]
        model = RobotModel(dev, np.linalg.inv(world.T_world(device)), link, tip[:3], False)
        lo = np.maximum(dev.limit_array("lower"), -np.pi)
        hi = np.minimum(dev.limit_array("upper"), np.pi)
        if args.only is None:
            _trial(model, lo, hi, sigma, args.trials, label)
            _plan(model, lo, hi, sigma, label)
        g_base = world.T_world(device)[:3, :3].T @ cell.gravity
        holding = holding_torques(dev, world.carried_loads(device), g_base)
        _compliance(model, holding, lo, hi, sigma, args.trials, label)


if __name__ == "__main__":
    main()

"""Probing that a robot can do: plan -> probe program -> probe (simulated) -> calibrate, in one run.

Run:  .venv/bin/python bench/probing.py [--seeds 30] [--sigma 0.02]

On workcells/probing (a Puma 560 with a 3 mm ball probe; an L-bracket mesh
located by three faces and two edges, a plate mesh by two faces and two
holes):

1. ``plan-measurements --program``: targets on material chosen by greedy
   D-optimal selection, reachable and collision-free, in a 2-opt order; the
   program passes the simulation check.  Printed: the share of targets on
   material (on the owner's mesh surface, the ball clear of the part), the
   predicted sigma of each frame against the same numbers of points spread
   uniformly, the wall time.
2. The program's cycle time (simulated) against the same targets visited in
   the planned order (frame by frame, feature by feature) without the
   ordering step.
3. A "true" cell (bracket and plate moved by up to 0.6 mm and 0.25 deg) is
   probed by the program once (each guarded move's first contact on the true
   parts); for each noise seed, Gaussian noise (sigma) is added, the frames
   calibrated, and their errors taken against the truth.  The Cramer-Rao
   bound is sigma^2 (J^T J)^-1 at the truth for the points actually probed;
   its median rotation and translation errors are drawn from it.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from rworld_cli import spatial  # noqa: E402
from rworld_cli.api import plan_cell_measurements  # noqa: E402
from rworld_cli.calibration.pipeline import calibrate  # noqa: E402
from rworld_cli.calibration.probe_run import measurement_features, probe_run  # noqa: E402
from rworld_cli.calibration.probing import probe_program  # noqa: E402
from rworld_cli.calibration.solve import _jacobian  # noqa: E402
from rworld_cli.collision.bodies import point_triangle_distance  # noqa: E402
from rworld_cli.geometry import shape_mesh, winding_number  # noqa: E402
from rworld_cli.model.measurements import Measurement, MeasurementSet  # noqa: E402
from rworld_cli.schema.loader import load_cell  # noqa: E402
from rworld_cli.schema.programs import load_run  # noqa: E402
from rworld_cli.simulate.engine import simulate  # noqa: E402
from rworld_cli.world.tree import World  # noqa: E402

CELL = REPO / "workcells" / "probing"
ARCSEC = np.pi / 648000
TRUTH = {  # owner -> (dx, dy, dz) m, (droll, dpitch, dyaw) deg, applied to the nominal pose
    "bracket": ([0.5e-3, -0.6e-3, 0.2e-3], [0.1, -0.08, 0.25]),
    "plate": ([-0.6e-3, 0.4e-3, -0.2e-3], [-0.07, 0.1, -0.2]),
}


def truth_cell(folder: Path) -> Path:
    """A copy of the probing cell with the parts moved by TRUTH (in their parent's frame)."""
    import shutil

    shutil.copytree(CELL, folder, dirs_exist_ok=True)
    poses = (folder / "poses.yaml").read_text()
    nominal = {
        "bracket": ([-0.08, -0.3, 0.0], [0, 0, 180]),
        "plate": ([-0.25, 0.1, 0.0], [0, 0, 0]),
    }
    for name, (xyz, rpy) in nominal.items():
        dxyz, drpy = TRUTH[name]
        R = spatial.rpy_to_matrix(np.radians(rpy)) @ spatial.rpy_to_matrix(np.radians(drpy))
        new_rpy = np.degrees(spatial.matrix_to_rpy(R))
        new_xyz = np.add(xyz, dxyz)
        old = next(line for line in poses.splitlines() if line.strip().startswith(f"{name}:"))
        poses = poses.replace(
            old,
            f"  {name}: {{xyz: [{', '.join(repr(float(x)) for x in new_xyz)}], rpy: "
            f"[{', '.join(repr(float(x)) for x in new_rpy)}]}}",
        )
    (folder / "poses.yaml").write_text(poses)
    return folder


def on_material(cell, plans) -> tuple[int, int]:
    """(targets on their owner's surface with the ball clear of the part, targets)."""
    world = World(cell)
    good = total = 0
    for plan in plans:
        for d in plan.directives:
            f = cell.features[d.feature]
            tri = shape_mesh(cell.objects[f.owner].shape).triangles()
            T = np.linalg.inv(world.T_world(f.owner))
            contacts = d.contacts @ T[:3, :3].T + T[:3, 3]
            centres = d.points @ T[:3, :3].T + T[:3, 3]
            surface = point_triangle_distance(contacts[:, None], tri[None]).min(axis=1)
            clear = point_triangle_distance(centres[:, None], tri[None]).min(axis=1)
            inside = winding_number(centres, tri) > 0.5
            # 1 um: the holes are 360-gons, their facets 0.4 um inside the nominal circle
            ok = (surface < 1e-6) & (clear >= d.probe_radius - 1e-6) & ~inside
            good += int(ok.sum())
            total += len(ok)
    return good, total


def cycle_time(cell_path: Path, text: str, folder: Path, name: str) -> tuple[float, bool]:
    path = folder / name
    path.write_text(text)
    result = simulate(load_run(str(cell_path), str(path)))
    return result.cycle_time, result.ok


def errors(T: np.ndarray, T_true: np.ndarray) -> tuple[float, float]:
    dR = T[:3, :3] @ T_true[:3, :3].T
    angle = float(np.arccos(np.clip((np.trace(dR) - 1) / 2, -1, 1)))
    return angle, float(np.linalg.norm(T[:3, 3] - T_true[:3, 3]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=30)
    parser.add_argument("--sigma", type=float, default=0.02, help="probing noise, mm")
    args = parser.parse_args()
    sigma = args.sigma / 1000
    cell = load_cell(str(CELL)).cell
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        t0 = time.perf_counter()
        result = plan_cell_measurements(
            str(CELL), None, 5e-5, 1e-4, program=str(tmp / "probe.yaml")
        )
        wall = time.perf_counter() - t0
        plans = result.plans
        good, total = on_material(cell, plans)
        print(f"plan-measurements --program: {wall:.1f} s (IK, collision checks, 2-opt, and the")
        print("  simulation check of the program)")
        print(f"targets on material: {good} of {total} ({100 * good / total:.0f} %); reachable and")
        print(f"  collision-free: the program passed the check ({result.stops} stops)")
        print()
        head = ("frame", "points", "D-optimal sigma", "uniform sigma", "ratio")
        print(f"{head[0]:8s} {head[1]:>6s} {head[2]:>22s} {head[3]:>22s} {head[4]:>6s}")
        for p in plans:
            n = sum(len(d.points) for d in p.directives)
            print(
                f"{p.frame:8s} {n:6d} {p.sigma_translation * 1e3:9.4f} mm "
                f'{p.sigma_rotation / ARCSEC:6.1f}" '
                f"{p.uniform_sigma_translation * 1e3:9.4f} mm "
                f'{p.uniform_sigma_rotation / ARCSEC:6.1f}" '
                f"{p.sigma_translation / p.uniform_sigma_translation:6.3f}"
            )
        # the same targets in the planned order (frame by frame, feature by feature)
        ordered_text, _ = probe_program(result.rig, plans, ordered=True)
        planned_text, _ = probe_program(result.rig, plans, ordered=False)
        t_ordered, ok1 = cycle_time(CELL, ordered_text, tmp, "ordered.yaml")
        t_planned, ok2 = cycle_time(CELL, planned_text, tmp, "planned.yaml")
        verdict = {True: "ok", False: "FAILED"}
        print()
        print(
            f"cycle time (simulated): ordered {t_ordered:.2f} s (check {verdict[ok1]}), "
            f"planned order {t_planned:.2f} s (check {verdict[ok2]}), ratio "
            f"{t_ordered / t_planned:.3f}"
        )
        # the round trip on a true cell
        truth_dir = truth_cell(tmp / "truth")
        truth = load_cell(str(truth_dir)).cell
        run = load_run(str(CELL), str(tmp / "probe.yaml"))
        sim = simulate(run, collisions=False)
        probed = probe_run(sim, run, truth)
        off = sum(p.off_edge for p in probed)
        true_world = World(truth)
        radius = float(cell.sensors["probe_ball"].ball)
        print()
        print(
            f"round trip: {len(probed)} probes, {off} off an edge, sigma {args.sigma} mm, "
            f"{args.seeds} noise seeds"
        )
        observed = {p.frame: [] for p in plans}
        for seed in range(args.seeds):
            features = measurement_features(cell, probed, sigma, seed)
            measured = MeasurementSet(
                {
                    name: Measurement(
                        name,
                        f.points,
                        f.above,
                        f.ordered,
                        radius,
                        "sim",
                        f.offset,
                        f.boss,
                        f.depth,
                    )
                    for name, f in features.items()
                },
                [],
                sigma,
            )
            res = calibrate(cell, measured)
            for frame in observed:
                observed[frame].append(
                    errors(res.solutions[frame].T_world, true_world.T_world(frame))
                )
        exact = measurement_features(cell, probed, 0.0, 0)
        rng = np.random.default_rng(0)
        print(
            f"{'frame':8s} {'CRB rot':>8s} {'rworld':>8s} {'ratio':>6s} {'CRB trans':>10s} "
            f"{'rworld':>8s} {'ratio':>6s}"
        )
        ratios = []
        for plan in plans:
            frame = plan.frame
            cond = next(c for c in cell.conditions if c.frame == frame)
            feats = [cell.features[f] for f in cond.features]
            fits = {
                f.name: type(
                    "Fit",
                    (),
                    {"points": exact[f.name].points, "n_points": len(exact[f.name].points)},
                )
                for f in feats
            }
            probing = {
                f.name: Measurement(
                    f.name,
                    exact[f.name].points,
                    None,
                    False,
                    radius,
                    "",
                    exact[f.name].offset,
                    exact[f.name].boss,
                    exact[f.name].depth,
                ).probing
                for f in feats
            }
            J = _jacobian(feats, fits, probing, true_world.T_world(frame))
            crb = sigma**2 * np.linalg.inv(J.T @ J)
            draws = rng.multivariate_normal(np.zeros(6), crb, 200000)
            crb_rot = np.median(np.linalg.norm(draws[:, :3], axis=1))
            crb_trans = np.median(np.linalg.norm(draws[:, 3:], axis=1))
            rot = np.median([e[0] for e in observed[frame]])
            trans = np.median([e[1] for e in observed[frame]])
            ratios += [rot / crb_rot, trans / crb_trans]
            print(
                f'{frame:8s} {crb_rot / ARCSEC:7.1f}" {rot / ARCSEC:7.1f}" {rot / crb_rot:6.3f} '
                f"{crb_trans * 1e3:7.4f} mm {trans * 1e3:5.4f} {trans / crb_trans:6.3f}"
            )
        print(f"largest ratio to the Cramer-Rao bound: {max(ratios):.3f}")


if __name__ == "__main__":
    main()

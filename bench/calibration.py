"""Calibration accuracy against the Cramer-Rao bound, on five feature sets, in one run.

Run:  .venv/bin/python bench/calibration.py [--trials 300] [--sigma 0.05]

For each scenario - a box probed on 6 planes, on 3 planes, on 2 edges
(lines); an L-bracket by an edge and 2 planes; a plate by 2 planes and a
hole (circle) - 10 points per feature are spread over the features, moved
by a fixed "true" pose, and disturbed by Gaussian noise (sigma, mm).  Each
trial solves the natural frame (C2: oriented features) by the report's
closed form alone and by rworld (closed form + maximum likelihood).  The
Cramer-Rao bound is sigma^2 (J^T J)^-1 at the truth; its median rotation
and translation errors are drawn from that covariance.  Also: the predicted
standard error (from the fit) against the observed spread, and noiseless
recovery.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from rworld_cli import spatial  # noqa: E402
from rworld_cli.calibration.fit import fit_circle, fit_line, fit_plane  # noqa: E402
from rworld_cli.calibration.solve import _jacobian, closed_form, solve_natural  # noqa: E402
from rworld_cli.model.cell import Feature  # noqa: E402

ARCSEC = np.pi / 648000
TRUTH = spatial.make_transform(
    spatial.rpy_to_matrix(np.radians([3.0, -2.0, 25.0])), [0.4, -0.1, 0.75]
)


def plane(name, point, normal, u_extent, v_extent, n):
    normal = np.asarray(normal, float) / np.linalg.norm(normal)
    u = np.cross(normal, [1, 0, 0] if abs(normal[0]) < 0.9 else [0, 1, 0])
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    k = int(np.ceil(np.sqrt(n)))
    gu, gv = np.meshgrid(
        np.linspace(-0.35, 0.35, k) * u_extent, np.linspace(-0.35, 0.35, k) * v_extent
    )
    pts = np.asarray(point) + gu.ravel()[:n, None] * u + gv.ravel()[:n, None] * v
    return Feature(name, "o", "plane", np.asarray(point, float), normal), pts


def line(name, point, direction, length, n):
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    return Feature(name, "o", "line", np.asarray(point, float), d), np.asarray(point) + np.linspace(
        -0.35, 0.35, n
    )[:, None] * length * d


def circle(name, center, normal, radius, n):
    normal = np.asarray(normal, float) / np.linalg.norm(normal)
    u = np.cross(normal, [1, 0, 0])
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    a = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return Feature(name, "o", "circle", np.asarray(center, float), normal, radius), np.asarray(
        center
    ) + radius * (np.cos(a)[:, None] * u + np.sin(a)[:, None] * v)


def scenarios(n=10):
    L, W, H = 0.2, 0.15, 0.1  # the box, centred
    faces = [
        ((0, 0, H / 2), (0, 0, 1), L, W),
        ((0, 0, -H / 2), (0, 0, -1), L, W),
        ((L / 2, 0, 0), (1, 0, 0), W, H),
        ((-L / 2, 0, 0), (-1, 0, 0), W, H),
        ((0, W / 2, 0), (0, 1, 0), L, H),
        ((0, -W / 2, 0), (0, -1, 0), L, H),
    ]
    box6 = [plane(f"p{k}", *f, n) for k, f in enumerate(faces)]
    box3 = [plane(f"p{k}", *faces[k], n) for k in (0, 2, 5)]
    lines2 = [
        line("e0", (0, -W / 2, H / 2), (1, 0, 0), L, n),
        line("e1", (L / 2, 0, H / 2), (0, 1, 0), W, n),
    ]
    bracket = [
        line("e0", (0, 0, 0.05), (1, 0, 0), 0.12, n),
        plane("p0", (0, -0.02, 0.0), (0, -1, 0), 0.12, 0.05, n),
        plane("p1", (0.06, 0.0, 0.025), (1, 0, 0), 0.04, 0.05, n),
    ]
    plate = [
        plane("p0", (0, 0, 0.005), (0, 0, 1), 0.2, 0.2, n),
        plane("p1", (0.1, 0, 0), (1, 0, 0), 0.2, 0.01, n),
        circle("c0", (0.03, 0.04, 0.005), (0, 0, 1), 0.02, n),
    ]
    return {
        "box, 6 planes": box6,
        "box, 3 planes": box3,
        "box, 2 lines": lines2,
        "L-bracket, line + 2 planes": bracket,
        "plate, 2 planes + hole": plate,
    }


def fits_for(items, T, rng, sigma):
    fits = {}
    for f, pts in items:
        w = pts @ T[:3, :3].T + T[:3, 3] + rng.normal(0, sigma, pts.shape)
        if f.kind == "plane":
            above = T[:3, :3] @ (f.point + 0.01 * f.direction) + T[:3, 3]
            fits[f.name] = fit_plane(f.name, w, above)
        elif f.kind == "line":
            fits[f.name] = fit_line(f.name, w, ordered=True)
        else:
            above = T[:3, :3] @ (f.point + 0.01 * f.direction) + T[:3, 3]
            fits[f.name] = fit_circle(f.name, w, above)
    return fits


def rotation_angle(Ta, Tb):
    return float(np.linalg.norm(spatial.rotation_vector(Ta[:3, :3].T @ Tb[:3, :3])))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=300)
    parser.add_argument("--sigma", type=float, default=0.05, help="mm")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    sigma = args.sigma / 1000
    print(
        f"sigma {args.sigma} mm, 10 points per feature, {args.trials} trials; median rotation "
        "error in arcsec\n"
    )
    print(
        f"{'scenario':28s} {'CRB':>7s} {'rworld':>7s} {'ratio':>6s} {'closed':>7s} {'ratio':>6s} "
        f"{'pred/obs sigma':>15s} {'noiseless':>10s}"
    )
    rng = np.random.default_rng(args.seed)
    for name, items in scenarios().items():
        features = [f for f, _ in items]
        exact = fits_for(items, TRUTH, rng, 0.0)
        J = _jacobian(features, exact, {}, TRUTH)
        crb = sigma**2 * np.linalg.inv(J.T @ J)
        draws = rng.multivariate_normal(np.zeros(6), crb, 200000)
        crb_rot = np.median(np.linalg.norm(draws[:, :3], axis=1)) / ARCSEC
        noiseless = solve_natural("o", "C2", features, exact, {}, np.eye(4))
        noiseless_err = float(np.abs(noiseless.T_world - TRUTH).max())
        ml, cf, predicted, deviations = [], [], [], []
        for _ in range(args.trials):
            fits = fits_for(items, TRUTH, rng, sigma)
            sol = solve_natural("o", "C2", features, fits, {}, np.eye(4), sigma=None)
            T_cf, _ = closed_form("C2", features, fits)
            ml.append(rotation_angle(sol.T_world, TRUTH) / ARCSEC)
            cf.append(rotation_angle(T_cf, TRUTH) / ARCSEC)
            predicted.append(np.sqrt(np.diag(sol.covariance)))
            dR = spatial.rotation_vector(sol.T_world[:3, :3] @ TRUTH[:3, :3].T)
            deviations.append(np.r_[dR, sol.T_world[:3, 3] - TRUTH[:3, 3]])
        ratio_spread = np.median(np.array(predicted), axis=0) / np.std(np.array(deviations), axis=0)
        print(
            f"{name:28s} {crb_rot:7.1f} {np.median(ml):7.1f} {np.median(ml) / crb_rot:6.3f} "
            f"{np.median(cf):7.1f} "
            f"{np.median(cf) / crb_rot:6.3f} "
            f"{ratio_spread.min():7.2f}..{ratio_spread.max():<5.2f} {noiseless_err:10.1e}"
        )
    print(
        "\nratio = median error / Cramer-Rao median; pred/obs sigma = predicted standard error / "
        "observed spread "
        "(range over the 6 pose coordinates); noiseless = max |T - T_true| element"
    )


if __name__ == "__main__":
    main()

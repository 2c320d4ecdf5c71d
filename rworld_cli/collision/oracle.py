"""Reference distances for convex primitives, independent of the GJK code in :mod:`.convex`.

For tests and benches (``tests/collision``, ``bench/collision.py``), as
:mod:`rworld_cli.sensing.exact` is for sensing: closed forms for a point against a box or a
cylinder (so sphere pairs), the enumeration of vertex-box and edge-edge distances for two
disjoint boxes, and for cylinder pairs the convex problem min |x - y| over the cylinder's points
solved by scipy (SLSQP, several starts).  None of it shares code with the production path.
"""

from __future__ import annotations

import numpy as np


def point_box(p: np.ndarray, T: np.ndarray, half: np.ndarray) -> np.ndarray:
    """Distance from points (N, 3) to boxes (N): clamp in the box frame."""
    local = np.einsum("nji,nj->ni", T[:, :3, :3], p - T[:, :3, 3])
    return np.linalg.norm(np.maximum(np.abs(local) - half, 0.0), axis=1)


def point_cylinder(p, T, r, h) -> np.ndarray:
    """Distance from points to solid cylinders (axis z of T, radius r, half length h)."""
    local = np.einsum("nji,nj->ni", T[:, :3, :3], p - T[:, :3, 3])
    radial = np.maximum(np.hypot(local[:, 0], local[:, 1]) - r, 0.0)
    axial = np.maximum(np.abs(local[:, 2]) - h, 0.0)
    return np.hypot(radial, axial)


def segment_segment(p0, p1, q0, q1) -> np.ndarray:
    """Least distance between segments (closed form with clamping; Ericson 5.1.9), vectorised."""
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a = np.einsum("...i,...i", d1, d1)
    e = np.einsum("...i,...i", d2, d2)
    f = np.einsum("...i,...i", d2, r)
    c = np.einsum("...i,...i", d1, r)
    b = np.einsum("...i,...i", d1, d2)
    denom = a * e - b * b
    s = np.where(
        denom > 1e-18, np.clip((b * f - c * e) / np.where(denom > 1e-18, denom, 1), 0, 1), 0
    )
    t = (b * s + f) / e
    s = np.where(t < 0, np.clip(-c / a, 0, 1), np.where(t > 1, np.clip((b - c) / a, 0, 1), s))
    t = np.clip(t, 0, 1)
    return np.linalg.norm(p0 + d1 * s[..., None] - (q0 + d2 * t[..., None]), axis=-1)


CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
EDGES = [(i, j) for i in range(8) for j in range(i + 1, 8) if np.sum(CORNERS[i] != CORNERS[j]) == 1]


def box_box(Ta, ha, Tb, hb) -> np.ndarray:
    """Exact distance of disjoint boxes: vertex-box and edge-edge candidates."""
    va = Ta[:, None, :3, 3] + np.einsum("nij,vj->nvi", Ta[:, :3, :3], CORNERS * ha)
    vb = Tb[:, None, :3, 3] + np.einsum("nij,vj->nvi", Tb[:, :3, :3], CORNERS * hb)
    n = len(Ta)
    best = np.full(n, np.inf)
    for k in range(8):
        best = np.minimum(best, point_box(va[:, k], Tb, hb))
        best = np.minimum(best, point_box(vb[:, k], Ta, ha))
    for i, j in EDGES:
        for k, m in EDGES:
            best = np.minimum(best, segment_segment(va[:, i], va[:, j], vb[:, k], vb[:, m]))
    return best


def cylinder_points(T, r, h, u):
    """Points of a solid cylinder from parameters u (..., 3) in [0, 1]^3 (area-uniform)."""
    rho = r * np.sqrt(u[..., 0])
    phi = 2 * np.pi * u[..., 1]
    z = h * (2 * u[..., 2] - 1)
    local = np.stack([rho * np.cos(phi), rho * np.sin(phi), z], axis=-1)
    return local @ T[:3, :3].T + T[:3, 3]


def cylinder_distance(Ta, ra, ha, other_distance) -> float:
    """min over the cylinder's points of the distance to the other solid (a convex problem)."""
    from scipy.optimize import minimize

    best = np.inf
    for start in ([0.5, 0.5, 0.5], [0.9, 0.1, 0.1], [0.9, 0.6, 0.9], [0.2, 0.3, 0.95]):

        def f(x):
            rho, phi, z = x
            p = Ta[:3, :3] @ np.array([rho * np.cos(phi), rho * np.sin(phi), z]) + Ta[:3, 3]
            return other_distance(p)

        res = minimize(
            f,
            [ra * start[0], 2 * np.pi * start[1], ha * (2 * start[2] - 1)],
            method="SLSQP",
            bounds=[(0, ra), (-10, 10), (-ha, ha)],
            options={"ftol": 1e-15, "maxiter": 500},
        )
        best = min(best, res.fun)
    return float(best)

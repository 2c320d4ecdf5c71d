"""Exact distances of convex pieces against independent oracles, on thousands of random poses.

Each test runs twice: on the compiled GJK (``collision/compiled.py``) and on the numpy GJK that
``RWORLD_KERNELS=numpy`` selects.  Oracles (none shares code with rworld_cli.collision):

* sphere-sphere, sphere-box, sphere-cylinder: closed forms (point to solid, minus the radius);
* box-box: the least of the 16 vertex-to-box distances and the 144 edge-to-edge distances
  (exact for two disjoint boxes), and for overlap the 15-axis separating-axis test of
  ``geometry.obb_overlap``;
* cylinder pairs: the convex problem min |x - y| solved by scipy (SLSQP) from the point-to-
  cylinder closed form, and for overlap a witness point found inside both.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from rworld_cli.collision import convex as cv
from rworld_cli.collision.oracle import (
    box_box,
    cylinder_distance,
    cylinder_points,
    point_box,
    point_cylinder,
)
from rworld_cli.geometry import obb_overlap

TOL = 1e-9  # m, the required distance accuracy on primitives


@pytest.fixture(autouse=True, params=["llvm", "numpy"])
def gjk_backend(request, monkeypatch):
    """Every oracle test runs on the compiled GJK and on the numpy fallback."""
    monkeypatch.setenv("RWORLD_KERNELS", request.param)
    return request.param


def random_poses(n: int, seed: int, spread: float = 0.35) -> np.ndarray:
    rng = np.random.default_rng(seed)
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, :3, :3] = Rotation.random(n, random_state=seed).as_matrix()
    T[:, :3, 3] = rng.uniform(-spread, spread, (n, 3))
    return T


# --------------------------------------------------------------------------- tests


def test_sphere_pairs_match_closed_forms():
    n = 4000
    Ta, Tb = random_poses(n, 1), random_poses(n, 2)
    rb = np.full(n, 0.08)
    sph = cv.spheres(Ta[:, :3, 3], np.full(n, 0.1))
    # sphere - sphere
    got = cv.distance(sph, cv.spheres(Tb[:, :3, 3], rb))
    want = np.maximum(np.linalg.norm(Ta[:, :3, 3] - Tb[:, :3, 3], axis=1) - 0.18, 0)
    assert np.max(np.abs(got.distance - want)) < TOL
    assert np.array_equal(got.overlap, want <= 0)
    # sphere - box
    half = np.array([0.12, 0.05, 0.2])
    got = cv.distance(sph, cv.boxes(Tb, half))
    d = point_box(Ta[:, :3, 3], Tb, half) - 0.1
    assert np.max(np.abs(got.distance - np.maximum(d, 0))) < TOL
    assert np.array_equal(got.overlap, d <= 0)
    # sphere - cylinder
    got = cv.distance(sph, cv.cylinders(Tb, 0.06, 0.15))
    d = point_cylinder(Ta[:, :3, 3], Tb, 0.06, 0.15) - 0.1
    sep = np.abs(d) > TOL
    assert np.max(np.abs(got.distance - np.maximum(d, 0))[sep]) < TOL
    assert np.array_equal(got.overlap[sep], (d <= 0)[sep])
    # closest points lie on the surfaces and are the distance apart
    far = got.distance > 1e-6
    gap = np.linalg.norm(got.point_a[far] - got.point_b[far], axis=1)
    assert np.max(np.abs(gap - got.distance[far])) < TOL


def test_box_pairs_match_enumeration_and_separating_axes():
    n = 3000
    Ta, Tb = random_poses(n, 3), random_poses(n, 4)
    ha, hb = np.array([0.05, 0.1, 0.15]), np.array([0.1, 0.05, 0.025])
    got = cv.distance(cv.boxes(Ta, ha), cv.boxes(Tb, hb))
    overlap = obb_overlap(Ta, np.tile(ha, (n, 1)), Tb, np.tile(hb, (n, 1)))
    want = box_box(Ta, ha, Tb, hb)
    # decisions: exact separating axes, except pairs within the tolerance of touching
    clear = ~overlap & (want > TOL) | overlap & (got.distance == 0)
    assert np.array_equal(got.overlap[clear], overlap[clear])
    assert np.sum(~clear) <= 2
    sep = ~overlap
    assert sep.sum() > 1000 and overlap.sum() > 100
    assert np.max(np.abs(got.distance[sep] - want[sep])) < TOL
    # penetration of overlapping boxes: at most the smallest full box extent, and separating
    # them along the reported normal by the reported depth leaves them touching
    depth, normal = cv.penetration(cv.boxes(Ta[overlap], ha), cv.boxes(Tb[overlap], hb))
    assert np.all(depth > 0) and np.all(depth <= 2 * hb.max() + 2 * ha.max())
    moved = Tb[overlap].copy()
    moved[:, :3, 3] += (depth + 1e-7)[:, None] * normal
    after = cv.distance(cv.boxes(Ta[overlap], ha), cv.boxes(moved, hb))
    assert np.all(after.distance < 1e-6) and not after.overlap.any()


@pytest.mark.parametrize("other", ["box", "cylinder"])
def test_cylinder_pairs_match_a_convex_solver(other):
    n = 150
    Ta, Tb = random_poses(n, 5, 0.3), random_poses(n, 6, 0.3)
    ra, ha = 0.05, 0.15
    cyl = cv.cylinders(Ta, ra, ha)
    if other == "box":
        hb = np.array([0.1, 0.05, 0.025])
        got = cv.distance(cyl, cv.boxes(Tb, hb))
        to_other = lambda k: lambda p: point_box(p[None], Tb[k : k + 1], hb)[0]  # noqa: E731
        inside = lambda pts, k: point_box(pts, np.repeat(Tb[k : k + 1], len(pts), 0), hb) == 0  # noqa: E731
    else:
        rb, hb2 = 0.04, 0.1
        got = cv.distance(cyl, cv.cylinders(Tb, rb, hb2))
        to_other = (
            lambda k: (  # noqa: E731
                lambda p: point_cylinder(p[None], Tb[k : k + 1], rb, hb2)[0]
            )
        )
        inside = (
            lambda pts, k: (  # noqa: E731
                point_cylinder(pts, np.repeat(Tb[k : k + 1], len(pts), 0), rb, hb2) == 0
            )
        )
    u = np.random.default_rng(7).uniform(size=(4000, 3))
    checked = 0
    for k in range(n):
        witness = inside(cylinder_points(Ta[k], ra, ha, u), k).any()
        if witness:
            assert got.overlap[k], k
            continue
        want = cylinder_distance(Ta[k], ra, ha, to_other(k))
        if want > 1e-6:
            assert not got.overlap[k], k
            assert abs(got.distance[k] - want) < TOL, (k, got.distance[k], want)
            checked += 1
    assert checked > 50


def test_triangles_and_degenerate_inputs():
    # a triangle above a box: the distance is the height gap
    tri = np.array([[[0, 0, 0.3], [0.1, 0, 0.3], [0, 0.1, 0.3]]], dtype=float)
    got = cv.distance(cv.triangles(tri), cv.boxes(np.eye(4)[None], [0.2, 0.2, 0.1]))
    assert got.distance[0] == pytest.approx(0.2, abs=TOL)
    # coincident centres: no division by zero, full overlap
    same = cv.distance(cv.spheres(np.zeros((1, 3)), [0.1]), cv.boxes(np.eye(4)[None], [0.1] * 3))
    assert same.overlap[0] and same.distance[0] == 0
    # out of iterations: the reported distance is GJK's lower bound, never above the truth
    T = random_poses(300, 8)
    a, b = cv.cylinders(np.tile(np.eye(4), (300, 1, 1)), 0.05, 0.15), cv.cylinders(T, 0.04, 0.1)
    rough, exact = cv.distance(a, b, max_iterations=3), cv.distance(a, b)
    assert np.all(rough.distance <= exact.distance + TOL)
    assert np.all(rough.distance + rough.error >= exact.distance - TOL)


def test_climbing_a_box_by_its_closed_form_neighbours_finds_the_best_corner():
    """``box_neighbours`` (three per corner, no hull computed): from any corner, climbing
    to a better neighbour until none is better ends at the corner a scan finds, for boxes
    flat or not (seeded directions and extents)."""
    rng = np.random.default_rng(3)
    neighbours = cv.box_neighbours(8)
    for half in (np.array([0.1, 0.2, 0.3]), np.array([0.1, 0.0, 0.3]), np.array([0.0, 0.0, 0.2])):
        corners = cv.box_corners(half)
        for d in rng.normal(size=(200, 3)):
            value = corners @ d
            for start in range(8):
                at = start
                while True:
                    better = [n for n in neighbours[at] if n >= 0 and value[n] > value[at]]
                    if not better:
                        break
                    at = max(better, key=lambda n: value[n])
                assert value[at] == value.max()

"""The planning runtime of issue 17, kept exact.

- rworld's own cubic splines are scipy's CubicSpline (each boundary, random knots), so dropping
  the scipy.interpolate import changed no path.
- The torque bound's default density (``check_cells``) still keeps 10x denser sampling within the
  limits, on the reference Puma problem and the UR5 natural spline.
- The payload search's mass family (torque affine in a point mass) gives the same coefficients as
  a device built with that mass.
- Repairs re-solve locally: the incremental passes give the full passes' answer.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from rworld_cli.dynamics import DeviceDynamics, Payload
from rworld_cli.planning.constraints import PathGrid, check_cells, path_coefficients
from rworld_cli.planning.path import JointPath
from rworld_cli.planning.payload import PointMassFamily
from rworld_cli.planning.topp import (
    _Stages,
    constraints_from_limits,
    limit_ratios,
    sample_trajectory,
    time_optimal,
)
from tests.planning.test_limits import ur5_case
from tests.planning.test_planning import CONFIGS, DYN, PATH, G


@pytest.mark.parametrize("boundary", ["clamped", "natural", "not-a-knot"])
def test_splines_are_scipys(boundary):
    rng = np.random.default_rng(3)
    worst = 0.0
    for _ in range(60):
        k = int(rng.integers(2, 10))
        inner = np.sort(rng.uniform(0.05, 0.95, k - 2))
        if k > 2 and np.diff(np.r_[0.0, inner, 1.0]).min() < 0.02:
            continue
        knots = np.r_[0.0, inner, 1.0]
        values = rng.normal(size=(k, 4))
        ours = JointPath(values, knots, boundary)
        theirs = CubicSpline(knots, values, bc_type=boundary)
        s = np.r_[np.linspace(0.0, 1.0, 401), knots]
        for order, got in enumerate(ours.evaluate(s)):
            ref = theirs(s, order)
            worst = max(worst, float(np.abs(got - ref).max() / max(1.0, np.abs(ref).max())))
    assert worst <= 1e-12


def test_spline_pieces_interpolate_and_join_smoothly():
    path = JointPath(np.radians([[0, 10], [40, -20], [10, 30], [60, 0]]), [0, 0.2, 0.7, 1.0])
    breaks, c = path.pieces
    assert c.shape == (4, 3, 2)
    q, dq, ddq = path.evaluate(breaks)
    assert np.allclose(q, path.waypoints, atol=1e-12)
    assert np.allclose(dq[[0, -1]], 0.0, atol=1e-12)  # clamped
    eps = 1e-9
    for order, (left, right) in enumerate(
        zip(path.evaluate(breaks[1:-1] - eps), path.evaluate(breaks[1:-1] + eps))
    ):
        assert np.allclose(left, right, atol=1e-6), order  # C2 across the knots


def _polyline(rng, count: int, n: int = 4):
    return np.cumsum(rng.normal(size=(count, n)), axis=0)


def test_a_blended_path_without_blends_is_the_segments_path():
    rng = np.random.default_rng(5)
    way = _polyline(rng, 6)
    from rworld_cli.planning.path import length_knots

    blended = JointPath(way, None, "blended")
    segments = JointPath(way, length_knots(way), "segments")
    s = np.linspace(0, 1, 1001)
    for got, ref in zip(blended.evaluate(s), segments.evaluate(s)):
        assert np.array_equal(got, ref)


def test_blends_are_the_bezier_curves_joining_the_lines_with_their_slopes():
    """Random polylines and blends: each blend is the quadratic Bezier curve of its ends and
    corner (what the planner checks), dq/ds is continuous everywhere (the device moves
    through blended corners) and zero at the corners at rest, and every joint stays within
    the range of the waypoints (the blends lie in their corners' triangles)."""
    from rworld_cli.planning.path import blend_corners

    rng = np.random.default_rng(6)
    for _ in range(40):
        way = _polyline(rng, int(rng.integers(3, 8)))
        blends = np.r_[0.0, rng.choice([0.0, 0.1, 0.3, 0.5], len(way) - 2), 0.0]
        path = JointPath(way, None, "blended", blends)
        knots = path.knots
        h = np.diff(knots)
        tau = np.r_[0.0, blends[1:-1] * np.minimum(h[:-1], h[1:]), 0.0]
        ends = blend_corners(knots, way, blends)
        for k in np.flatnonzero(blends):
            u = np.linspace(0, 1, 51)
            q = path.evaluate(knots[k] - tau[k] + 2 * tau[k] * u)[0]
            u = u[:, None]
            bezier = (1 - u) ** 2 * ends[k, 0] + 2 * u * (1 - u) * ends[k, 1] + u**2 * ends[k, 2]
            assert np.abs(q - bezier).max() < 1e-12
        breaks, c = path.pieces
        inner = breaks[1:-1]
        eps = 1e-9
        left, right = path.evaluate(inner - eps), path.evaluate(inner + eps)
        assert np.abs(left[0] - right[0]).max() < 1e-7
        assert np.abs(left[1] - right[1]).max() < 1e-5 * max(1.0, np.abs(c[2]).max())
        dq_at_knots = path.evaluate(knots)[1]
        rest = blends == 0
        assert np.abs(dq_at_knots[rest]).max() < 1e-9
        q_min, _, q_max, _ = path.extrema()
        assert (q_min >= way.min(axis=0) - 1e-12).all()
        assert (q_max <= way.max(axis=0) + 1e-12).all()


def test_a_blended_corner_is_timed_without_stopping_and_sooner():
    """The time-optimal timing of a path blended at every corner is shorter than at rest at
    every via point, within the same limits (the exact between-grid check)."""
    from rworld_cli.planning.topp import Limits

    rng = np.random.default_rng(7)
    way = _polyline(rng, 5, 3)
    limits = Limits(np.full(3, 2.0), np.full(3, 5.0), None)
    at_rest = time_optimal(JointPath(way, None, "blended"), limits)[0]
    blended = JointPath(way, None, "blended", np.r_[0, 0.5, 0.5, 0.5, 0])
    fast, info = time_optimal(blended, limits)
    assert fast.duration < 0.95 * at_rest.duration
    t, q, qd, qdd = sample_trajectory(blended, fast, 4001)
    ratios = limit_ratios(q, qd, qdd, limits)
    assert ratios["velocity"].max() <= 1 + 1e-9 and ratios["acceleration"].max() <= 1 + 1e-6
    s_knots = blended.knots[1:-1]
    speed = np.interp(s_knots, fast.s, np.sqrt(np.maximum(fast.x, 0)))
    assert (speed > 0.05).all()  # sdot at the via points: moving


def test_bad_blends_are_refused():
    way = np.eye(3)
    with pytest.raises(ValueError, match="one per waypoint"):
        JointPath(way, None, "blended", [0, 0.6, 0])
    with pytest.raises(ValueError, match="ends are not blended"):
        JointPath(way, None, "blended", [0.1, 0.2, 0])
    with pytest.raises(ValueError, match="knots follow its joint-space lengths"):
        JointPath(way, [0, 0.2, 1], "blended")
    with pytest.raises(ValueError, match="blends are for boundary 'blended'"):
        JointPath(way, None, "segments", [0, 0, 0])


def test_unknown_boundary_is_refused():
    with pytest.raises(ValueError, match="boundary"):
        JointPath(np.zeros((3, 2)), None, "periodic")


def test_default_check_density():
    assert check_cells(99) == 1000 and check_cells(999) == 3996


@pytest.mark.parametrize("config", ["b_rated", "b_aggr", "c_vtau"])
@pytest.mark.parametrize("grid", [100, 500])
def test_default_torque_bound_holds_ten_times_denser(config, grid):
    """At the default density (1 000 fine cells at these grids) 200 001 instants and both sides
    of every grid instant find no limit exceeded."""
    limits, _ = CONFIGS[config]
    timing, info = time_optimal(PATH, limits, DYN, G, grid)
    assert info["dense_ratio"] <= 1.0
    _, q, qd, qdd = sample_trajectory(PATH, timing, 200001, switches=True)
    for name, ratio in limit_ratios(q, qd, qdd, limits, DYN, G).items():
        assert ratio.max() <= 1.0, (name, ratio.max())


@pytest.mark.parametrize("grid", [100, 300])
def test_default_torque_bound_holds_on_the_ur5_natural_spline(grid):
    path, limits, dyn = ur5_case()
    g = np.array([0, 0, -9.81])
    timing, _ = time_optimal(path, limits, dyn, g, grid)
    _, q, qd, qdd = sample_trajectory(path, timing, 200001, switches=True)
    ratios = limit_ratios(q, qd, qdd, limits, dyn, g)
    assert ratios["torque"].max() <= 1.0 and ratios["velocity"].max() <= 1.0


def test_point_mass_family_is_the_device_with_that_mass():
    device = DYN.device
    com = np.array([0.01, -0.02, 0.1])
    family = PointMassFamily(
        *(
            DeviceDynamics(device, Payload.point_mass(m, com), armature=True, friction=False)
            for m in (0.0, 1.0)
        )
    )
    s = np.linspace(0.0, 1.0, 301)
    for mass in (0.0, 2.5, 7.25):
        got = family.at(mass).torque_coefficients(PATH, s, G)
        direct = DeviceDynamics(
            device, Payload.point_mass(mass, com), armature=True, friction=False
        )
        want = path_coefficients(PATH, s, direct, G)[3]
        for a, b in zip(got, want):
            assert np.abs(a - b).max() <= 1e-10 * max(1.0, np.abs(b).max())
    assert len(family._cache) == 1  # one pair of Newton-Euler passes served every mass


@pytest.mark.parametrize("config", ["b_rated", "b_aggr"])
def test_incremental_passes_equal_full_passes(config):
    """A repair round re-solves only around the changed caps; the result is the full solve's."""
    limits, _ = CONFIGS[config]
    s = np.linspace(0.0, 1.0, 200)
    constraints = constraints_from_limits(limits, DYN, G)
    for c in constraints:
        c.prepare(PATH, s)
    stages = _Stages(PathGrid(s, *PATH.evaluate(s)), constraints)
    caps = np.full(len(s), np.inf)
    K_lo, K_hi, _ = stages.backward(caps, True)
    x, u, binding = stages.forward(K_lo, K_hi, caps, [""] * len(s))
    rng = np.random.default_rng(5)
    for _ in range(5):
        new_caps = caps.copy()
        picked = rng.choice(len(s) - 2, 6, replace=False) + 1
        new_caps[picked] = np.minimum(new_caps[picked], x[picked] * rng.uniform(0.5, 0.99, 6))
        full_lo, full_hi, _ = stages.backward(new_caps, True)
        full = stages.forward(full_lo, full_hi, new_caps, [""] * len(s))
        inc_lo, inc_hi, lowest = stages.backward(new_caps, True, (K_lo, K_hi, caps))
        changed = np.flatnonzero(new_caps != caps)
        first, last = min(lowest, int(changed[0])), int(changed[-1])
        inc = stages.forward(inc_lo, inc_hi, new_caps, [""] * len(s), (x, u, binding, first, last))
        assert inc_lo == full_lo and inc_hi == full_hi
        assert np.array_equal(inc[0], full[0]) and np.array_equal(inc[1], full[1])
        caps, K_lo, K_hi, (x, u, binding) = new_caps, inc_lo, inc_hi, inc

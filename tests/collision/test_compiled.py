"""The compiled GJK (``collision/compiled.py``) against the numpy GJK it mirrors.

The oracle tests of ``test_convex.py`` run on both; here the two are compared with each other on
the pairs where rounding matters most (boxes and cylinders, many of them touching), and the
compiled kernel's speed path is checked to be the one taken.
"""

from __future__ import annotations

import numpy as np
import pytest

from rworld_cli.collision import convex as cv
from tests.collision.test_convex import random_poses


@pytest.mark.parametrize("kinds", [("box", "box"), ("box", "cylinder"), ("cylinder", "cylinder")])
def test_compiled_and_numpy_gjk_agree(kinds):
    """The two implementations of one algorithm: the same distances (to the convergence
    tolerance), decisions and iteration counts up to rounding; valid closest points on both."""
    from rworld_cli import kernels
    from rworld_cli.collision.compiled import gjk

    if kernels.backend() != "llvm":
        pytest.skip("no compiled kernels on this machine")
    n = 3000
    Ta, Tb = random_poses(n, 21, 0.05), random_poses(n, 22)

    def make(kind, T, size):
        return (
            cv.boxes(T, size * np.array([0.5, 1.0, 1.5]))
            if kind == "box"
            else (cv.cylinders(T, size * 0.6, size * 1.4))
        )

    a, b = make(kinds[0], Ta, 0.1), make(kinds[1], Tb, 0.08)
    assert gjk(a, b, cv.MAX_ITERATIONS) is not None
    compiled = cv.distance(a, b)
    numpy_ = cv._distances(a, b, *cv._gjk_numpy(a, b, cv.MAX_ITERATIONS))
    assert np.abs(compiled.distance - numpy_.distance).max() <= 1e-9
    assert np.array_equal(compiled.overlap, numpy_.overlap)
    assert 0 < compiled.overlap.sum() < n  # both kinds of answer are exercised
    # rounding can stop a curved pair's linear convergence an iteration or more sooner or later;
    # most pairs take the same steps, and as many on average
    assert np.mean(compiled.iterations == numpy_.iterations) >= 0.85
    assert abs(compiled.iterations.mean() / numpy_.iterations.mean() - 1.0) <= 0.05
    far = ~compiled.overlap
    gap = np.linalg.norm(compiled.point_a[far] - compiled.point_b[far], axis=1)
    assert np.abs(gap - compiled.distance[far]).max() <= 1e-9


def _hull_table(hulls: list[np.ndarray]):
    """Hulls as one table padded to one width, with their vertices' hull neighbours."""
    width = max(len(h) for h in hulls)
    vertices = np.stack([np.concatenate([h, np.repeat(h[:1], width - len(h), 0)]) for h in hulls])
    rows = [cv.hull_neighbours(h, width) for h in hulls]
    degree = max(r.shape[1] for r in rows)
    neighbours = np.stack(
        [np.pad(r, ((0, 0), (0, degree - r.shape[1])), constant_values=-1) for r in rows]
    )
    return vertices, neighbours


def test_the_local_climbing_gjk_equals_the_world_scan():
    """Hulls of 8 to 3 000 vertices (and a box, and a flat one that is scanned) in their own
    frames, placed per pair, their supports found by climbing the hull's edges from the last
    one: the same distances and decisions as the world-frame GJK that scans every vertex of
    the placed copies, and a depth bound never above the penetration depth."""
    from scipy.spatial import ConvexHull
    from scipy.spatial.transform import Rotation

    from rworld_cli import kernels
    from rworld_cli.collision.compiled import gjk_local, shape_rows

    if kernels.backend() != "llvm":
        pytest.skip("no compiled kernels on this machine")
    rng = np.random.default_rng(3)

    def hull(count, scale):
        p = rng.normal(size=(count, 3))
        p *= scale * rng.uniform(0.5, 1.5, 3) / np.linalg.norm(p, axis=1)[:, None]
        return p[ConvexHull(p).vertices]

    box = cv.box_corners(np.array([0.05, 0.1, 0.02]))
    flat = np.array([[0.0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0.1, 0.1, 0]])
    A = [hull(n, 0.1) for n in (8, 50, 400, 3000)] + [box]
    B = [hull(n, 0.08) for n in (12, 900)] + [box, flat]
    (va, na), (vb, nb) = _hull_table(A), _hull_table(B)
    assert nb[3, 0, 0] == -2  # the flat one: no hull with volume, scanned
    P = 6000
    ra, rb = rng.integers(0, len(A), P), rng.integers(0, len(B), P)
    Ra = Rotation.random(P, random_state=1).as_matrix()
    Rb = Rotation.random(P, random_state=2).as_matrix()
    ta, tb = rng.uniform(-0.25, 0.25, (P, 3)), rng.uniform(-0.25, 0.25, (P, 3))
    world_a = cv.hulls(np.einsum("pij,pvj->pvi", Ra, va[ra]) + ta[:, None], Ra)
    world_b = cv.hulls(np.einsum("pij,pvj->pvi", Rb, vb[rb]) + tb[:, None], Rb)
    reference = cv.distance(world_a, world_b)
    rows = gjk_local(
        (va, na, ra, np.concatenate([Ra.reshape(P, 9), ta], axis=1)),
        (vb, nb, rb, np.concatenate([Rb.reshape(P, 9), tb], axis=1)),
        shape_rows(world_a),
        shape_rows(world_b),
        cv.MAX_ITERATIONS,
    )
    local = cv.from_kernel(world_a, world_b, rows)
    assert np.array_equal(local.overlap, reference.overlap)
    assert 0 < local.overlap.sum() < P
    assert np.abs(local.distance - reference.distance).max() <= 1e-12
    over = np.flatnonzero(local.overlap)
    depth, _ = cv.penetration(world_a.take(over), world_b.take(over))
    bound = local.depth_bound[over]
    assert (bound <= depth + 1e-12).all() and (bound > 0).mean() > 0.9


def test_the_compiled_box_bound_equals_the_numpy_one():
    """bvh.box_gap compiled (compiled_bvh) against its numpy form on random trees and poses,
    flat (triangle) boxes included: equal to rounding."""
    from scipy.spatial.transform import Rotation

    from rworld_cli import kernels
    from rworld_cli.collision import bvh, compiled_bvh

    if kernels.backend() != "llvm":
        pytest.skip("no compiled kernels on this machine")
    rng = np.random.default_rng(4)
    tree_a = bvh.build(rng.normal(size=(300, 3, 3)) * 0.05 + rng.normal(size=(300, 1, 3)) * 0.3)
    tree_b = bvh.build(rng.normal(size=(200, 4, 3)) * 0.05 + rng.normal(size=(200, 1, 3)) * 0.3)
    K, Q = 40, 100_000
    R = Rotation.random(K, random_state=5).as_matrix()
    t = rng.normal(size=(K, 3)) * 0.3
    a = rng.integers(0, len(tree_a.half), Q)
    b = rng.integers(0, len(tree_b.half), Q)
    k = rng.integers(0, K, Q)
    compiled = compiled_bvh.box_gap(tree_a, a, tree_b, b, k, R, t)
    numpy_ = bvh.box_gap(tree_a, a, tree_b, b, R[k], t[k])
    assert (numpy_ > 0).any() and (numpy_ <= 0).any()
    np.testing.assert_allclose(compiled, numpy_, rtol=0, atol=1e-12)


def test_every_kernels_ir_builds_and_verifies():
    """A kernel whose IR does not build falls back to numpy with a warning - right for a user,
    a bug here (the suite's answers would not change, only their speed): every kernel's IR text
    parses and passes LLVM's verifier, and the module the box-tree walks link is one whole."""
    pytest.importorskip("llvmlite")
    import llvmlite.binding as llvm

    from rworld_cli.collision import bvh_ir, compiled, free_states_ir

    texts = {
        "gjk": compiled.gjk_ir("k_gjk"),
        "gjk local": compiled.gjk_ir("k_gjk_local", local=True),
        "box gap": bvh_ir.box_gap_ir("k_gap"),
        "descend": bvh_ir.descend_ir("k_descend"),
        "touching": bvh_ir.touching_ir("k_touching"),
        "contacts": bvh_ir.contacts_ir("k_contacts", "k_gjk_local"),
        "free states": free_states_ir.free_states_ir("k_free", "k_contacts"),
        "pair rows": free_states_ir.free_states_ir("k_rows", "k_contacts", rows=True),
    }
    modules = {}
    for name, text in texts.items():
        modules[name] = llvm.parse_assembly(text)
        modules[name].verify()
    linked = modules["gjk local"]
    for name in ("contacts", "free states", "pair rows"):
        linked.link_in(modules[name])
    linked.verify()
    for symbol in ("k_gjk_local", "k_contacts", "k_free", "k_rows"):
        assert not linked.get_function(symbol).is_declaration, symbol


@pytest.mark.filterwarnings("error")
def test_the_compiled_kernels_are_built_where_llvm_is_the_backend():
    """Where the machine compiles kernels, every kernel rworld asks for is there (no silent
    fallback: a failed build warns, and a warning fails this test)."""
    from rworld_cli import kernels
    from rworld_cli.collision import compiled, compiled_bvh

    if kernels.backend() != "llvm":
        pytest.skip("no compiled kernels on this machine")
    assert compiled.gjk_function() is not None
    assert compiled.gjk_local_function() is not None
    assert all(function is not None for function in compiled_bvh._functions())

"""The bodies' box trees (``collision/bvh.py``) against GJK over every leaf pair.

The search drops a leaf pair only when a lower bound on its distance is above a distance
measured; these tests check the bound (random oriented boxes, flat ones among them: a
triangle's box), the tree (every leaf inside every box above it), and the result: on the
vendors' own meshes (tests/data/vendor_cells), at random poses and at poses a fraction of a
millimetre from contact or just inside it, :func:`pair_distance` equals the minimum of GJK over
every leaf pair to 1e-9 m, with the deepest overlap and the same buried decision.
"""

from __future__ import annotations

import zlib
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from rworld_cli.collision import bvh
from rworld_cli.collision import convex as cv
from rworld_cli.collision.bodies import collision_model, pair_distance
from rworld_cli.schema.loader import load_cell

CELLS = Path(__file__).resolve().parents[1] / "data" / "vendor_cells"


@cache
def vendor_bodies(cell: str) -> dict:
    loaded = load_cell(str(CELLS / cell / "cell.yaml"))
    model = collision_model(getattr(loaded, "cell", loaded))
    return {b.label: b for b in model.bodies}


def random_frames(rng, n: int, spread: float) -> np.ndarray:
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, :3, :3] = Rotation.random(n, random_state=rng).as_matrix()
    T[:, :3, 3] = rng.normal(size=(n, 3)) * spread
    return T


def test_the_box_bound_never_exceeds_the_distance():
    """Oriented boxes at random, a third of them flat (a triangle's box) and some thin: the
    bound is at most the exact distance of the boxes (GJK on their corners), and it is not
    vacuous (on average within a few per cent of it where they are apart)."""
    rng = np.random.default_rng(7)
    Q = 5000
    trees = []
    for _ in range(2):
        half = rng.uniform(0.0, 0.1, (Q, 3))
        half[: Q // 3, 2] = 0.0  # flat
        half[Q // 3 : Q // 2, :2] *= 0.02  # needles
        trees.append(
            bvh.Tree(
                rng.normal(size=(Q, 3)) * 0.1,
                half,
                Rotation.random(Q, random_state=rng).as_matrix(),
                -np.ones(Q, int),
                -np.ones(Q, int),
                np.arange(Q),
            )
        )
    R = Rotation.random(Q, random_state=rng).as_matrix()
    t = rng.normal(size=(Q, 3)) * 0.2
    gap = bvh.box_gap(trees[0], np.arange(Q), trees[1], np.arange(Q), R, t)

    def corners(tree, Rw=None, tw=None):
        c = cv.box_corners(np.ones(3))[None] * tree.half[:, None, :]
        pts = tree.center[:, None, :] + c @ tree.axes  # rows of axes: the box's directions
        return pts if Rw is None else pts @ np.transpose(Rw, (0, 2, 1)) + tw[:, None]

    eye = np.tile(np.eye(3), (Q, 1, 1))
    exact = cv.distance(
        cv.hulls(corners(trees[0]), eye), cv.hulls(corners(trees[1], R, t), eye)
    ).distance
    assert (gap <= exact + 1e-12).all()
    apart = exact > 0
    assert apart.sum() > Q // 2
    assert np.mean(np.maximum(gap[apart], 0) / exact[apart]) > 0.9


def test_every_leaf_lies_in_every_box_above_it():
    bodies = vendor_bodies("iiwa14")
    for label in ("plate", "kuka_lbr_iiwa_14_r820.link_2", "kuka_lbr_iiwa_14_r820"):
        body = bodies[label]
        tree = body.tree
        points = body._triangles if body.is_mesh else body._hulls[0]
        parent = np.full(len(tree.item), -1)
        inner = np.flatnonzero(tree.left >= 0)
        parent[tree.left[inner]], parent[tree.right[inner]] = inner, inner
        for node in np.flatnonzero(tree.item >= 0):
            pts = points[tree.item[node]]
            up = node
            while up >= 0:
                local = (pts - tree.center[up]) @ tree.axes[up].T
                assert (np.abs(local) <= tree.half[up] + 1e-12).all()
                up = parent[up]
        assert (tree.item >= 0).sum() == len(points)  # every leaf once


def _spheres(pieces) -> tuple[np.ndarray, np.ndarray]:
    """A ball around each piece: (centres (P, 3), radii (P,)) [m], from its placed vertices (a
    cylinder's from its radius and half length), grown by its margin."""
    points = pieces.points
    centre = points.mean(axis=1)
    radius = np.linalg.norm(points - centre[:, None], axis=2).max(axis=1)
    cyl = pieces.cylinder
    centre[cyl] = pieces.center[cyl]
    radius[cyl] = np.hypot(pieces.radius[cyl], pieces.half_length[cyl])
    return centre, radius + pieces.margin


def exhaustive(a, b, Ta, Tb, chunk: int = 200_000):
    """GJK over every leaf pair at each state: (distance, deepest penetration) per state.

    Pairs go to GJK in the order of a lower bound of their distance (their balls' gap), and the
    rest are left once the bound passes the least distance measured: every pair that could
    overlap or be the closest is measured (exact, and independent of the tree's box bound)."""
    na, nb = (int((body.tree.item >= 0).sum()) for body in (a, b))
    dist, depth = [], []
    for k in range(len(Ta)):
        pa = a.leaf_pieces(np.arange(na), np.repeat(Ta[k : k + 1], na, 0))
        pb = b.leaf_pieces(np.arange(nb), np.repeat(Tb[k : k + 1], nb, 0))
        (ca, ra), (cb, rb) = _spheres(pa), _spheres(pb)
        bound = np.linalg.norm(ca[:, None] - cb[None], axis=2) - ra[:, None] - rb[None]
        order = np.argsort(bound, axis=None)
        best, deepest = np.inf, 0.0
        for start in range(0, order.size, chunk):
            if bound.flat[order[start]] > max(best, 0.0):
                break
            ia, ib = np.unravel_index(order[start : start + chunk], bound.shape)
            res = cv.distance(pa.take(ia), pb.take(ib))
            best = min(best, res.distance.min())
            over = np.flatnonzero(res.overlap)
            if len(over):
                pen = cv.penetration(pa.take(ia[over]), pb.take(ib[over]))[0].max()
                deepest = max(deepest, pen)
        dist.append(best)
        depth.append(deepest)
    return np.array(dist), np.array(depth)


PAIRS = [  # (cell, a, b, random states): mesh x mesh, fixture x link mesh, hulls x mesh,
    # open x closed mesh (the fixture's pair: 2.4 M leaf pairs a state, most passed over by
    # the balls' bound), a single large hull (the flange, 198 vertices) over the plate's
    # triangles: the walk's leaf-against-box bound
    ("iiwa14", "kuka_lbr_iiwa_14_r820.link_2", "kuka_lbr_iiwa_14_r820.link_4", 3),
    ("iiwa14", "plate", "kuka_lbr_iiwa_14_r820.link_6", 1),
    ("iiwa14", "plate", "kuka_lbr_iiwa_14_r820.link_7", 4),
    ("iiwa14", "kuka_lbr_iiwa_14_r820", "kuka_lbr_iiwa_14_r820.link_3", 3),
    ("tx2_60", "staubli_tx2_60.link_1", "staubli_tx2_60.link_3", 3),
]


@pytest.mark.parametrize("cell, label_a, label_b, states", PAIRS)
def test_the_tree_search_finds_the_exhaustive_minimum(cell, label_a, label_b, states):
    """Random poses, then the same poses moved along each state's closest-pair line to 0.3 mm
    apart and 0.3 mm inside (where faces hover over faces and the leaves' bounds all tie)."""
    bodies = vendor_bodies(cell)
    a, b = bodies[label_a], bodies[label_b]
    rng = np.random.default_rng(zlib.crc32((label_a + label_b).encode()))
    Ta = random_frames(rng, states, 0.0)
    Tb = random_frames(rng, states, 0.0)
    # b's centre 1.2 bounding radii from a's, in a random direction: near, mostly apart
    direction = rng.normal(size=(states, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    centre_b = 1.2 * (a.radius + b.radius) * direction
    Tb[:, :3, 3] = centre_b - Tb[:, :3, :3] @ b.center + Ta[:, :3, :3] @ a.center
    first = pair_distance(a, b, Ta, Tb)
    moved = [Tb]
    for target in (3e-4, -3e-4):
        T = Tb.copy()
        direction = first.point_a - first.point_b
        length = np.linalg.norm(direction, axis=1, keepdims=True)
        unit = np.divide(direction, length, out=np.zeros_like(direction), where=length > 0)
        T[:, :3, 3] += unit * (first.distance - target)[:, None]
        moved.append(T)
    assert (first.distance > 1e-3).all()
    Ta3, Tb3 = np.concatenate([Ta] * 3), np.concatenate(moved)
    got = pair_distance(a, b, Ta3, Tb3)
    want, deepest = exhaustive(a, b, Ta3, Tb3)
    reported = np.where(got.buried, want, got.distance)  # a buried body: 0, depth >= distance
    assert np.abs(reported - want).max() <= 1e-9
    touching = want <= 0
    assert touching.any() and (~touching).any()
    assert np.abs(got.depth[touching & ~got.buried] - deepest[touching & ~got.buried]).max() <= 1e-9
    # the points reported are the pair's: as far apart as the distance
    free = ~touching
    gap = np.linalg.norm(got.point_a[free] - got.point_b[free], axis=1)
    assert np.abs(gap - got.distance[free]).max() <= 1e-9


@pytest.mark.parametrize("backend", ["llvm", "numpy"])
def test_shared_vertices_give_what_copies_give(backend, monkeypatch):
    """A hull of thousands of vertices is kept once, in its own frame, for all its states
    (``Pieces.local``; ``share`` refers to it) and measures as its placed copies do, on both
    GJK implementations (the compiled one climbs it, the numpy one places it)."""
    from rworld_cli import kernels

    monkeypatch.setenv("RWORLD_KERNELS", backend)
    if backend == "llvm" and kernels.backend() != "llvm":
        pytest.skip("no compiled kernels on this machine")
    body = vendor_bodies("gp7")["motoman_gp7.link_2_l"]  # one hull of 3 202 vertices
    rng = np.random.default_rng(3)
    hulls = body.pieces(random_frames(rng, 4, 0.0))
    rows = rng.integers(0, 4, 200)
    triangles = cv.triangles(rng.normal(size=(200, 3, 3)) * 0.3)
    shared = cv.distance(hulls.share(rows), triangles)
    copied = cv.distance(hulls.take(rows).materialized(), triangles)
    kept = hulls.share(rows)
    assert kept.local[0].shape[:2] == (1, 3202) and kept.vertices.shape[1] == 1  # not copied
    assert hulls.take(rows).materialized().vertices.shape == (200, 3202, 3)
    assert 0 < shared.overlap.sum() < 200
    assert np.array_equal(shared.overlap, copied.overlap)
    assert np.abs(shared.distance - copied.distance).max() <= 1e-12
    far = ~copied.overlap
    assert np.abs(shared.point_a[far] - copied.point_a[far]).max() <= 1e-12
    # depths: placed a block at a time from the table, as from the copies
    over = np.flatnonzero(copied.overlap)
    assert kept.take(over).width == 3202
    depth_kept, _ = cv.penetration(kept.take(over), triangles.take(over))
    depth_copied, _ = cv.penetration(
        hulls.take(rows).materialized().take(over), triangles.take(over)
    )
    np.testing.assert_array_equal(depth_kept, depth_copied)


@pytest.mark.parametrize("label_a, label_b", [
    ("plate", "kuka_lbr_iiwa_14_r820.link_4"),
    ("kuka_lbr_iiwa_14_r820.link_2", "kuka_lbr_iiwa_14_r820.link_5"),
])  # fmt: skip
def test_the_compiled_walk_finds_the_numpy_searchs_leaf_pairs(label_a, label_b, monkeypatch):
    """A collision test (within 0): the compiled depth-first walk returns exactly the leaf
    pairs of the breadth-first numpy search, at random poses with the boxes overlapping, and
    the same collision answer from pair_distance."""
    from rworld_cli import kernels
    from rworld_cli.collision import compiled_bvh

    if kernels.backend() != "llvm":
        pytest.skip("no compiled kernels on this machine")
    bodies = vendor_bodies("iiwa14")
    a, b = bodies[label_a], bodies[label_b]
    rng = np.random.default_rng(9)
    n = 200
    Ta = random_frames(rng, n, 0.0)
    Tb = random_frames(rng, n, 0.0)
    direction = rng.normal(size=(n, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    spread = rng.uniform(0.2, 1.0, (n, 1)) * (a.radius + b.radius)
    Tb[:, :3, 3] = spread * direction - Tb[:, :3, :3] @ b.center + Ta[:, :3, :3] @ a.center
    walked = bvh.candidates(a.tree, b.tree, Ta, Tb, None, 1e-9)
    with_walk = pair_distance(a, b, Ta, Tb, within=0.0, deep_enough=1e-3)
    monkeypatch.setattr(compiled_bvh, "touching", lambda *args: None)
    searched = bvh.candidates(a.tree, b.tree, Ta, Tb, None, 1e-9)
    without = pair_distance(a, b, Ta, Tb, within=0.0, deep_enough=1e-3)
    assert len(searched[0]) > n  # boxes overlap: work for both
    assert set(zip(*(x.tolist() for x in walked))) == set(zip(*(x.tolist() for x in searched)))
    assert np.all(np.diff(walked[0]) >= 0)  # sorted by state
    collide = lambda r: (r.distance <= 0) & (r.depth > 1e-3) | r.buried  # noqa: E731
    assert np.array_equal(collide(with_walk), collide(without))
    assert collide(without).any() and (~collide(without)).any()


@pytest.mark.parametrize("backend", ["llvm", "numpy"])
def test_shared_rows_in_blocks_join_on_both_gjks(backend, monkeypatch):
    """Shared vertex rows measured a block at a time give what one call gives, with or without
    the compiled GJK's depth bound (the numpy GJK has none: the blocks' results still join)."""
    from rworld_cli import kernels

    monkeypatch.setenv("RWORLD_KERNELS", backend)
    if backend == "llvm" and kernels.backend() != "llvm":
        pytest.skip("no compiled kernels on this machine")
    rng = np.random.default_rng(5)
    table = cv.triangles(rng.normal(size=(50, 3, 3)) * 0.2)
    rows = rng.integers(0, 50, 300)
    others = cv.triangles(rng.normal(size=(300, 3, 3)) * 0.2)
    whole = cv.distance(table.share(rows), others)
    monkeypatch.setattr(cv, "SHARED_BUDGET", 3 * 40)  # blocks of 40 pairs
    blocks = cv.distance(table.share(rows), others)
    np.testing.assert_array_equal(blocks.distance, whole.distance)
    assert (blocks.depth_bound is None) == (backend == "numpy")


def test_the_compiled_descent_follows_the_numpy_one():
    """The descent to a leaf pair (the upper bound's measure) compiled: it ends on leaves, and
    on the same leaves as the numpy descent (bounds tie exactly at 0 where boxes overlap; a
    rounding of the bound may break a rare tie between apart boxes the other way: any leaf
    pair is an upper bound)."""
    from rworld_cli import kernels
    from rworld_cli.collision import compiled_bvh

    if kernels.backend() != "llvm":
        pytest.skip("no compiled kernels on this machine")
    bodies = vendor_bodies("iiwa14")
    a, b = bodies["plate"], bodies["kuka_lbr_iiwa_14_r820.link_4"]
    rng = np.random.default_rng(11)
    n = 400
    Ta, Tb = random_frames(rng, n, 0.0), random_frames(rng, n, 0.0)
    direction = rng.normal(size=(n, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    spread = rng.uniform(0.3, 1.5, (n, 1)) * (a.radius + b.radius)
    Tb[:, :3, 3] = spread * direction - Tb[:, :3, :3] @ b.center + Ta[:, :3, :3] @ a.center
    R, t = bvh._relative(Ta, Tb)
    k = np.arange(n)
    roots = np.zeros(n, dtype=int)
    got_a, got_b = compiled_bvh.descend(a.tree, b.tree, k, roots, roots, R, t)
    assert a.tree.is_leaf[got_a].all() and b.tree.is_leaf[got_b].all()
    numpy_a, numpy_b = _numpy_descent(a.tree, b.tree, k, roots, R, t)
    same = (numpy_a == got_a) & (numpy_b == got_b)
    assert same.mean() >= 0.99


def _numpy_descent(tree_a, tree_b, k, roots, R, t):
    """The numpy descent of bvh.candidates, from the roots."""
    a, b = roots.copy(), roots.copy()
    while True:
        inner = ~(tree_a.is_leaf[a] & tree_b.is_leaf[b])
        if not inner.any():
            return a, b
        ki = k[inner]
        a1, b1, a2, b2 = bvh._split(tree_a, tree_b, a[inner], b[inner])
        out = []
        for x, y in ((a1, b1), (a2, b2)):
            g = np.maximum(bvh.box_gap(tree_a, x, tree_b, y, R[ki], t[ki]), 0.0)
            centre = np.einsum("qij,qj->qi", R[ki], tree_b.center[y]) + t[ki]
            out.append((g, np.linalg.norm(tree_a.center[x] - centre, axis=1)))
        (g1, c1), (g2, c2) = out
        first = (g1 < g2) | ((g1 == g2) & (c1 <= c2))
        a[inner] = np.where(first, a1, a2)
        b[inner] = np.where(first, b1, b2)

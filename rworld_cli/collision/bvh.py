"""Bounding-volume hierarchies of bodies, and the batched search for a pair's nearest leaves.

Why: a pair of bodies with several convex leaves on both sides (two triangle meshes, a mesh
and a link made of hulls, two links of several hulls) has leaves x leaves combinations; a
vendor's link meshes (500-1000 triangles) against a fixture (2 900) give millions per state.
A tree over each body's leaves, built once per body, finds the few combinations that may hold
a state's nearest pair in about log(leaves) steps per state, and memory independent of
leaves x leaves.

**Tree.**  Each node is an oriented box in the body's frame (centre, half extents, axes) around
its leaves, fitted along their points' principal axes (a triangle's box is flat); a leaf is one
triangle, one convex part's hull, or a primitive.  Built top-down, splitting the leaves'
centres at the median along the node's longest axis (so the depth is about log2(leaves) + 1).

**Bounds** (:func:`box_gap`).  For a node pair at a state (``T_a_b``, the pose of b's frame in
a's), the separating-axis test of two oriented boxes gives a lower bound on the distance of
anything inside them: along a's three axes, the distance between a's box and the box along
those axes that holds b's; the same in b's frame; and the gaps along the nine edge-edge axes
(Gottschalk et al., OBBTree, 1996).  The largest is the bound; where the boxes overlap along
all fifteen axes, it is the least overlap, 0 or negative.

**Search** (:func:`candidates`), vectorised over states, breadth first from the roots: node
pairs are split (the node with the larger box, or the one that is not a leaf) and kept only
while their bound is within 1e-9 m of the state's upper bound.  The upper bound is a distance
measured: every :data:`REFINE_EVERY` levels, each state's most promising node pair (lowest
bound; among overlapping boxes, the nearest centres) is followed down to a leaf pair, which is
measured exactly (GJK), so it tightens as the boxes shrink.  What is left are leaf pairs; they
are all returned, the measured ones among them, so the nearest pair is never dropped: a pair
dropped has a bound, hence a distance, above a distance that was measured.

Every pair that is not dropped is measured by the caller; the result equals GJK over every
leaf pair (``tests/collision/test_bvh.py`` compares them).
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass

import numpy as np

# node pairs in flight per batch of states: bounds memory whatever the meshes (about 100 MB)
FRONTIER_BUDGET = 1_000_000
GAP_BLOCK = 65536  # node pairs per bound evaluation: its temporaries stay near 50 MB
# the upper bounds are refined every this many levels of the search (each refinement is a
# descent to a leaf pair and one exact distance per state)
REFINE_EVERY = 3


@dataclass(frozen=True)
class Tree:
    """An oriented-box tree over a body's leaves, in the body's frame.

    Attributes
    ----------
    center, half : ndarray, shape (N, 3)
        Each node's box centre [m] (in the body's frame) and half extents along its axes [m].
    axes : ndarray, shape (N, 3, 3)
        Each node's box axes as rows (unit, in the body's frame).
    left, right : ndarray of int, shape (N,)
        Children (-1 for leaves).  The root is node 0.
    item : ndarray of int, shape (N,)
        The leaf's index in the body's leaves (-1 for inner nodes).
    """

    center: np.ndarray
    half: np.ndarray
    axes: np.ndarray
    left: np.ndarray
    right: np.ndarray
    item: np.ndarray

    @property
    def is_leaf(self) -> np.ndarray:
        return self.item >= 0


CACHED_LEAVES = 64  # trees over this many leaves or more are kept in the user's cache


def build(points: np.ndarray) -> Tree:
    """The tree over leaves given by points that they are the hull of (module docstring).

    Parameters
    ----------
    points : ndarray, shape (L, P, 3)
        Each leaf's points in the body's frame [m] (a triangle's 3 vertices, a hull's
        vertices, a primitive's box corners; padding by repeating a point is harmless).

    A tree of :data:`CACHED_LEAVES` leaves or more is kept in the user's cache
    (``rworld_cli.cache``, kind ``meshes``), keyed by the points and this module's code: a
    vendor link's tree costs a tenth of a second to fit, every command.
    """
    import hashlib

    from .. import cache

    points = np.ascontiguousarray(points, dtype=float)
    if len(points) < CACHED_LEAVES:
        return _build(points)
    key = hashlib.sha256(_code() + str(points.shape).encode() + points.tobytes()).hexdigest()
    data = cache.arrays(
        "meshes", f"tree-{key[:40]}.npz", _FIELDS, lambda: dataclasses.asdict(_build(points))
    )
    return Tree(**data)


_FIELDS = tuple(f.name for f in dataclasses.fields(Tree))


@functools.cache
def _code() -> bytes:
    """This module's code: what a cached tree depends on besides its points."""
    from pathlib import Path

    return Path(__file__).read_bytes()


def _build(points: np.ndarray) -> Tree:
    """:func:`build`, computed."""
    L = len(points)
    centroid = points.mean(axis=1)
    n_nodes = 2 * L - 1
    center, half = np.empty((n_nodes, 3)), np.empty((n_nodes, 3))
    axes = np.empty((n_nodes, 3, 3))
    left, right, item = np.full(n_nodes, -1), np.full(n_nodes, -1), np.full(n_nodes, -1)
    next_free = 1
    stack = [(0, np.arange(L))]
    while stack:
        node, members = stack.pop()
        center[node], half[node], axes[node] = _fit_box(points[members].reshape(-1, 3))
        if len(members) == 1:
            item[node] = members[0]
            continue
        # split the leaves' centres at the median along the node's longest axis
        along = (centroid[members] - center[node]) @ axes[node, int(np.argmax(half[node]))]
        order = members[np.argsort(along, kind="stable")]
        mid = len(order) // 2
        left[node], right[node] = next_free, next_free + 1
        next_free += 2
        stack.append((left[node], order[:mid]))
        stack.append((right[node], order[mid:]))
    return Tree(center, half, axes, left, right, item)


def _fit_box(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A box around points (M, 3) along their principal axes: centre, half extents, axes
    (rows).  A triangle's box is flat, a sliver's thin: much tighter than an axis-aligned
    box, which a long triangle across a face fills."""
    mean = points.mean(axis=0)
    centred = points - mean
    _, vectors = np.linalg.eigh(centred.T @ centred)  # principal axes: columns, ascending
    axes = vectors.T[::-1].copy()
    local = centred @ axes.T
    low, high = local.min(axis=0), local.max(axis=0)
    return mean + ((low + high) / 2) @ axes, (high - low) / 2, axes


def box_gap(
    tree_a: Tree, a: np.ndarray, tree_b: Tree, b: np.ndarray, R: np.ndarray, t: np.ndarray
) -> np.ndarray:
    """A lower bound on the distance between node boxes, by the separating axes of both.

    Parameters
    ----------
    tree_a, tree_b : Tree
    a, b : ndarray of int, shape (Q,)
        Nodes of each tree.
    R, t : ndarray, shapes (Q, 3, 3) and (Q, 3)
        ``T_a_b``: b's frame in a's.

    Returns
    -------
    ndarray, shape (Q,)
        Where the boxes are apart along one of the axes: the larger of the distances between
        a's box and the box along a's axes holding b's, and the same in b's frame [m];
        elsewhere the least overlap along those axes, <= 0.
    """
    Ua, Ub = tree_a.axes[a], tree_b.axes[b]
    ha, hb = tree_a.half[a], tree_b.half[b]
    # b's box in a's box frame: rotation M, centre p (matmul on 3 x 3 stacks: faster than einsum)
    M = Ua @ R @ np.transpose(Ub, (0, 2, 1))
    p = (Ua @ ((R @ tree_b.center[b][:, :, None])[:, :, 0] + t - tree_a.center[a])[:, :, None])[
        :, :, 0
    ]
    absM = np.abs(M)
    along_a = np.abs(p) - ha - (absM @ hb[:, :, None])[:, :, 0]
    along_b = np.abs((p[:, None, :] @ M)[:, 0]) - hb - (ha[:, None, :] @ absM)[:, 0]
    # apart on some axis: the distance between a's box and the box along a's axes that holds
    # b's (and the same in b's frame); overlapping on every axis: the least overlap, <= 0
    apart_a = np.sqrt((np.maximum(along_a, 0.0) ** 2).sum(axis=1))
    apart_b = np.sqrt((np.maximum(along_b, 0.0) ** 2).sum(axis=1))
    # the nine edge-edge axes a_i x b_j of the separating-axis test (Gottschalk et al., OBBTree,
    # 1996), as gaps: across a tilted pair of flat boxes (two triangles) the face axes are weak
    i1, i2 = [1, 2, 0], [2, 0, 1]
    absM = absM + 1e-12  # parallel axes: the cross product vanishes, the gap is taken as 0
    reach_a = ha[:, i1, None] * absM[:, i2, :] + ha[:, i2, None] * absM[:, i1, :]  # (Q, i, j)
    reach_b = hb[:, None, i1] * absM[:, :, i2] + hb[:, None, i2] * absM[:, :, i1]
    across = np.abs(p[:, i2, None] * M[:, i1, :] - p[:, i1, None] * M[:, i2, :])
    length = np.sqrt(np.maximum(1.0 - M**2, 0.0))
    edge = (
        np.where(length > 1e-6, (across - reach_a - reach_b) / np.maximum(length, 1e-6), -np.inf)
        .reshape(len(p), 9)
        .max(axis=1)
    )
    inside = np.maximum(np.maximum(along_a.max(axis=1), along_b.max(axis=1)), edge)
    return np.where(inside > 0, np.maximum(np.maximum(apart_a, apart_b), edge), inside)


def gap_at(
    tree_a: Tree, a: np.ndarray, tree_b: Tree, b: np.ndarray, k: np.ndarray, R, t
) -> np.ndarray:
    """:func:`box_gap` of node pairs ``a[q]``, ``b[q]`` at states ``k[q]`` of ``T_a_b`` (``R``
    (K, 3, 3), ``t`` (K, 3)): compiled (:mod:`compiled_bvh`) when kernels are on, else by
    numpy in blocks of :data:`GAP_BLOCK` (temporaries bounded, whatever the frontier)."""
    from .compiled_bvh import box_gap as compiled_gap

    out = compiled_gap(tree_a, a, tree_b, b, k, R, t)
    if out is not None:
        return out
    out = np.empty(len(k))
    for start in range(0, len(k), GAP_BLOCK):
        sl = slice(start, start + GAP_BLOCK)
        out[sl] = box_gap(tree_a, a[sl], tree_b, b[sl], R[k[sl]], t[k[sl]])
    return out


def _relative(Ta: np.ndarray, Tb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``T_a_b`` = inv(Ta) Tb as rotations (K, 3, 3) and translations (K, 3)."""
    Ra = Ta[:, :3, :3]
    R = np.einsum("kji,kjl->kil", Ra, Tb[:, :3, :3])
    t = np.einsum("kji,kj->ki", Ra, Tb[:, :3, 3] - Ta[:, :3, 3])
    return R, t


def _split(tree_a: Tree, tree_b: Tree, a: np.ndarray, b: np.ndarray):
    """Each node pair's two child pairs: the larger node's children (or the one that is not a
    leaf).  Returns (a1, b1, a2, b2)."""
    leaf_a, leaf_b = tree_a.is_leaf[a], tree_b.is_leaf[b]
    size_a, size_b = tree_a.half[a].sum(axis=1), tree_b.half[b].sum(axis=1)
    split_a = ~leaf_a & (leaf_b | (size_a >= size_b))
    a1 = np.where(split_a, tree_a.left[a], a)
    a2 = np.where(split_a, tree_a.right[a], a)
    b1 = np.where(split_a, b, tree_b.left[b])
    b2 = np.where(split_a, b, tree_b.right[b])
    return a1, b1, a2, b2


def candidates(
    tree_a: Tree,
    tree_b: Tree,
    Ta: np.ndarray,
    Tb: np.ndarray,
    measure,
    within: float | np.ndarray = np.inf,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The leaf pairs that may hold each state's nearest pair (module docstring).

    Parameters
    ----------
    tree_a, tree_b : Tree
    Ta, Tb : ndarray, shape (K, 4, 4)
        ``T_world_frame`` of each body at each state.
    measure : callable
        ``measure(k, leaf_a, leaf_b) -> distance (Q,)``: the exact distance of leaves
        ``leaf_a[q]`` of a and ``leaf_b[q]`` of b at state ``k[q]`` [m].
    within : float or ndarray, shape (K,)
        Only pairs that may be nearer than this [m] are wanted (a collision test asks for 0),
        for all states or each: the search starts with it as the state's upper bound, and a
        state left with no pair is farther than it.

    Returns
    -------
    k, leaf_a, leaf_b : ndarray of int, shape (Q,)
        State and leaf indices of every pair kept, sorted by state.
    """
    K = len(Ta)
    R, t = _relative(Ta, Tb)
    # a collision test (within about 0): a distance measured, clamped at 0, cannot lower the
    # bound below 0, so no refinement; the compiled depth-first walk finds the same leaf pairs
    upper = np.broadcast_to(np.asarray(within, dtype=float), (K,)).copy()
    refining = bool(np.any(upper > 1e-9))
    if not refining:
        from .compiled_bvh import touching

        found = touching(tree_a, tree_b, R, t, float(upper.max(initial=0.0)) + 1e-9)
        if found is not None:
            return found

    def gap(k, a, b):
        return gap_at(tree_a, a, tree_b, b, k, R, t)

    def promise(k, a, b, g):
        """How promising a node pair is: its bound, and among pairs whose boxes overlap (all
        tie at <= 0 near the roots) the nearer box centres."""
        centre_b = np.einsum("qij,qj->qi", R[k], tree_b.center[b]) + t[k]
        return np.maximum(g, 0.0), np.linalg.norm(tree_a.center[a] - centre_b, axis=1)

    def descend(k, a, b):
        """From node pairs down to leaf pairs, always into the more promising child pair."""
        from .compiled_bvh import descend as compiled_descend

        leaves = compiled_descend(tree_a, tree_b, k, a, b, R, t)
        if leaves is not None:
            return leaves
        a, b = a.copy(), b.copy()
        while True:
            inner = ~(tree_a.is_leaf[a] & tree_b.is_leaf[b])
            if not inner.any():
                return a, b
            ki = k[inner]
            a1, b1, a2, b2 = _split(tree_a, tree_b, a[inner], b[inner])
            g1, c1 = promise(ki, a1, b1, gap(ki, a1, b1))
            g2, c2 = promise(ki, a2, b2, gap(ki, a2, b2))
            first = (g1 < g2) | ((g1 == g2) & (c1 <= c2))
            a[inner] = np.where(first, a1, a2)
            b[inner] = np.where(first, b1, b2)

    def refine(k, a, b, g):
        """Each state's most promising node pair, followed down to a leaf pair and measured:
        the upper bound tightens as the frontier gets finer."""
        lowest, near = promise(k, a, b, g)
        order = np.lexsort((near, lowest, k))
        first = order[np.r_[True, k[order][1:] != k[order][:-1]]]
        ks = k[first]
        la, lb = descend(ks, a[first], b[first])
        exact = np.maximum(measure(ks, tree_a.item[la], tree_b.item[lb]), 0.0)
        # fmin: a measurement that failed (NaN) must not become the state's bound, which
        # would drop every pair of the state (it is measured again below, and reported)
        upper[ks] = np.fmin(upper[ks], exact)

    # breadth first from the roots, the upper bounds refined every few levels; states in
    # batches, memory bounded
    out_k, out_a, out_b = [], [], []
    depth = max(int(np.ceil(np.log2(max(len(tree_a.item), 2)))), 1) + max(
        int(np.ceil(np.log2(max(len(tree_b.item), 2)))), 1
    )
    batch = max(1, FRONTIER_BUDGET // (8 * depth))
    for start in range(0, K, batch):
        k = np.arange(start, min(K, start + batch))
        fa, fb = np.zeros(len(k), dtype=int), np.zeros(len(k), dtype=int)
        g = gap(k, fa, fb)
        level = 0
        while len(k):
            if level % REFINE_EVERY == 0 and refining:
                refine(k, fa, fb, g)
            level += 1
            keep = g <= upper[k] + 1e-9
            k, fa, fb, g = k[keep], fa[keep], fb[keep], g[keep]
            done = tree_a.is_leaf[fa] & tree_b.is_leaf[fb]
            out_k.append(k[done])
            out_a.append(tree_a.item[fa[done]])
            out_b.append(tree_b.item[fb[done]])
            k, fa, fb = k[~done], fa[~done], fb[~done]
            if not len(k):
                break
            a1, b1, a2, b2 = _split(tree_a, tree_b, fa, fb)
            k = np.concatenate([k, k])
            fa, fb = np.concatenate([a1, a2]), np.concatenate([b1, b2])
            g = gap(k, fa, fb)
    k, la, lb = (np.concatenate(x) for x in (out_k, out_a, out_b))
    order = np.argsort(k, kind="stable")
    return k[order], la[order], lb[order]

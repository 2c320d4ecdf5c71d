"""Exact distance between convex pieces (GJK), for many pairs in one call.

A **piece** is a convex solid in world coordinates, one of

* a polytope given by its vertices (a box's corners, a mesh triangle's
  three vertices, the hull of a convex part of a mesh; a batch pads every piece to
  the same count by repeating a vertex), or
* a cylinder (centre, unit axis, radius, half length),

grown by a **margin** (a sphere is its centre point grown by its radius).
:class:`Pieces` holds P of them as flat arrays.

:func:`distance` runs Gilbert-Johnson-Keerthi on P pairs at once: compiled to machine code
(:mod:`rworld_cli.collision.compiled`, one pair after another) where kernels are available,
otherwise vectorised over the pairs in numpy (below); the two are the same algorithm.  The
nearest point of each simplex (at most 4 points of the Minkowski difference)
to the origin is found by brute force over its 15 faces: each face's affine
projection is solved and kept when its barycentric weights are all
non-negative; the nearest kept one is the simplex's nearest point.  That is
slower per iteration than Johnson's recursion but has no case analysis that
round-off can send the wrong way.  Pairs leave the loop as they converge
(``|v|^2 - v.w <= 1e-12 |v|^2``: the distance is then within 1e-12 relative of
exact), so a batch costs what its slowest pairs cost only for those pairs.

Polytopes converge in finitely many steps.  Cylinders have curved sides and
converge linearly near the end; 96 iterations reach the tolerance for every
case of the property tests.

Penetration: when the cores overlap, GJK returns distance 0 and
:func:`penetration` measures the depth, the least overlap of the two pieces'
projections over all directions (the distance from the origin to the boundary of
their Minkowski difference).  For two polytopes the least is taken on a face
normal of that difference: a face normal of either piece or the cross product of
an edge of each.  Boxes and triangles carry those directions (``complete``), so
for their pairs the least over the candidates - each piece's axes, the cross
products of a's with b's, each piece's first two axes crossed, the centre line -
is exact.  A box or a triangle against a hull whose faces and edges are known
(:attr:`Pieces.faces`) is exact too: the hull's face normals, and each cross product of an
edge of the one with an edge of the hull kept where it lies in the hull edge's normal cone
(between the normals of its two faces: there the edge is the hull's support, so the
support is known without reading every vertex).  Other pairs (two hulls, cylinders)
start from the same candidates and are then measured by :func:`expanding_depth`: the hull
of support points of the difference grown towards its face nearest the origin until the
support along that face's normal is within :data:`DEPTH_TOLERANCE` of it (the expanding
polytope algorithm, with each hull taken by qhull).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .simplex import ABSOLUTE_TOLERANCE, RELATIVE_TOLERANCE
from .simplex import FACES as _FACES

MAX_ITERATIONS = 96
SHARED_BUDGET = 4_000_000  # vertices copied out of shared tables per GJK call (about 100 MB)


@dataclass
class Pieces:
    """P convex pieces in world coordinates (see the module docstring).

    Attributes
    ----------
    vertices : ndarray, shape (P, V, 3)
        Polytope vertices [m] (a vertex repeated to fill V); for cylinders the centre.
    cylinder : ndarray of bool, shape (P,)
    center : ndarray, shape (P, 3)
        A point inside the piece (for cylinders: the centre of its axis) [m].
    axis : ndarray, shape (P, 3)
        Cylinder axis (unit); also used as a candidate direction for polytopes (box z axis).
    radius, half_length : ndarray, shape (P,)
        Cylinder radius and half length [m].
    margin : ndarray, shape (P,)
        Growth of the core [m] (sphere radius; 0 otherwise).
    axes : ndarray, shape (P, 3, 3)
        The piece's own axes as rows (box axes; cylinder: two radial axes and the axis).
    rows : ndarray of int, shape (P,), or None
        When given, ``vertices`` is a table (M, V, 3) shared by the pieces: piece p's vertices
        are ``vertices[rows[p]]`` (see :meth:`share`).
    local : tuple, or None
        When given, the polytopes in their own frames: ``(table (M, V, 3), neighbours (M, V, D)
        int64, rows (P,) int64, poses (P, 12): R's rows then t)``, piece p being
        ``table[rows[p]]`` placed by its pose (:func:`rworld_cli.collision.compiled.
        gjk_local` climbs their hulls); ``vertices`` then holds only their centres, and
        :attr:`points` places the vertices when something needs them.
    complete : ndarray of bool, shape (P,), or None
        The piece's ``axes`` with the cross product of the first two hold every face normal
        and edge direction it has (a box: its axes; a triangle: its three edges, their cross
        its normal; a sphere's core, a point): :func:`penetration`'s candidates are then the
        exact set for a pair of such pieces.  None: no piece is (a hull's principal axes, a
        cylinder: measured by :func:`expanding_depth`).
    faces : tuple, or None
        Hulls' faces, ``(table (C, F, 4) or a function that returns it when first needed,
        row (P,) int, R (P, 3, 3), t (P, 3))``: piece p's
        are ``table[row[p]]`` (unit outward normal and offset, ``n.x <= offset`` inside, in its
        own frame; rows of zeros pad, :func:`hull_faces`), placed by ``R[p]``, ``t[p]``.  More
        candidates for :func:`candidate_depth`, each with its support known (an upper bound
        close to the exact depth, so that few pairs need :func:`expanding_depth`).  A fifth
        entry, when there is one: the hulls' edges (C, E, 12) or a function that returns
        them (:func:`hull_edges`, rows of zeros pad): with them a box's or a triangle's depth
        against the hull is exact (:func:`edge_depth`).
    """

    vertices: np.ndarray
    cylinder: np.ndarray
    center: np.ndarray
    axis: np.ndarray
    radius: np.ndarray
    half_length: np.ndarray
    margin: np.ndarray
    axes: np.ndarray
    rows: np.ndarray | None = None
    local: tuple | None = None
    complete: np.ndarray | None = None
    faces: tuple | None = None

    @property
    def points(self) -> np.ndarray:
        """Each piece's vertices (P, V, 3) [m] (copied out of a shared table, or placed)."""
        if self.local is not None:
            table, _, rows, poses = self.local
            R, t = poses[:, :9].reshape(-1, 3, 3), poses[:, 9:]
            return table[rows] @ np.transpose(R, (0, 2, 1)) + t[:, None, :]
        return self.vertices if self.rows is None else self.vertices[self.rows]

    def __len__(self) -> int:
        return len(self.center)

    @property
    def width(self) -> int:
        """Vertices per piece (a table's, for pieces in their own frames): what a block of
        them costs in memory once placed."""
        return int(self.local[0].shape[1] if self.local is not None else self.vertices.shape[1])

    def take(self, index) -> Pieces:
        """The pieces at ``index`` (an integer array), as a new batch."""
        shared = self.rows is not None
        local = None
        if self.local is not None:
            table, neighbours, rows, poses = self.local
            local = (table, neighbours, rows[index], poses[index])
        return Pieces(
            self.vertices if shared else self.vertices[index],
            self.cylinder[index],
            self.center[index],
            self.axis[index],
            self.radius[index],
            self.half_length[index],
            self.margin[index],
            self.axes[index],
            None if self.rows is None else self.rows[index],
            local,
            None if self.complete is None else self.complete[index],
            None
            if self.faces is None
            else (
                self.faces[0],
                self.faces[1][index],
                self.faces[2][index],
                self.faces[3][index],
                *self.faces[4:],
            ),
        )

    def materialized(self) -> Pieces:
        """The same pieces with their own vertex rows (a shared table copied out, pieces in
        their own frames placed)."""
        if self.rows is None and self.local is None:
            return self
        return dataclasses.replace(self, vertices=self.points, rows=None, local=None)

    def share(self, index) -> Pieces:
        """The pieces at ``index``, their vertices left in this batch's table (no copy): a
        hull of thousands of vertices met by many pairs is stored once, and :func:`distance`
        copies them out a block of pairs at a time (pieces in their own frames are only
        taken: their table is shared already)."""
        if self.local is not None:
            return self.take(index)
        table = (
            self if self.rows is not None else dataclasses.replace(self, rows=np.arange(len(self)))
        )
        return table.take(index)

    def support(self, d: np.ndarray) -> np.ndarray:
        """The core's farthest point in direction ``d`` (P, 3) -> (P, 3) [m] (margin excluded)."""
        vertices = self.points
        dots = np.einsum("pvi,pi->pv", vertices, d)
        out = vertices[np.arange(len(d)), np.argmax(dots, axis=1)]
        if self.cylinder.any():
            c = self.cylinder
            a, dc = self.axis[c], d[c]
            along = np.einsum("pi,pi->p", dc, a)
            radial = dc - along[:, None] * a
            radial -= np.einsum("pi,pi->p", radial, a)[:, None] * a  # rounding left along a
            norm = np.linalg.norm(radial, axis=1)
            # along the axis (to rounding) every point of the end disc supports: take its centre
            tiny = norm <= 1e-12 * np.linalg.norm(dc, axis=1)
            scale = np.divide(self.radius[c], norm, out=np.zeros_like(norm), where=~tiny)
            out[c] = (
                self.center[c]
                + np.where(along >= 0, 1.0, -1.0)[:, None] * self.half_length[c][:, None] * a
                + scale[:, None] * radial
            )
        return out

    def extent(self, n: np.ndarray) -> np.ndarray:
        """Support value max x.n over the piece, margin included: (P, 3) unit -> (P,) [m]."""
        return np.einsum("pi,pi->p", self.support(n), n) + self.margin


@dataclass
class Distances:
    """Result of :func:`distance` for P pairs.

    Attributes
    ----------
    distance : ndarray, shape (P,)
        Euclidean distance between the solids [m]; 0 when they touch or overlap.
    point_a, point_b : ndarray, shape (P, 3)
        Closest points on a and on b [m] (for overlapping pairs: a point of the overlap, twice).
    overlap : ndarray of bool, shape (P,)
        The solids share a point.
    iterations : ndarray of int, shape (P,)
    """

    distance: np.ndarray
    point_a: np.ndarray
    point_b: np.ndarray
    overlap: np.ndarray
    iterations: np.ndarray
    error: np.ndarray  # bound on (true distance - reported distance) [m]; 0 when converged
    # overlapping pairs: a lower bound on the penetration depth [m] GJK's last simplex gives
    # (0 where it gives none, and always from the numpy GJK)
    depth_bound: np.ndarray | None = None


def distance(a: Pieces, b: Pieces, max_iterations: int = MAX_ITERATIONS) -> Distances:
    """Distance between pieces ``a[k]`` and ``b[k]`` for every k (GJK).

    Runs the compiled GJK (:mod:`rworld_cli.collision.compiled`, one pair at a time in machine
    code) where kernels are available, else the same algorithm vectorised over the pairs in
    numpy; the two agree to rounding.

    Parameters
    ----------
    a, b : Pieces
        P pieces each, in the same (world) frame.
    max_iterations : int
        Pairs still short of the tolerance then (curved pieces nearly tangent) report GJK's
        lower bound ``v.w / |v|`` instead: never more than the true distance, and within
        ``Distances.error`` of it.

    Returns
    -------
    Distances
    """
    from .compiled import gjk, gjk_local, shape_rows

    if a.local is not None or b.local is not None:
        # pieces in their own frames: the compiled GJK climbs them where it runs; the other
        # side is read where it lies (a world table, or a shared one, by row)
        def side(p: Pieces):
            if p.local is not None:
                return p.local
            rows = p.rows if p.rows is not None else np.arange(len(p))
            return (p.vertices, None, rows, _IDENTITY_POSES(len(p)))

        rows = gjk_local(side(a), side(b), shape_rows(a), shape_rows(b), max_iterations)
        if rows is not None:
            return from_kernel(a, b, rows)
        a, b = a.materialized(), b.materialized()
    if a.rows is not None or b.rows is not None:
        # shared vertices: copied out a block of pairs at a time, so a hull of thousands of
        # vertices met by many pairs costs a block's memory, not all of it at once
        width = max(a.width, b.width, 1)
        block = max(1, SHARED_BUDGET // width)
        if len(a) > block:
            parts = [
                distance(
                    a.take(np.arange(s, min(len(a), s + block))),
                    b.take(np.arange(s, min(len(a), s + block))),
                    max_iterations,
                )
                for s in range(0, len(a), block)
            ]
            joined = {
                f.name: None  # the numpy GJK gives no depth bound
                if any(getattr(r, f.name) is None for r in parts)
                else np.concatenate([getattr(r, f.name) for r in parts])
                for f in dataclasses.fields(Distances)
            }
            return Distances(**joined)  # type: ignore[arg-type]
        a, b = a.materialized(), b.materialized()
    rows = gjk(a, b, max_iterations)
    if rows is None:
        return _distances(a, b, *_gjk_numpy(a, b, max_iterations))
    return from_kernel(a, b, rows)


def from_kernel(a: Pieces, b: Pieces, rows: np.ndarray) -> Distances:
    """:class:`Distances` of pieces ``a``, ``b`` from the compiled GJK's rows (P, 12)
    (:mod:`rworld_cli.collision.compiled`): margins applied, the depth bound kept where the
    pieces have none (a sphere's margin adds to the depth)."""
    out = _distances(
        a,
        b,
        rows[:, 1:4],
        rows[:, 4:7],
        rows[:, 7] != 0.0,
        rows[:, 8].astype(int),
        rows[:, 9],
        rows[:, 10] != 0.0,
    )
    out.depth_bound = np.where((a.margin == 0) & (b.margin == 0), rows[:, 11], 0.0)
    return out


def _IDENTITY_POSES(count: int) -> np.ndarray:
    """``count`` identity poses as rows of R then t (P, 12)."""
    out = np.zeros((count, 12))
    out[:, [0, 4, 8]] = 1.0
    return out


def _gjk_numpy(a: Pieces, b: Pieces, max_iterations: int):
    """GJK on the cores, vectorised over the pairs: (point_a, point_b, overlap, iterations,
    lower, unfinished) - the cores' nearest points (P, 3) each, whether they overlap, the
    iterations run, GJK's last lower bound on the distance, and whether a pair ran out of
    iterations."""
    P = len(a)
    # results, by pair
    weights_out = np.zeros((P, 4))
    from_a_out = np.zeros((P, 4, 3))
    from_b_out = np.zeros((P, 4, 3))
    overlap = np.zeros(P, dtype=bool)
    iterations = np.zeros(P, dtype=int)
    lower_out = np.full(P, np.nan)  # GJK's lower bound, for pairs that run out of iterations
    unfinished = np.zeros(P, dtype=bool)
    # the state of the pairs still running, compact (rows follow ``index``); the simplex holds
    # points 0 .. count-1 of the Minkowski difference a - b
    index = np.arange(P)
    A, B = a, b
    simplex = np.zeros((P, 4, 3))
    from_a = np.zeros((P, 4, 3))
    from_b = np.zeros((P, 4, 3))
    weights = np.zeros((P, 4))
    count = np.zeros(P, dtype=int)
    v = a.center - b.center
    v[np.einsum("pi,pi->p", v, v) < 1e-24] = (1.0, 0.0, 0.0)
    lower = np.full(P, np.nan)

    def finish(rows: np.ndarray) -> None:
        k = index[rows]
        weights_out[k] = weights[rows]
        from_a_out[k] = from_a[rows]
        from_b_out[k] = from_b[rows]
        lower_out[k] = lower[rows]

    for it in range(max_iterations):
        if not len(index):
            break
        sa = A.support(-v)
        sb = B.support(v)
        w = sa - sb
        iterations[index] += 1
        if it:
            vv = np.einsum("pi,pi->p", v, v)
            vw = np.einsum("pi,pi->p", v, w)
            gap = vv - vw  # |v| times the bound on |v| - distance
            norm_v = np.sqrt(vv)
            lower = vw / np.maximum(norm_v, 1e-300)
            # done: the distance is within 1e-10 of |v| relative to the pieces' scale, or within
            # ABSOLUTE_TOLERANCE [m] (touching pairs, where |v| tends to 0), or w is a point the
            # simplex already has (no progress is possible)
            scale = norm_v * (norm_v + np.linalg.norm(w, axis=1))
            done = (gap <= RELATIVE_TOLERANCE * scale) | (gap <= ABSOLUTE_TOLERANCE * norm_v)
            done |= np.any(
                (np.arange(4)[None, :] < count[:, None])
                & (np.abs(simplex - w[:, None, :]).max(axis=2) <= 1e-15 * (1 + scale[:, None])),
                axis=1,
            )
            if done.any():
                finish(np.flatnonzero(done))
                keep = np.flatnonzero(~done)
                index, A, B = index[keep], A.take(keep), B.take(keep)
                simplex, from_a, from_b = simplex[keep], from_a[keep], from_b[keep]
                weights, count, v, lower = weights[keep], count[keep], v[keep], lower[keep]
                sa, sb, w = sa[keep], sb[keep], w[keep]
                if not len(index):
                    break
        rows = np.arange(len(index))
        simplex[rows, count] = w
        from_a[rows, count] = sa
        from_b[rows, count] = sb
        count = count + 1
        lam, nearest, inside, order = _nearest_in_simplex(simplex, count)
        # compact each simplex: the points with positive weight in front
        simplex = np.take_along_axis(simplex, order[..., None], axis=1)
        from_a = np.take_along_axis(from_a, order[..., None], axis=1)
        from_b = np.take_along_axis(from_b, order[..., None], axis=1)
        weights = np.take_along_axis(lam, order, axis=1)
        count = np.sum(weights > 0, axis=1)
        v = nearest
        hit = inside | (np.einsum("pi,pi->p", nearest, nearest) <= 1e-30)
        if hit.any():
            finish(np.flatnonzero(hit))
            overlap[index[hit]] = True
            keep = np.flatnonzero(~hit)
            index, A, B = index[keep], A.take(keep), B.take(keep)
            simplex, from_a, from_b = simplex[keep], from_a[keep], from_b[keep]
            weights, count, v, lower = weights[keep], count[keep], v[keep], lower[keep]
    if len(index):  # out of iterations
        finish(np.arange(len(index)))
        unfinished[index] = True
    pa = np.einsum("pk,pki->pi", weights_out, from_a_out)
    pb = np.einsum("pk,pki->pi", weights_out, from_b_out)
    return pa, pb, overlap, iterations, lower_out, unfinished


def _distances(a, b, pa, pb, overlap, iterations, lower, unfinished) -> Distances:
    """The solids' distances from the cores' GJK (see :func:`_gjk_numpy`): the lower bound
    where a pair ran out of iterations, then the margins (spheres' radii)."""
    P = len(pa)
    core = np.where(overlap, 0.0, np.linalg.norm(pa - pb, axis=1))
    error = np.zeros(P)
    if unfinished.any():  # out of iterations: report the lower bound
        bound = np.clip(lower[unfinished], 0.0, core[unfinished])
        bound = np.where(np.isnan(bound), 0.0, bound)
        error[unfinished] = core[unfinished] - bound
        core[unfinished] = bound
    margin = a.margin + b.margin
    direction = np.divide(
        pb - pa, core[:, None], out=np.zeros_like(pa), where=core[:, None] > 0
    )  # from a towards b
    dist = np.maximum(core - margin, 0.0)
    overlap = overlap | (core <= margin)
    # move the closest points out by the margins (spheres' surfaces)
    point_a = pa + a.margin[:, None] * direction
    point_b = pb - b.margin[:, None] * direction
    mid = 0.5 * (point_a + point_b)
    point_a = np.where(overlap[:, None], mid, point_a)
    point_b = np.where(overlap[:, None], mid, point_b)
    return Distances(dist, point_a, point_b, overlap, iterations, error)


def _nearest_in_simplex(Y: np.ndarray, count: np.ndarray):
    """Nearest point to the origin of the convex hull of each simplex's first ``count`` points.

    Parameters
    ----------
    Y : ndarray, shape (P, 4, 3)
    count : ndarray of int, shape (P,)
        1 to 4; the last of them is the newest point.

    Returns
    -------
    weights : ndarray, shape (P, 4)
        Barycentric weights (0 for points not needed).
    nearest : ndarray, shape (P, 3)
    inside : ndarray of bool, shape (P,)
        The origin lies inside a full tetrahedron.
    order : ndarray of int, shape (P, 4)
        A permutation putting the points with positive weight first.
    """
    P = len(Y)
    best = np.full(P, np.inf)
    weights = np.zeros((P, 4))
    nearest = np.zeros((P, 3))
    inside = np.zeros(P, dtype=bool)
    for n, faces in _FACES.items():
        group = np.flatnonzero(count == n)
        if not len(group):
            continue
        Yg = Y[group]
        for face in faces:
            idx = list(face)
            lam, valid = _affine_nearest(Yg[:, idx])
            point = np.einsum("rk,rki->ri", lam, Yg[:, idx])
            d2 = np.einsum("ri,ri->r", point, point)
            better = valid & (d2 < best[group])
            r = group[better]
            best[r] = d2[better]
            nearest[r] = point[better]
            weights[r] = 0.0
            weights[r[:, None], np.array(idx)[None, :]] = lam[better]
            if len(idx) == 4:
                inside[r] = True
    order = np.argsort(weights <= 0, axis=1, kind="stable")
    return weights, nearest, inside, order


def _affine_nearest(pts: np.ndarray):
    """Barycentric weights of the origin's projection on the affine hull of k points (R, k, 3),
    and whether they are all non-negative (with a non-degenerate hull).
    """
    R, k = pts.shape[:2]
    if k == 1:
        return np.ones((R, 1)), np.ones(R, dtype=bool)
    p0 = pts[:, 0]
    E = pts[:, 1:] - p0[:, None, :]
    G = np.einsum("rai,rbi->rab", E, E)
    rhs = -np.einsum("rai,ri->ra", E, p0)
    if k == 2:
        det = G[:, 0, 0]
        size = det
        mu = (rhs[:, 0] / np.where(det > 0, det, 1.0))[:, None]
    elif k == 3:
        a, b, c = G[:, 0, 0], G[:, 0, 1], G[:, 1, 1]
        det = a * c - b * b
        size = a * c
        safe = np.where(det > 0, det, 1.0)
        mu = np.stack(
            [(c * rhs[:, 0] - b * rhs[:, 1]) / safe, (a * rhs[:, 1] - b * rhs[:, 0]) / safe],
            axis=1,
        )
    else:
        # Cramer's rule with the columns of E: the triple product gives the determinant
        cof = np.stack(
            [np.cross(E[:, 1], E[:, 2]), np.cross(E[:, 2], E[:, 0]), np.cross(E[:, 0], E[:, 1])],
            axis=1,
        )
        vol = np.einsum("ri,ri->r", E[:, 0], cof[:, 0])
        det = vol * vol
        size = np.prod(np.einsum("rai,rai->ra", E, E), axis=1)
        safe = np.where(np.abs(vol) > 0, vol, 1.0)
        # in 3-D the affine hull is everything: the origin's weights solve E^T mu = -p0
        mu = np.einsum("rai,ri->ra", cof, -p0) / safe[:, None]
    valid = det > 1e-24 * np.maximum(size, 1e-300) if k > 2 else det > 0
    lam = np.concatenate([1.0 - mu.sum(axis=1, keepdims=True), mu], axis=1)
    valid = valid & np.all(lam >= 0.0, axis=1)
    return lam, valid


def penetration(
    a: Pieces,
    b: Pieces,
    deep_enough: float = np.inf,
    state: np.ndarray | None = None,
    exact_above: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Penetration depth of overlapping pieces (module docstring): exact for pairs of
    ``complete`` pieces by their candidate directions, by :func:`expanding_depth` for the
    others.

    Parameters
    ----------
    a, b : Pieces
        P pairs (expected to overlap).
    deep_enough : float
        Depths are exact up to this [m]: a pair shown deeper is reported with a depth above
        it, not measured further (a collision test needs no more).
    state : ndarray of int, shape (P,), optional
        Each pair's group (its state): only each group's deepest pair is measured exactly; the
        others keep an upper bound that does not exceed it (what a state's depth, the deepest
        of its pairs, needs).  The pairs are measured deepest bound first.
    exact_above : float
        Depths are exact above this [m]: a pair whose candidates bound it at or below (a
        touch within the collision tolerance, whatever its depth) keeps that bound.

    Returns
    -------
    depth : ndarray, shape (P,)
        How far b must move along ``normal`` to separate [m] (0 or less: they do not overlap).
    normal : ndarray, shape (P, 3)
        Unit direction from a towards b.
    """
    P = len(a)
    # a box or a triangle against a hull with its edges (either way round): bounded first by
    # the hull's faces alone, then measured exactly by every candidate with the edges' crosses
    # (edge_depth), in waves - each state's deepest bound not yet measured, while it can still
    # be its deepest pair and the state is not deeper than asked already
    hull_side = np.zeros(P)  # +1: a is the hull, -1: b is
    for faced, other, towards in ((a, b, 1.0), (b, a, -1.0)):
        if faced.faces is not None and len(faced.faces) >= 5 and other.complete is not None:
            hull_side[other.complete & ~other.cylinder & ~faced.cylinder & (hull_side == 0)] = (
                towards
            )
    best, normal = np.full(P, np.inf), np.zeros((P, 3))
    rows = np.flatnonzero(hull_side == 0)
    if len(rows):
        best[rows], normal[rows] = candidate_depth(a.take(rows), b.take(rows))
    rows = np.flatnonzero(hull_side)
    if len(rows):
        # the hull's faces, and the other's own face normals (a triangle's, a box's axes):
        # a tight bound where a state's pairs all reach about as deep (a hull through a
        # plate's triangles), so that the deepest measured leaves the rest below it
        A, B = a.take(rows), b.take(rows)
        best[rows], normal[rows] = candidate_depth(A, B, directions=False)
        axes = np.where((hull_side[rows] > 0)[:, None, None], B.axes, A.axes)
        own = np.concatenate([axes, np.cross(axes[:, 0], axes[:, 1])[:, None]], axis=1)
        value, direction = _direction_depth(A, B, own)
        better = value < best[rows]
        best[rows[better]], normal[rows[better]] = value[better], direction[better]
    exact = np.zeros(P, dtype=bool)
    if a.complete is not None and b.complete is not None:
        exact = a.complete & b.complete & (hull_side == 0)
    rows = np.flatnonzero(~exact & (best > max(exact_above, 0.0)))
    # each group's deepest measured so far (the complete pairs' exact already); no groups: a
    # floor that never skips
    _, group = np.unique(np.zeros(P) if state is None else state, return_inverse=True)
    floor = np.full(group.max(initial=-1) + 1, -np.inf)
    if state is not None:
        np.maximum.at(floor, group[exact], best[exact])
    todo = rows[hull_side[rows] != 0]
    rows = rows[hull_side[rows] == 0]
    todo = todo[np.argsort(-best[todo], kind="stable")]
    per_state = 1  # rows of each state measured at once: 1, 2, 4, ... (all without states)
    while len(todo):
        # a bound within DEPTH_TOLERANCE of its state's deepest: no deeper than the tolerance
        # the depths are exact to (ties: a plate's triangles a hull reaches through alike)
        above = best[todo] > floor[group[todo]] + DEPTH_TOLERANCE
        todo = todo[above & (floor[group[todo]] <= deep_enough)]
        wave = todo if state is None else todo[rank_in_group(group[todo]) < per_state]
        if not len(wave):
            break
        # the faces' and the other's normals' bound is the least over those candidates
        # already: the edges' crosses are the rest
        value, direction = best[wave], normal[wave]
        for towards, (faced, other) in ((1.0, (a, b)), (-1.0, (b, a))):
            mine = np.flatnonzero(hull_side[wave] == towards)
            if not len(mine):
                continue
            least, along = edge_depth(faced.take(wave[mine]), other.take(wave[mine]))
            better = least < value[mine]
            value[mine[better]] = least[better]
            direction[mine[better]] = towards * along[better]
        best[wave], normal[wave] = value, direction  # exact now
        if state is not None:
            np.maximum.at(floor, group[wave], best[wave])
        todo = np.setdiff1d(todo, wave, assume_unique=True)
        todo = todo[np.argsort(-best[todo], kind="stable")]
        per_state *= 2
    if not len(rows):
        return best, normal
    # a point core (a sphere's) in a cylinder: the point's depth below its side or its cap, in
    # closed form (the expanding polytope converges slowly on a curved side)
    for point, round_, towards in ((a, b, -1.0), (b, a, 1.0)):
        sel = rows[round_.cylinder[rows] & ~point.cylinder[rows]]
        sel = sel[np.ptp(point.points[sel], axis=1).max(axis=1) == 0.0] if len(sel) else sel
        if not len(sel):
            continue
        u = point.points[sel, 0] - round_.center[sel]
        axis = round_.axis[sel]
        z = np.einsum("pi,pi->p", u, axis)
        radial = u - z[:, None] * axis
        rho = np.linalg.norm(radial, axis=1)
        side = round_.radius[sel] - rho
        cap = round_.half_length[sel] - np.abs(z)
        margins = point.margin[sel] + round_.margin[sel]
        out = np.where(rho > 0, 1.0, 0.0)[:, None] * radial / np.maximum(rho, 1e-300)[:, None]
        out = np.where((side <= cap)[:, None], out, np.sign(z + (z == 0))[:, None] * axis)
        best[sel] = np.minimum(side, cap) + margins
        normal[sel] = towards * out  # from a towards b: the point leaves by that side
        rows = np.setdiff1d(rows, sel)
    for k in rows[np.argsort(-best[rows], kind="stable")]:
        if best[k] <= floor[group[k]] + DEPTH_TOLERANCE:
            continue  # an upper bound below a deeper pair of its state: that one counts
        one = np.array([k])
        start = (float(best[k]), normal[k].copy())
        depth, n = expanding_depth(a.take(one), b.take(one), deep_enough, start)
        if depth < best[k]:
            best[k], normal[k] = depth, n
        if state is not None:
            floor[group[k]] = max(floor[group[k]], best[k])
    return best, normal


def candidate_depth(a: Pieces, b: Pieces, directions: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """The least projection overlap of P pairs over their candidate directions (module
    docstring): an upper bound on the penetration depth, exact for ``complete`` pieces;
    (depth (P,) [m], unit normal from a towards b (P, 3)).  ``directions`` False: the
    hulls' faces only (each costs the other piece's few vertices, not the hull's many; inf
    where neither piece has faces)."""
    P = len(a)
    if not directions:
        best, normal = np.full(P, np.inf), np.zeros((P, 3))
    else:
        best, normal = _direction_depth(a, b)
    # a hull's faces: the other piece pushed out through each (its support along the face's
    # normal is the face's offset), the other's vertices taken into the hull's frame
    for faced, other, towards in ((a, b, 1.0), (b, a, -1.0)):
        if faced.faces is None:
            continue
        table, row, R, t = faced.faces[:4]
        table = table() if callable(table) else table
        usable = np.abs(table[..., :3]).sum(axis=2) > 0.5  # (C, F): padding rows out
        # a cylinder's extent along the normals: in world, in closed form
        round_ = np.flatnonzero(other.cylinder)
        block = max(1, PENETRATION_BUDGET // table.shape[1])
        for start in range(0, len(round_), block):
            sel = round_[start : start + block]
            placed = place_faces(table[row[sel]], R[sel], t[sel])
            _, lo = _extents(other.take(sel), placed[..., :3])
            value = placed[..., 3] + faced.margin[sel, None] - lo
            value = np.where(usable[row[sel]], value, np.inf)
            f = np.argmin(value, axis=1)
            least = value[np.arange(len(sel)), f]
            better = least < best[sel]
            best[sel[better]] = least[better]
            normal[sel[better]] = towards * placed[better, f[better], :3]
        for part in np.unique(row[~other.cylinder]):
            rows = np.flatnonzero((row == part) & ~other.cylinder)
            n, offset = table[part, :, :3], table[part, :, 3]
            block = max(1, PENETRATION_BUDGET // (max(other.width, 1) * len(n)))
            for start in range(0, len(rows), block):
                sel = rows[start : start + block]
                points = other.take(sel).points  # placed a block at a time (a large hull)
                local = np.einsum("pji,pvj->pvi", R[sel], points - t[sel, None, :])
                lo = (local @ n.T).min(axis=1) - other.margin[sel, None]  # (S, F)
                value = offset + faced.margin[sel, None] - lo
                value = np.where(usable[part], value, np.inf)
                f = np.argmin(value, axis=1)
                least = value[np.arange(len(sel)), f]
                better = least < best[sel]
                best[sel[better]] = least[better]
                normal[sel[better]] = towards * np.einsum(
                    "pij,pj->pi", R[sel[better]], n[f[better]]
                )
    return best, normal


def _direction_depth(
    a: Pieces, b: Pieces, dirs: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`candidate_depth` over the pieces' own directions (their axes, their crosses,
    the centre line, the triangles' normals), not the hulls' faces; or over ``dirs`` (P, D,
    3), any lengths."""
    P = len(a)
    if dirs is None:
        cands = [a.axes[:, i] for i in range(3)] + [b.axes[:, i] for i in range(3)]
        cands += [np.cross(a.axes[:, i], b.axes[:, j]) for i in range(3) for j in range(3)]
        cands.append(b.center - a.center)
        # a triangle's normal (its first two edges crossed; a box's third axis again)
        cands += [np.cross(a.axes[:, 0], a.axes[:, 1]), np.cross(b.axes[:, 0], b.axes[:, 1])]
        dirs = np.stack(cands, axis=1)  # (P, D, 3)
    length = np.linalg.norm(dirs, axis=2)
    good = length > 1e-9
    dirs = np.divide(dirs, length[..., None], out=np.zeros_like(dirs), where=good[..., None])
    dirs[~good] = (1.0, 0.0, 0.0)
    depth = np.empty((P, dirs.shape[1], 2))
    # every direction in one product per block of pairs (not one pass over the vertices per
    # direction and sign): a hull of thousands of vertices is read once
    width = max(a.width, b.width, 1)
    block = max(1, PENETRATION_BUDGET // (width * dirs.shape[1]))
    for start in range(0, P, block):
        sl = slice(start, min(P, start + block))
        hi_a, lo_a = _extents(a.take(np.arange(sl.start, sl.stop)), dirs[sl])
        hi_b, lo_b = _extents(b.take(np.arange(sl.start, sl.stop)), dirs[sl])
        # b moved along +n: a's reach along n less b's least; along -n: the other way round
        depth[sl, :, 0] = hi_a - lo_b
        depth[sl, :, 1] = hi_b - lo_a
    flat = np.where(good[..., None], depth, np.inf).reshape(P, -1)
    pick = np.argmin(flat, axis=1)  # the first least, in the candidates' order
    best = flat[np.arange(P), pick]
    sign = np.where(pick % 2 == 0, 1.0, -1.0)
    normal = sign[:, None] * dirs[np.arange(P), pick // 2]
    normal[~np.isfinite(best)] = 0.0
    return best, normal


def edge_depth(hull: Pieces, other: Pieces) -> tuple[np.ndarray, np.ndarray]:
    """The least overlap of P pairs over the cross products of an edge of ``other`` (its
    ``axes``: a triangle's edges, a box's axes) with an edge of ``hull`` (``hull.faces``'
    fifth entry, :func:`hull_edges`) that lie in that hull edge's normal cone: (value (P,)
    [m], inf where there is none; unit direction (P, 3) in world, along which ``other``
    moves out of ``hull``).

    The directions normal to an edge ``a`` of the other form a great circle; a hull edge's
    normal cone is the arc between its faces' normals ``f1``, ``f2``.  The circle crosses the
    arc where ``f1.a`` and ``f2.a`` differ in sign, at ``d = |f2.a| f1 + |f1.a| f2`` (normal
    to both edges, inside the cone).  There the hull's support along ``d`` is the edge, so
    each candidate costs the other piece's few vertices, not the hull's many.  With the
    hull's faces and the other's own face normals (:func:`candidate_depth`) these are every
    face normal of the pair's Minkowski difference: the least over all is the exact depth.
    Worked in the hull's frame (the other's vertices and edges moved there)."""
    P = len(hull)
    value = np.full(P, np.inf)
    direction = np.zeros((P, 3))
    assert hull.faces is not None and len(hull.faces) >= 5
    _, row, R, t = hull.faces[:4]
    edges = hull.faces[4]
    edges = edges() if callable(edges) else edges
    points = other.points
    margins = hull.margin + other.margin
    for part in np.unique(row):
        rows = np.flatnonzero(row == part)
        e = edges[part]
        e = e[np.abs(e[:, 3:6]).sum(axis=1) > 0]  # padding rows out
        if not len(e):
            continue
        start, f1, f2 = e[:, 0:3], e[:, 6:9], e[:, 9:12]
        block = max(1, PENETRATION_BUDGET // (3 * len(e)))
        for first in range(0, len(rows), block):
            sel = rows[first : first + block]
            Rs, ts = R[sel], t[sel]
            local = np.einsum("sji,svj->svi", Rs, points[sel] - ts[:, None, :])  # (S, V, 3)
            axes = np.einsum("sji,saj->sai", Rs, other.axes[sel])  # (S, 3, 3)
            s1, s2 = axes @ f1.T, axes @ f2.T  # (S, 3, E)
            s_k, a_k, e_k = np.nonzero(s1 * s2 < 0.0)  # the circle crosses the arc
            if not len(s_k):
                continue
            d = np.abs(s2[s_k, a_k, e_k])[:, None] * f1[e_k]
            d += np.abs(s1[s_k, a_k, e_k])[:, None] * f2[e_k]
            d /= np.linalg.norm(d, axis=1, keepdims=True)
            # the other moved along d out past the hull's reach (the edge's) by its least
            least = np.einsum("ni,ni->n", d, start[e_k])
            least -= np.einsum("nvi,ni->nv", local[s_k], d).min(axis=1)
            # each row's least candidate: sorted by row then value, the first of each row
            order = np.lexsort((least, s_k))
            keep = order[np.r_[True, s_k[order][1:] != s_k[order][:-1]]]
            mine = sel[s_k[keep]]
            value[mine] = least[keep] + margins[mine]
            direction[mine] = np.einsum("sij,sj->si", Rs[s_k[keep]], d[keep])
    return value, direction


def hull_edges(vertices: np.ndarray) -> np.ndarray:
    """The edges of the hull of ``vertices`` (V, 3) [m] between faces that are not coplanar,
    each once: (E, 12) rows ``[start (3), end - start (3), outward unit normal of one face
    (3), of the other (3)]``; none (0, 12) for a flat or degenerate set."""
    return hull_tables(vertices)[1]


def hull_tables(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`hull_faces` and :func:`hull_edges` of ``vertices`` (V, 3) from one qhull."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        hull = ConvexHull(vertices)
    except (QhullError, ValueError):
        return np.zeros((0, 4)), np.zeros((0, 12))
    faces = np.column_stack([hull.equations[:, :3], -hull.equations[:, 3]])
    _, first = np.unique(np.round(faces, 12), axis=0, return_index=True)
    simplices, neighbours, n = hull.simplices, hull.neighbors, hull.equations[:, :3]
    i = np.repeat(np.arange(len(simplices)), 3)
    j = np.tile(np.arange(3), len(simplices))
    k = neighbours[i, j]  # the facet across the edge opposite vertex j
    keep = i < k
    i, j, k = i[keep], j[keep], k[keep]
    keep = np.einsum("ei,ei->e", n[i], n[k]) < 1.0 - 1e-12  # an edge inside a flat face: none
    i, j, k = i[keep], j[keep], k[keep]
    p0 = hull.points[simplices[i, (j + 1) % 3]]
    p1 = hull.points[simplices[i, (j + 2) % 3]]
    return faces[np.sort(first)], np.column_stack([p0, p1 - p0, n[i], n[k]])


DEPTH_TOLERANCE = 1e-9  # [m] expanding_depth stops when its bounds are this close
DEPTH_ITERATIONS = 200  # expansions at most (a polytope pair needs a few dozen)
# the first support points: the 26 directions of a cube's faces, edges and corners
_SEED_DIRECTIONS = np.array(
    [
        [x, y, z]
        for x in (-1, 0, 1)
        for y in (-1, 0, 1)
        for z in (-1, 0, 1)
        if (x, y, z) != (0, 0, 0)
    ],
    dtype=float,
)
_SEED_DIRECTIONS /= np.linalg.norm(_SEED_DIRECTIONS, axis=1, keepdims=True)


def expanding_depth(
    a: Pieces, b: Pieces, deep_enough: float = np.inf, start: tuple | None = None
) -> tuple[float, np.ndarray]:
    """The penetration depth of one pair of overlapping convex pieces (any kind) [m], to
    :data:`DEPTH_TOLERANCE`, and its unit normal from a towards b (3,).

    The Minkowski difference ``D = a - b`` holds the origin; the depth is the least of its
    support function ``h(u) = max_a u.x - min_b u.y`` over unit ``u``, the distance from the
    origin to D's boundary.  Two polytopes of at most :data:`EXACT_HULL_POINTS` vertex
    differences: D is their hull, its face nearest the origin found by qhull at once (unless
    the hull of 28 support points, inside D, already puts the depth above ``deep_enough``).
    Otherwise (larger hulls, a cylinder): support points of D along the candidate directions
    and 26 more are its inner polytope; while the origin is not inside it, the supports along
    the normals of the faces it lies beyond are added (none new: the origin is on D's
    boundary, depth 0).  Then, as the expanding polytope algorithm: the face nearest the
    origin (distance ``d``, normal ``n``) is a lower bound and ``h(n)`` an upper one; the
    support along ``n`` is added until they meet, or the lower bound is above
    ``deep_enough``.  The upper bound is returned (a depth never below the exact one).
    ``start``: the pair's :func:`candidate_depth` (depth, normal), when known."""
    from scipy.spatial import ConvexHull, QhullError

    if start is None:
        best, normal = candidate_depth(a, b)
        start = (float(best[0]), normal[0])
    upper, upper_n = start[0], np.array(start[1], dtype=float)
    normal = upper_n[None]
    margin = float(a.margin[0] + b.margin[0])
    # each polytope's vertices placed once (a support is then one product, not a copy of the
    # hull per direction), without its padding
    pa = _distinct(a.points[0]) if not a.cylinder[0] else None
    pb = _distinct(b.points[0]) if not b.cylinder[0] else None
    # (3, V) copies: a support is then a row-wise argmax over contiguous memory
    pa_t = None if pa is None else np.ascontiguousarray(pa.T)
    pb_t = None if pb is None else np.ascontiguousarray(pb.T)

    def support(u: np.ndarray) -> np.ndarray:  # the cores' difference's support points (M, 3)
        M = len(u)
        if pa is not None:
            sa = pa[np.argmax(u @ pa_t, axis=1)]
        else:
            sa = a.take(np.zeros(M, dtype=int)).support(u)
        if pb is not None:
            sb = pb[np.argmin(u @ pb_t, axis=1)]
        else:
            sb = b.take(np.zeros(M, dtype=int)).support(-u)
        return sa - sb

    dirs = np.concatenate([_SEED_DIRECTIONS, normal, -normal])
    dirs = dirs[np.linalg.norm(dirs, axis=1) > 0.5]
    points = support(dirs)  # the inner polytope: the expansion's start, or the small pairs' bound
    if pa is not None and pb is not None and len(pa) * len(pb) <= EXACT_HULL_POINTS:
        if np.isfinite(deep_enough):
            # the seeds' inner polytope bounds the depth from below: deeper than asked, the
            # whole difference's hull is not needed
            try:
                seeds = ConvexHull(points)
                least = float(np.min(-seeds.equations[:, 3]))
                if least > 0.0 and least + margin > deep_enough:  # the origin inside
                    return upper, upper_n
            except (QhullError, ValueError):
                pass
        try:
            hull = ConvexHull((pa[:, None, :] - pb[None, :, :]).reshape(-1, 3))
        except (QhullError, ValueError):  # flat: the origin on D's boundary
            return min(upper, margin), upper_n
        face = int(np.argmin(-hull.equations[:, 3]))
        depth = max(float(-hull.equations[face, 3]), 0.0) + margin
        if depth < upper:
            upper, upper_n = depth, hull.equations[face, :3].copy()
        return upper, upper_n
    for _ in range(DEPTH_ITERATIONS):
        try:
            hull = ConvexHull(points)
        except (QhullError, ValueError):  # flat: the origin on D's boundary (or no volume)
            return min(upper, margin), upper_n
        n, offset = hull.equations[:, :3], -hull.equations[:, 3]  # n.x <= offset inside
        beyond = offset <= 0.0
        if beyond.any():  # the origin not inside the inner polytope yet
            new = support(n[beyond])
            gain = np.einsum("ij,ij->i", new, n[beyond]) - offset[beyond]
            if not (gain > DEPTH_TOLERANCE).any():
                return min(upper, margin), upper_n  # on D's boundary: touching
            points = np.concatenate([points, new[gain > DEPTH_TOLERANCE]])
            continue
        face = int(np.argmin(offset))
        u = n[face]
        s = support(u[None])[0]
        h = float(u @ s)
        if h + margin < upper:
            upper, upper_n = h + margin, u.copy()
        if h - offset[face] <= DEPTH_TOLERANCE or offset[face] + margin > deep_enough:
            break
        points = np.concatenate([points, s[None]])
    return upper, upper_n


def rank_in_group(group: np.ndarray) -> np.ndarray:
    """Each row's place among the rows of its group (0 for the first), in row order."""
    order = np.argsort(group, kind="stable")
    sorted_group = group[order]
    position = np.arange(len(group))
    first = np.maximum.accumulate(
        np.where(np.r_[True, sorted_group[1:] != sorted_group[:-1]], position, 0)
    )
    rank = np.empty(len(group), dtype=int)
    rank[order] = position - first
    return rank


def _distinct(points: np.ndarray) -> np.ndarray:
    """A piece's own vertices (V, 3): its padding (copies of its first vertex after its last,
    :mod:`.pieces`) cut off."""
    other = np.flatnonzero(np.any(points != points[0], axis=1))
    return points[: (other[-1] + 1) if len(other) else 1]


# vertex differences of two polytopes hulled at once, at most (more: the expansion)
EXACT_HULL_POINTS = 1_500


PENETRATION_BUDGET = 8_000_000  # vertex-direction products per block of penetration pairs


def _extents(p: Pieces, dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each piece's largest and least projection on its directions (P, D, 3) unit, margin
    included: (P, D) each [m]."""
    same = _same_hulls(p)
    if same is not None:  # a few hulls met by many pairs: each placed once, all its rows at once
        hi, lo = np.empty(dirs.shape[:2]), np.empty(dirs.shape[:2])
        for rows in same:
            vertices = p.take(rows[:1]).points[0]  # (V, 3)
            proj = vertices @ dirs[rows].reshape(-1, 3).T  # (V, n D)
            hi[rows] = proj.max(axis=0).reshape(len(rows), -1)
            lo[rows] = proj.min(axis=0).reshape(len(rows), -1)
    else:
        proj = p.points @ np.transpose(dirs, (0, 2, 1))  # (P, V, D)
        hi, lo = proj.max(axis=1), proj.min(axis=1)
    c = p.cylinder
    if c.any():  # a cylinder's support in closed form: centre, end cap, rim
        along = np.einsum("pdi,pi->pd", dirs[c], p.axis[c])
        radial = np.sqrt(np.maximum(1.0 - along**2, 0.0))
        centre = np.einsum("pdi,pi->pd", dirs[c], p.center[c])
        reach = p.half_length[c][:, None] * np.abs(along) + p.radius[c][:, None] * radial
        hi[c], lo[c] = centre + reach, centre - reach
    return hi + p.margin[:, None], lo - p.margin[:, None]


def _same_hulls(p: Pieces) -> list[np.ndarray] | None:
    """The rows of ``p`` grouped by hull (the same part at the same pose, by its faces'
    entry), when there are at most a quarter as many hulls as rows: a link's hull against
    the many triangles of a fixture, at a few states.  None otherwise (or no faces)."""
    if p.faces is None or len(p) < 8:
        return None
    _, row, R, t = p.faces[:4]
    key = np.column_stack([row, R.reshape(-1, 9), t])
    order = np.lexsort(key.T[::-1])
    ordered = key[order]
    starts = np.flatnonzero(np.r_[True, np.any(ordered[1:] != ordered[:-1], axis=1)])
    if 4 * len(starts) > len(p):
        return None
    return np.split(order, starts[1:])


# --------------------------------------------------------------------------- building pieces

_CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)


def box_corners(half: np.ndarray) -> np.ndarray:
    """The 8 corners (8, 3) of a box with half extents ``half`` (3,) in its own frame [m]."""
    return _CORNERS * np.asarray(half, dtype=float)


def boxes(T: np.ndarray, half: np.ndarray) -> Pieces:
    """Boxes centred at ``T[:, :3, 3]`` with axes ``T[:, :3, :3]`` and half extents (P, 3) [m]."""
    T = np.asarray(T, dtype=float).reshape(-1, 4, 4)
    half = np.broadcast_to(np.asarray(half, dtype=float), (len(T), 3))
    R, c = T[:, :3, :3], T[:, :3, 3]
    vertices = c[:, None, :] + np.einsum("pij,pvj->pvi", R, _CORNERS * half[:, None, :])
    P = len(T)
    return Pieces(
        vertices,
        np.zeros(P, dtype=bool),
        c.copy(),
        R[:, :, 2].copy(),
        np.zeros(P),
        np.zeros(P),
        np.zeros(P),
        np.transpose(R, (0, 2, 1)).copy(),
        complete=np.ones(P, dtype=bool),
    )


def spheres(center: np.ndarray, radius: np.ndarray) -> Pieces:
    """Spheres: centres (P, 3) and radii (P,) [m]."""
    c = np.asarray(center, dtype=float).reshape(-1, 3)
    P = len(c)
    return Pieces(
        np.repeat(c[:, None, :], 8, axis=1),
        np.zeros(P, dtype=bool),
        c.copy(),
        np.tile([0.0, 0.0, 1.0], (P, 1)),
        np.zeros(P),
        np.zeros(P),
        np.broadcast_to(np.asarray(radius, dtype=float), (P,)).copy(),
        np.broadcast_to(np.eye(3), (P, 3, 3)).copy(),
        complete=np.ones(P, dtype=bool),
    )


def cylinders(T: np.ndarray, radius: np.ndarray, half_length: np.ndarray) -> Pieces:
    """Cylinders centred at ``T[:, :3, 3]`` along ``T[:, :3, 2]``; radius and half length [m]."""
    T = np.asarray(T, dtype=float).reshape(-1, 4, 4)
    P = len(T)
    c = T[:, :3, 3]
    return Pieces(
        np.repeat(c[:, None, :], 8, axis=1),
        np.ones(P, dtype=bool),
        c.copy(),
        T[:, :3, 2].copy(),
        np.broadcast_to(np.asarray(radius, dtype=float), (P,)).copy(),
        np.broadcast_to(np.asarray(half_length, dtype=float), (P,)).copy(),
        np.zeros(P),
        np.transpose(T[:, :3, :3], (0, 2, 1)).copy(),
    )


def triangles(tri: np.ndarray) -> Pieces:
    """Triangles (P, 3, 3) [m] as flat polytopes."""
    tri = np.asarray(tri, dtype=float).reshape(-1, 3, 3)
    P = len(tri)
    vertices = tri.copy()
    # its three edges as its axes: with their crosses (the normal, each against the other
    # piece's) the exact candidates of penetration
    axes = tri[:, [1, 2, 0]] - tri
    axes /= np.linalg.norm(axes, axis=2, keepdims=True) + 1e-300
    n = np.cross(axes[:, 0], axes[:, 1])
    n /= np.linalg.norm(n, axis=1, keepdims=True) + 1e-300
    return Pieces(
        vertices,
        np.zeros(P, dtype=bool),
        tri.mean(axis=1),
        n,
        np.zeros(P),
        np.zeros(P),
        np.zeros(P),
        axes,
        complete=np.ones(P, dtype=bool),
    )


def hulls(vertices: np.ndarray, axes: np.ndarray, faces: tuple | None = None) -> Pieces:
    """Convex polytopes given by their vertices.

    Parameters
    ----------
    vertices : ndarray, shape (P, V, 3)
        Each polytope's vertices in world [m] (a vertex repeated to fill V).
    axes : ndarray, shape (P, 3, 3)
        Unit directions as rows (principal axes): candidate axes for :func:`penetration`.
    faces : tuple, optional
        Their faces (:attr:`Pieces.faces`).
    """
    P = len(vertices)
    return Pieces(
        np.asarray(vertices, dtype=float),
        np.zeros(P, dtype=bool),
        vertices.mean(axis=1),
        axes[:, 2].copy(),
        np.zeros(P),
        np.zeros(P),
        np.zeros(P),
        np.asarray(axes, dtype=float),
        faces=faces,
    )


def hull_faces(vertices: np.ndarray) -> np.ndarray:
    """The faces of the hull of ``vertices`` (V, 3) [m]: unit outward normals and offsets
    (F, 4), ``n.x <= offset`` inside, each normal once (coplanar facets merged); none (0, 4)
    for a flat or degenerate set."""
    return hull_tables(vertices)[0]


def place_faces(faces: np.ndarray, R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Faces (..., F, 4) of a frame moved by rotation ``R`` (..., 3, 3) and translation ``t``
    (..., 3) into world: the normals turned, the offsets moved along them; zero rows stay."""
    n = np.einsum("...ij,...fj->...fi", R, faces[..., :3])
    offset = faces[..., 3] + np.einsum("...fi,...i->...f", n, t)
    return np.concatenate([n, np.where(np.abs(n).sum(-1) > 0.5, offset, 0.0)[..., None]], -1)


def box_neighbours(width: int = 8) -> np.ndarray:
    """:func:`hull_neighbours` of :func:`box_corners` in closed form: corner ``4x + 2y + z``
    (each bit a sign) and the three corners that differ from it in one bit, padded with -1 to
    ``width`` rows (8, 3).  Exact for climbing on any box, flat ones too: a linear function
    on a box's corners is a sum over its axes, so a corner no neighbour beats is the best."""
    out = np.full((max(width, 8), 3), -1, dtype=np.int64)
    corner = np.arange(8)
    out[:8] = corner[:, None] ^ np.array([4, 2, 1])
    return out


def hull_neighbours(vertices: np.ndarray, width: int | None = None) -> np.ndarray:
    """Each vertex's neighbours on the convex hull of ``vertices`` (V, 3) - every vertex must be
    one of the hull's -, as rows of indices padded with -1 to the largest count (V, D), or to
    ``width`` rows.  A flat or degenerate set (no hull with volume) gives -2 in the first
    entry: the compiled GJK then scans every vertex (:func:`rworld_cli.collision.compiled.
    gjk_local`)."""
    from scipy.spatial import ConvexHull, QhullError

    V = len(vertices)
    rows = V if width is None else width
    if V <= 1:
        return np.full((rows, 1), -1, dtype=np.int64)
    try:
        hull = ConvexHull(vertices)
    except (QhullError, ValueError):
        out = np.full((rows, 1), -1, dtype=np.int64)
        out[0, 0] = -2
        return out
    if len(hull.vertices) != V:  # not every point on the hull: climbing could stop inside
        out = np.full((rows, 1), -1, dtype=np.int64)
        out[0, 0] = -2
        return out
    edges = np.unique(np.sort(hull.simplices[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0)
    both = np.concatenate([edges, edges[:, ::-1]])
    both = both[np.argsort(both[:, 0], kind="stable")]
    counts = np.bincount(both[:, 0], minlength=V)
    out = np.full((rows, int(counts.max())), -1, dtype=np.int64)
    starts = np.r_[0, np.cumsum(counts)[:-1]]
    slot = np.arange(len(both)) - starts[both[:, 0]]
    out[both[:, 0], slot] = both[:, 1]
    return out

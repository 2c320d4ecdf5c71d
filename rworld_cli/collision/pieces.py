"""The bodies' convex pieces as flat tables for the compiled distance kernels: each body's
pieces (primitives, hull parts, triangles) gathered and placed per state, the local pieces and
their hull neighbours that the walk from a previous witness uses; built once per set of bodies."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from . import convex


def _gather(bodies: list, index: np.ndarray, T: np.ndarray) -> convex.Pieces:
    """The single convex piece of ``bodies[index[q]]`` at ``T[q]``, in query order.

    Every kind in one batch, whatever the number of bodies (a line of robots): the bodies'
    pieces in their shape frames (:func:`_piece_table`, built once per body list), then one
    matrix product and one rotation of the vertices for all queries.
    """
    table = _piece_table(bodies)
    kind = table.kind[index]
    Ts = T @ table.T_frame_shape[index]
    R, c = Ts[:, :3, :3], Ts[:, :3, 3]
    # corners only where there are any (boxes, hulls): spheres and cylinders are their centre;
    # padded only to the widest piece asked for (the padding repeats a vertex: the same shape)
    cornered = np.flatnonzero((kind == 0) | (kind == 2))
    width = int(table.counts[index].max(initial=1))
    world = np.repeat(c[:, None, :], width, axis=1)
    if len(cornered):
        R_c = np.transpose(R[cornered], (0, 2, 1))
        world[cornered] += table.vertices[index[cornered], :width] @ R_c  # matmul: 7x einsum
    return _placed(table, index, kind, R, c, world)


def _placed(table, index, kind, R, c, world) -> convex.Pieces:
    """The pieces ``table[index[q]]`` placed by ``R[q]``, ``c[q]`` (their shape frames in
    world), with vertices ``world`` (Q, V, 3) (their centres alone where the caller does not
    need them)."""
    axes = np.transpose(R, (0, 2, 1)).copy()  # boxes and cylinders: their own axes as rows
    axis = R[:, :, 2].copy()
    center = c.copy()
    sphere = kind == 1
    if sphere.any():  # a sphere's directions are the world's
        axes[sphere], axis[sphere] = np.eye(3), (0.0, 0.0, 1.0)
    hull = np.flatnonzero(kind == 2)
    if len(hull):  # a hull: its principal axes, its centre the mean of its vertices
        axes[hull] = np.einsum("kij,kaj->kai", R[hull], table.axes[index[hull]])
        axis[hull] = axes[hull, 2]
        center[hull] = c[hull] + np.einsum("kij,kj->ki", R[hull], table.center[index[hull]])
    scalars = table.scalars[index]
    return convex.Pieces(
        world,
        kind == 3,
        center,
        axis,
        scalars[:, 0].copy(),
        scalars[:, 1].copy(),
        scalars[:, 2].copy(),
        axes,
        complete=(kind == 0) | (kind == 1),  # boxes and spheres (module convex: penetration)
    )


def _local_distance(bodies, I, J, TI, TJ, max_iterations) -> convex.Distances | None:
    """:func:`convex.distance` of the single pieces of ``bodies[I[q]]`` at ``TI[q]`` and
    ``bodies[J[q]]`` at ``TJ[q]`` by the compiled GJK on the pieces in their own frames
    (:func:`compiled.gjk_local`: no vertex is copied or moved, and a hull of thousands of
    vertices is climbed, not scanned); None when no compiled kernel is available."""
    from .compiled import gjk_local, shape_rows

    table = _piece_table(bodies)
    sides = []
    for index, T in ((I, TI), (J, TJ)):
        Ts = T @ table.T_frame_shape[index]
        R, c = Ts[:, :3, :3], Ts[:, :3, 3]
        pieces = _placed(table, index, table.kind[index], R, c, c[:, None, :])
        pose = np.concatenate([R.reshape(-1, 9), c], axis=1)
        sides.append((pieces, (table.vertices, table.neighbours, index, pose)))
    (pa, local_a), (pb, local_b) = sides
    rows = gjk_local(local_a, local_b, shape_rows(pa), shape_rows(pb), max_iterations)
    if rows is None:
        return None
    return convex.from_kernel(pa, pb, rows)


@dataclass(frozen=True)
class _PieceTable:
    """Every single-piece body's :class:`LocalPiece`, stacked (bodies of several pieces hold
    zeros); vertices padded to one count by repeating the first."""

    kind: np.ndarray  # (B,) int
    T_frame_shape: np.ndarray  # (B, 4, 4)
    vertices: np.ndarray  # (B, V, 3)
    scalars: np.ndarray  # (B, 3): radius, half length, margin
    axes: np.ndarray  # (B, 3, 3)
    center: np.ndarray  # (B, 3)
    counts: np.ndarray  # (B,) int: each piece's own vertex count (before the padding)
    neighbours: np.ndarray  # (B, V, D) int64: each vertex's on the hull (convex.hull_neighbours)


# the last few body sequences (the bodies kept alive, so that their ids stay theirs) and tables
_TABLES: list[tuple[tuple[int, ...], list, _PieceTable]] = []


def _piece_table(bodies: list) -> _PieceTable:
    """The stacked pieces of ``bodies``, built once per sequence of bodies (a sweep asks
    thousands of times with the same one)."""
    key = tuple(map(id, bodies))
    for known, _, table in _TABLES:
        if known == key:
            return table
    table = _build_piece_table(bodies)
    _TABLES.insert(0, (key, list(bodies), table))
    del _TABLES[4:]  # a few models at a time: bodies stay alive only while they are recent
    return table


def _build_piece_table(bodies: list) -> _PieceTable:
    """The stacked pieces of ``bodies`` (:class:`_PieceTable`), built."""
    local = [
        b.local_piece if b.single_piece else LocalPiece(-1, np.eye(4), np.zeros((1, 3)))
        for b in bodies
    ]
    count = max((len(lp.vertices) for lp in local), default=1)
    return _PieceTable(
        np.array([lp.kind for lp in local], dtype=int),
        np.stack([lp.T_frame_shape for lp in local]) if local else np.zeros((0, 4, 4)),
        np.stack(
            [
                np.concatenate(
                    [lp.vertices, np.repeat(lp.vertices[:1], count - len(lp.vertices), 0)]
                )
                for lp in local
            ]
        )
        if local
        else np.zeros((0, 1, 3)),
        np.array([(lp.radius, lp.half_length, lp.margin) for lp in local], dtype=float).reshape(
            -1, 3
        ),
        np.stack([lp.axes for lp in local]) if local else np.zeros((0, 3, 3)),
        np.stack([lp.center for lp in local]) if local else np.zeros((0, 3)),
        np.array([len(lp.vertices) for lp in local], dtype=int),
        _neighbour_table(local, count),
    )


_NEIGHBOURS: dict[str, np.ndarray] = {}  # this process's hull neighbours, by their key


def _hull_neighbours(vertices: np.ndarray) -> np.ndarray:
    """:func:`convex.hull_neighbours` (V, D), kept in the user's cache (kind ``meshes``) by the
    vertices, and in this process once read (every piece table holding the hull pads the same
    rows): a vendor link's hull costs tens of milliseconds, and the first hull of a process
    the import of scipy's Qhull (about 0.3 s)."""
    import hashlib

    from .. import cache

    vertices = np.ascontiguousarray(vertices, dtype=float)
    key = hashlib.sha256(f"neighbours-2|{vertices.shape}|".encode() + vertices.tobytes())
    name = f"neighbours-{key.hexdigest()[:40]}.npz"
    known = _NEIGHBOURS.get(name)
    if known is None:
        known = cache.arrays(
            "meshes",
            name,
            ("neighbours",),
            lambda: {"neighbours": convex.hull_neighbours(vertices)},
        )["neighbours"]
        if len(_NEIGHBOURS) >= 256:  # a long process meets many cells: the oldest goes
            del _NEIGHBOURS[next(iter(_NEIGHBOURS))]
        _NEIGHBOURS[name] = known
    return known


def _neighbour_table(local: list, count: int) -> np.ndarray:
    """The hull neighbours of every piece's vertices (:func:`convex.hull_neighbours`), in one
    table (B, count, D) padded with -1 (rows past a piece's vertices: the copies of its first
    vertex that pad the vertex table, never climbed to): boxes and hulls; spheres and
    cylinders have none."""
    rows = [
        convex.box_neighbours()
        if lp.kind == 0
        else _hull_neighbours(lp.vertices)
        if lp.kind == 2
        else None
        for lp in local
    ]
    width = max((r.shape[1] for r in rows if r is not None), default=1)
    out = np.full((len(local), count, width), -1, dtype=np.int64)
    for j, r in enumerate(rows):
        if r is not None:
            out[j, : len(r), : r.shape[1]] = r
    return out


@dataclass(frozen=True)
class LocalPiece:
    """A body's single convex piece in its shape frame: what :func:`_gather` places.

    ``kind``: 0 box, 1 sphere, 2 hull (vertices in the body's frame, ``T_frame_shape`` the
    identity), 3 cylinder.  ``vertices`` (V, 3) [m]: a box's corners; the centre (zeros) for
    spheres and cylinders.  ``axes`` (3, 3) and ``center`` (3,): a hull's principal axes as
    rows and the mean of its vertices.
    """

    kind: int
    T_frame_shape: np.ndarray
    vertices: np.ndarray
    radius: float = 0.0
    half_length: float = 0.0
    margin: float = 0.0
    axes: np.ndarray = dataclasses.field(default_factory=lambda: np.eye(3))
    center: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(3))

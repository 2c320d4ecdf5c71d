"""The collision model of a cell: every body with geometry, its convex pieces and bounds.

A **body** is one shape on one frame: an object, a device's base, or a
device's link (hands, tools and aggregated devices are devices or objects, so
they are covered).  Sensors are sensing volumes, not solids, and are left
out.  Primitives (box, cylinder, sphere) are one convex piece each.  A closed
mesh whose connected parts are each convex (robots' collision meshes usually
are: hulls of the links, joined per link by ``rworld import urdf``) is exactly
the union of those parts' hulls: one convex piece per part, solid by
construction.  Any other mesh is its triangles, and it is a **solid** too:
:func:`pair_distance` also asks, by generalised winding number, whether the
other body lies inside it, so a link buried in an object is a collision
rather than a miss (surface-only libraries such as FCL report no contact
there).

Level two of the report's geometry - a bounding volume per shape - is a
bounding sphere here (centre and radius in the body's frame): it gives the
broad phase a lower bound on every pair's distance for one subtraction.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ..geometry import MeshData, shape_mesh, winding_number
from ..model.cell import CellModel, Shape
from . import bvh, convex
from .parts import (  # noqa: F401 - re-exported: the bodies' convex parts
    HULL_DEVIATION,
    PARTS_FORMAT,
    _code,
    _convex_parts,
    _hull_parts,
    _parts_arrays,
    _planes,
    _segment_distance,
    _uncovered,
    convex_parts,
    hull_deviation,
    point_triangle_distance,
)
from .pieces import (  # noqa: F401 - re-exported: the pieces' tables
    _TABLES,
    LocalPiece,
    _build_piece_table,
    _gather,
    _hull_neighbours,
    _local_distance,
    _neighbour_table,
    _piece_table,
    _PieceTable,
    _placed,
)


@dataclass(frozen=True)
class Body:
    """A shape on a frame.

    Attributes
    ----------
    label : str
        What messages call it: the object's or device's name (a base), or ``device.link``.
    owner : str
        The primitive (object or device) it belongs to.
    frame : str
        The frame the shape is given in (object or device natural frame, or link frame).
    shape : Shape
    center : ndarray, shape (3,)
        Bounding sphere centre in ``frame`` [m].
    radius : float
        Bounding sphere radius [m].
    """

    label: str
    owner: str
    frame: str
    shape: Shape
    center: np.ndarray
    radius: float
    parts: tuple[tuple[np.ndarray, np.ndarray], ...] | None = None  # convex parts of a mesh

    @property
    def is_mesh(self) -> bool:
        """A mesh checked triangle by triangle (not one made of convex parts)."""
        return self.shape.kind == "mesh" and self.parts is None

    @functools.cached_property
    def _hulls(self) -> tuple[np.ndarray, np.ndarray]:
        """The convex parts' hull vertices padded to one count (C, V, 3), and their axes
        (C, 3, 3): built once per body, used at every pose."""
        assert self.parts is not None
        count = max(len(v) for v, _ in self.parts)
        local = np.stack(
            [np.concatenate([v, np.repeat(v[:1], count - len(v), 0)]) for v, _ in self.parts]
        )
        return local, np.stack([a for _, a in self.parts])

    @functools.cached_property
    def _own_table(self) -> _PieceTable:
        """This body's single piece as a one-row piece table (its hull's neighbours too)."""
        return _build_piece_table([self])

    @property
    def single_piece(self) -> bool:
        """One convex piece: a primitive, or a mesh of one convex part."""
        return self.shape.kind != "mesh" or (self.parts is not None and len(self.parts) == 1)

    def mesh(self) -> MeshData:
        """The polyhedral model in the body's frame."""
        return shape_mesh(self.shape)

    @functools.cached_property
    def _triangles(self) -> np.ndarray:
        """A triangle mesh's triangles in its body's frame (T, 3, 3) [m], built once per body."""
        return self.mesh().triangles()

    @functools.cached_property
    def local_piece(self) -> LocalPiece:
        """The single convex piece in its shape frame (:func:`_gather`); a body of one piece."""
        assert self.single_piece
        shape = self.shape
        if self.parts is not None:
            local, axes = self._hulls
            return LocalPiece(2, np.eye(4), local[0], axes=axes[0], center=local[0].mean(axis=0))
        size = np.asarray(shape.size, dtype=float)
        T = np.asarray(shape.T_owner_shape, dtype=float)
        if shape.kind == "box":
            return LocalPiece(0, T, convex.box_corners(size / 2))
        if shape.kind == "sphere":
            return LocalPiece(1, T, np.zeros((1, 3)), margin=size[0] / 2)
        return LocalPiece(3, T, np.zeros((1, 3)), radius=size[0] / 2, half_length=size[2] / 2)

    @functools.cached_property
    def _triangle_box(self) -> tuple[np.ndarray, np.ndarray]:
        """The least and greatest corner (3,) of the mesh's triangles in the body's frame [m]."""
        return self._triangles.min(axis=(0, 1)), self._triangles.max(axis=(0, 1))

    @functools.cached_property
    def tree(self) -> bvh.Tree:
        """The box tree over the body's leaves (:mod:`bvh`): its triangles (a mesh checked by
        its triangles), its convex parts' hulls, or its one piece; built once per body."""
        if self.is_mesh:
            return bvh.build(self._triangles)
        if self.parts is not None:
            return bvh.build(self._hulls[0])
        box = self.shape.bounding_box
        corners = convex.box_corners(box.half_extents) @ box.T_owner_box[:3, :3].T
        return bvh.build((corners + box.T_owner_box[:3, 3])[None])

    @functools.cached_property
    def leaf_table(self) -> tuple | None:
        """The leaves of :attr:`tree` as polytopes in a table, for the compiled walk that
        measures them (:func:`compiled_bvh.contacts`): (vertices (R, V, 3), neighbours (R, V,
        D) or None: scanned, pose (12,) of the table's frame in the body's: R's rows then t,
        the estimate's axes (R, 3, 3) and centres (R, 3) or None); leaf ``item`` is row
        ``item``.  The axes and centres are those :func:`convex.candidate_depth` takes from the
        pieces (a triangle's edges as :func:`convex.triangles` makes them, a box's axes: the
        candidates that make their depths exact); hulls have none (their principal axes would
        bound a depth only from above), and their overlaps go to the exact query.  A cylinder
        is one row of one "vertex", ``(radius, half length, 0)``, its axis the pose's z, and
        ``"cylinder"`` in place of the estimate (the walk measures it by GJK's cylinder
        support).  None for a sphere."""
        identity = np.r_[np.eye(3).ravel(), np.zeros(3)]
        if self.is_mesh:
            pieces = convex.triangles(self._triangles)
            return self._triangles, None, identity, (pieces.axes, pieces.center)
        if self.parts is not None and not self.single_piece:
            return self._hulls[0], None, identity, None
        table = self._own_table
        if table.kind[0] not in (0, 2, 3):
            return None
        T = table.T_frame_shape[0]
        pose = np.r_[T[:3, :3].ravel(), T[:3, 3]]
        if table.kind[0] == 3:
            size = np.asarray(self.shape.size, dtype=float)
            return np.array([[[size[0] / 2, size[2] / 2, 0.0]]]), None, pose, "cylinder"
        # a box: its own axes and centre in its shape frame (exact depths); a hull's principal
        # axes would bound its depth only from above: the exact query measures it
        estimate = (np.eye(3)[None], np.zeros((1, 3))) if table.kind[0] == 0 else None
        return table.vertices, table.neighbours, pose, estimate

    @functools.cached_property
    def first_point(self) -> np.ndarray:
        """A point of the body in its frame (3,) [m]: its first leaf's first vertex (the
        buried test's witness, :func:`buried_in`)."""
        return self.leaf_pieces(np.zeros(1, dtype=int), np.eye(4)[None]).points[0, 0].copy()

    @functools.cached_property
    def walk_side(self) -> tuple | None:
        """:attr:`tree` and :attr:`leaf_table` prepared for :func:`compiled_bvh.contacts`
        (held here: the kernel reads their addresses), or None (a sphere)."""
        from .compiled_bvh import walk_side

        leaves = self.leaf_table
        return None if leaves is None else walk_side(self.tree, leaves)

    def leaf_pieces(self, leaf: np.ndarray, T_world_frame: np.ndarray) -> convex.Pieces:
        """Leaves ``leaf[q]`` of :attr:`tree` at poses ``T_world_frame[q]`` (Q, 4, 4), as Q
        convex pieces in world."""
        T = np.asarray(T_world_frame, dtype=float).reshape(-1, 4, 4)
        Rt, t = np.transpose(T[:, :3, :3], (0, 2, 1)), T[:, :3, 3]  # points as rows: x R^T
        if self.is_mesh:
            return convex.triangles(self._triangles[leaf] @ Rt + t[:, None])
        if self.parts is not None and not self.single_piece:
            local, axes = self._hulls
            width = int(self._hull_counts[leaf].max(initial=1))
            faces = (self._faces_table, leaf, T[:, :3, :3], t, self._edges_table)
            return convex.hulls(local[leaf, :width] @ Rt + t[:, None], axes[leaf] @ Rt, faces)
        return self.pieces(T)

    def _faces_table(self) -> np.ndarray:
        """Each convex part's hull faces in the body's frame, padded with zero rows to one
        count (C, F, 4) (:func:`convex.hull_faces`): the depth's candidates.  Computed when a
        depth first needs them (qhull, and scipy's import: 0.3 s a command otherwise)."""
        return self._hull_tables[0]

    def _edges_table(self) -> np.ndarray:
        """Each convex part's hull edges in the body's frame, padded with zero rows to one
        count (C, E, 12) (:func:`convex.hull_edges`): with the faces, a box's or a
        triangle's depth against the part is exact.  Computed with the faces."""
        return self._hull_tables[1]

    @functools.cached_property
    def _hull_tables(self) -> tuple[np.ndarray, np.ndarray]:
        """(faces, edges) of every convex part, one qhull a part (:func:`convex.hull_tables`)."""
        assert self.parts is not None
        tables = [convex.hull_tables(v) for v, _ in self.parts]
        return _padded([f for f, _ in tables], 4), _padded([e for _, e in tables], 12)

    @functools.cached_property
    def _hull_counts(self) -> np.ndarray:
        """Each convex part's own vertex count, before :attr:`_hulls` pads them (C,)."""
        assert self.parts is not None
        return np.array([len(v) for v, _ in self.parts])

    def pieces(self, T_world_frame: np.ndarray) -> convex.Pieces:
        """The body's convex pieces in world for K poses (K, 4, 4).

        Primitives give K pieces; a mesh of F triangles gives K * F, state-major.
        """
        T = np.asarray(T_world_frame, dtype=float).reshape(-1, 4, 4)
        shape = self.shape
        if self.single_piece and self.parts is not None and len(self.parts[0][0]) > LOCAL_VERTICES:
            # a large hull: left in its own frame, placed per state (convex.Pieces.local)
            table = self._own_table
            index = np.zeros(len(T), dtype=int)
            Ts = T @ table.T_frame_shape[0]
            R, c = Ts[:, :3, :3], Ts[:, :3, 3]
            pieces = _placed(table, index, table.kind[index], R, c, c[:, None, :])
            pose = np.concatenate([R.reshape(-1, 9), c], axis=1)
            pieces.local = (table.vertices, table.neighbours, index, pose)
            pieces.faces = (
                self._faces_table,
                index,
                T[:, :3, :3],
                T[:, :3, 3],
                self._edges_table,
            )
            return pieces
        if self.parts is not None:  # K * C hulls, state-major
            local, axes = self._hulls
            count = local.shape[1]
            world = np.einsum("kij,cvj->kcvi", T[:, :3, :3], local) + T[:, None, None, :3, 3]
            world_axes = np.einsum("kij,caj->kcai", T[:, :3, :3], axes)
            C = len(local)
            faces = (
                self._faces_table,
                np.tile(np.arange(C), len(T)),
                np.repeat(T[:, :3, :3], C, axis=0),
                np.repeat(T[:, :3, 3], C, axis=0),
                self._edges_table,
            )
            return convex.hulls(world.reshape(-1, count, 3), world_axes.reshape(-1, 3, 3), faces)
        if shape.kind == "mesh":
            tri = self.mesh().triangles()
            world = np.einsum("kij,ftj->kfti", T[:, :3, :3], tri) + T[:, None, None, :3, 3]
            return convex.triangles(world.reshape(-1, 3, 3))
        Ts = T @ shape.T_owner_shape
        size = np.asarray(shape.size, dtype=float)
        if shape.kind == "box":
            return convex.boxes(Ts, size / 2)
        if shape.kind == "sphere":
            return convex.spheres(Ts[:, :3, 3], np.full(len(T), size[0] / 2))
        return convex.cylinders(Ts, np.full(len(T), size[0] / 2), np.full(len(T), size[2] / 2))


@dataclass
class CollisionModel:
    """The bodies of a cell, and what has no geometry (listed, never silently skipped).

    Attributes
    ----------
    bodies : list of Body
    unchecked : list of str
        Objects, device bases and links with no geometry.
    open_meshes : list of str
        Mesh bodies that are not closed solids (checked as surfaces only).
    """

    bodies: list[Body]
    unchecked: list[str]
    open_meshes: list[str]

    def index(self) -> dict[str, int]:
        return {b.label: i for i, b in enumerate(self.bodies)}


def collision_model(cell: CellModel) -> CollisionModel:
    """Every body of the cell with its bounds; see the module docstring."""
    bodies: list[Body] = []
    unchecked: list[str] = []
    open_meshes: list[str] = []

    def add(label: str, owner: str, frame: str, shape: Shape | None) -> None:
        if shape is None:
            unchecked.append(label)
            return
        bodies.append(make_body(label, owner, frame, shape))
        if shape.kind == "mesh" and not shape.closed:
            open_meshes.append(label)

    for name, obj in cell.objects.items():
        add(name, name, name, obj.shape)
    for name, dev in cell.devices.items():
        add(name, name, name, dev.shape)
        for link, frame in zip(dev.links, dev.link_frames):
            add(frame, name, frame, link.shape)
    return CollisionModel(bodies, unchecked, open_meshes)


def make_body(label: str, owner: str, frame: str, shape: Shape) -> Body:
    """A :class:`Body` with its bounding sphere, and its convex parts when a mesh has them."""
    center, radius = _bounding_sphere(shape)
    parts = convex_parts(shape) if shape.kind == "mesh" else None
    return Body(label, owner, frame, shape, center, radius, parts)


def ball_body(label: str, radius: float) -> Body:
    """A sphere of ``radius`` [m] centred on its frame's origin (a probe's ball tip)."""
    from ..model.cell import Box

    shape = Shape("sphere", np.eye(4), np.full(3, 2 * radius), Box(np.eye(4), np.full(3, radius)))
    return make_body(label, label, label, shape)


# a single hull with more vertices than this is placed per state by its pose, not copied
# (convex.Pieces.local): GJK climbs it in its own frame
LOCAL_VERTICES = 32
BLOCK = 16384  # primitive queries per batched GJK call: bounds the memory of a large batch
# query-vertices per batched call: a block of pairs with 3000-vertex hulls (a vendor's link
# meshes) gets fewer queries, so each (Q, V, 3) array stays near 100 MB
VERTEX_BUDGET = 4_000_000


def _bounding_sphere(shape: Shape) -> tuple[np.ndarray, float]:
    box = shape.bounding_box
    return box.T_owner_box[:3, 3].copy(), float(np.linalg.norm(box.half_extents))


@dataclass
class PairDistance:
    """Distances of one body pair at K states (see :func:`pair_distance`).

    Attributes
    ----------
    distance : ndarray, shape (K,)
        Separation [m]; 0 when the solids touch or overlap.
    depth : ndarray, shape (K,)
        Penetration depth where they overlap [m] (0 elsewhere): exact, but where the query
        asked less (``deep_enough``, ``exact_above`` of :func:`pair_distance`).
    point_a, point_b : ndarray, shape (K, 3)
        Closest points (or the deepest contact points) in world [m].
    buried : ndarray of bool, shape (K,)
        One body lies wholly inside the other's closed mesh.
    """

    distance: np.ndarray
    depth: np.ndarray
    point_a: np.ndarray
    point_b: np.ndarray
    buried: np.ndarray

    @property
    def overlap(self) -> np.ndarray:
        return (self.distance <= 0.0) | self.buried


def pair_distance(
    a: Body,
    b: Body,
    Ta: np.ndarray,
    Tb: np.ndarray,
    max_iterations: int = convex.MAX_ITERATIONS,
    within: float | np.ndarray = np.inf,
    deep_enough: float = np.inf,
    exact_above: float = 0.0,
) -> PairDistance:
    """Exact distance between bodies ``a`` and ``b`` at K states.

    Parameters
    ----------
    a, b : Body
    Ta, Tb : ndarray, shape (K, 4, 4)
        ``T_world_frame`` of each body's frame.
    within : float or ndarray, shape (K,)
        Exact only where the distance is at most this [m] (for all states, or each); elsewhere
        it may be reported as inf, or as any distance above ``within`` (farther than it).  A
        collision test passes 0: bodies with several leaves then only look at their leaves
        whose boxes touch.
    deep_enough : float
        Exact depths only up to this [m]: a state with an overlapping leaf pair deeper is
        reported with that pair's depth, its other overlapping pairs not measured (a
        collision test needs to know the depth is over the tolerance, not by how much).
    exact_above : float
        Depths are exact above this [m]; below it they may be an upper bound below it (a
        touch within the collision tolerance is one whatever its depth: the pieces whose
        depth takes the expanding polytope, hulls and cylinders, are not measured further
        there).  0: every depth exact.

    Returns
    -------
    PairDistance
    """
    Ta = np.asarray(Ta, dtype=float).reshape(-1, 4, 4)
    Tb = np.asarray(Tb, dtype=float).reshape(-1, 4, 4)
    K = len(Ta)
    if a.single_piece and b.single_piece:
        pa, pb = a.pieces(Ta), b.pieces(Tb)
        res = convex.distance(pa, pb, max_iterations)
        dist, pta, ptb, over = res.distance, res.point_a, res.point_b, res.overlap
        depth = np.zeros(K)
        if over.any():
            rows = np.flatnonzero(over)
            d, n = convex.penetration(
                pa.take(rows), pb.take(rows), deep_enough, exact_above=exact_above
            )
            depth[rows] = np.maximum(d, 0.0)
        return PairDistance(dist, depth, pta, ptb, np.zeros(K, dtype=bool))
    walked = _walked(a, b, Ta, Tb, max_iterations, within, deep_enough, exact_above)
    if walked is not None:
        return walked
    return _searched(a, b, Ta, Tb, max_iterations, within, deep_enough, exact_above)


def _walked(
    a, b, Ta, Tb, max_iterations, within, deep_enough, exact_above=0.0
) -> PairDistance | None:
    """:func:`pair_distance` by the compiled walk of both trees (:func:`compiled_bvh.
    contacts`: branch and bound, each leaf pair measured by GJK where it is met): the states
    where no leaf pair overlaps take its nearest distance and closest points, those whose
    overlaps are none deeper than asked and all carry the depth estimate take the deepest's;
    the others (their depths to measure) go to :func:`_searched`.  None: no kernel, or a sphere or a
    cylinder (not polytopes)."""
    if a.walk_side is None or b.walk_side is None:
        return None
    from .compiled_bvh import contacts

    K = len(Ta)
    limit = np.broadcast_to(np.asarray(within, dtype=float), (K,))
    R, t = bvh._relative(Ta, Tb)
    found = contacts(a.walk_side, b.walk_side, R, t, limit + 2e-9, deep_enough, max_iterations)
    if found is None:
        return None
    status, nearest, witness = found
    out = PairDistance(
        np.full(K, np.inf), np.zeros(K), np.zeros((K, 3)), np.zeros((K, 3)), np.zeros(K, bool)
    )
    clear = np.flatnonzero(status == 0)
    measured = clear[np.isfinite(nearest[clear])]
    out.distance[measured] = nearest[measured]
    # overlaps none deeper than asked, each with the estimate the search would take: the
    # deepest one's depth and points (distance 0)
    shallow = np.flatnonzero((status == 2) & np.isfinite(witness[:, 8]))
    out.distance[shallow] = 0.0
    out.depth[shallow] = np.maximum(witness[shallow, 8], 0.0)
    placed = np.r_[measured, shallow]
    Rw, tw = Ta[placed, :3, :3], Ta[placed, :3, 3]  # a's frame, where GJK ran, in world
    out.point_a[placed] = np.einsum("kij,kj->ki", Rw, witness[placed, 0:3]) + tw
    out.point_b[placed] = np.einsum("kij,kj->ki", Rw, witness[placed, 3:6]) + tw
    rows = clear[buried_in(a, b, Ta[clear], Tb[clear])]
    out.buried[rows] = True
    out.depth[rows] = out.distance[rows]  # at least as deep as its distance to the surface
    out.distance[rows] = 0.0
    # deeper overlaps, or shallow ones without an estimate: their depths measured by the search
    rest = np.flatnonzero((status != 0) & ~((status == 2) & np.isfinite(witness[:, 8])))
    if len(rest):
        found_rest = _searched(
            a, b, Ta[rest], Tb[rest], max_iterations, limit[rest], deep_enough, exact_above
        )
        for name in ("distance", "depth", "point_a", "point_b", "buried"):
            getattr(out, name)[rest] = getattr(found_rest, name)
    return out


def _searched(a, b, Ta, Tb, max_iterations, within, deep_enough, exact_above=0.0) -> PairDistance:
    """:func:`pair_distance` of two bodies of several leaves (or one of them) by the trees'
    breadth-first search (:func:`bvh.candidates`) and their leaf pairs measured in batches."""
    K = len(Ta)
    # several leaves on either side (triangles, convex parts): the leaf pairs that may hold
    # each state's nearest pair, found by the bodies' trees (bvh), then measured; a single
    # piece is placed once per state and shared by its pairs
    placed_a = a.pieces(Ta) if a.single_piece else None
    placed_b = b.pieces(Tb) if b.single_piece else None

    def leaves(body, T, placed, k, leaf):
        return placed.share(k) if placed is not None else body.leaf_pieces(leaf, T[k])

    def measure(k, la, lb):
        return convex.distance(
            leaves(a, Ta, placed_a, k, la), leaves(b, Tb, placed_b, k, lb), max_iterations
        ).distance

    k, la, lb = bvh.candidates(a.tree, b.tree, Ta, Tb, measure, np.asarray(within) + 1e-9)
    return _closest(
        a,
        b,
        Ta,
        Tb,
        K,
        k,
        leaves(a, Ta, placed_a, k, la),
        leaves(b, Tb, placed_b, k, lb),
        max_iterations,
        deep_enough,
        exact_above,
    )


def _closest(
    a, b, Ta, Tb, K, k, pa, pb, max_iterations, deep_enough=np.inf, exact_above=0.0
) -> PairDistance:
    """Each state's closest pair among the piece pairs ``pa[q]``, ``pb[q]`` of state ``k[q]``,
    its depth where they overlap, and whether one body is buried in the other's closed mesh.
    ``deep_enough``: a state's overlapping pairs are measured a few at a time (GJK's simplex
    bound first), and a state with one deeper than this is done."""
    res = convex.distance(pa, pb, max_iterations)
    dist = np.full(K, np.inf)
    np.minimum.at(dist, k, res.distance)
    best = np.flatnonzero(res.distance <= dist[k])
    pta, ptb = np.zeros((K, 3)), np.zeros((K, 3))
    pta[k[best]], ptb[k[best]] = res.point_a[best], res.point_b[best]
    depth = np.zeros(K)
    overlapping = np.flatnonzero(res.overlap)
    if np.isfinite(deep_enough) and res.depth_bound is not None:
        # deeper than asked by GJK's own simplex: that state's depth is settled
        deep = overlapping[res.depth_bound[overlapping] > deep_enough]
        np.maximum.at(depth, k[deep], res.depth_bound[deep])
    # the deepest overlapping piece pair of each state: all at once when depths are to be
    # exact, else the first of each state, then the next two, four, ... of the states not
    # yet deeper than deep_enough
    rank = convex.rank_in_group(k[overlapping])
    last = int(rank.max(initial=-1))
    low, high = 0, (last + 1 if not np.isfinite(deep_enough) else 1)
    while low <= last:
        take = (rank >= low) & (rank < high) & (depth[k[overlapping]] <= deep_enough)
        rows = overlapping[take]
        if len(rows):
            d, _ = convex.penetration(
                pa.take(rows), pb.take(rows), deep_enough, k[rows], exact_above
            )
            np.maximum.at(depth, k[rows], np.maximum(d, 0.0))
        low, high = high, 2 * high + 1
    buried = np.zeros(K, dtype=bool)
    free = np.flatnonzero(dist > 0)
    rows = free[buried_in(a, b, Ta[free], Tb[free])]
    buried[rows] = True
    depth[rows] = dist[rows]  # at least as deep as its distance to the surface
    return PairDistance(np.where(buried, 0.0, dist), depth, pta, ptb, buried)


def buried_in(a: Body, b: Body, Ta: np.ndarray, Tb: np.ndarray) -> np.ndarray:
    """Whether one body lies inside the other's closed mesh at each of K states where their
    surfaces do not meet (the caller knows they do not): a solid inside a closed mesh touches
    no triangle, yet collides.  One point of the inner body (:attr:`Body.first_point`) decides,
    by the mesh's winding number (K,) bool."""
    buried = np.zeros(len(Ta), dtype=bool)
    for mesh_body, other, T_mesh, T_other in ((a, b, Ta, Tb), (b, a, Tb, Ta)):
        if not mesh_body.is_mesh or not mesh_body.shape.closed or not len(Ta):
            continue
        point = T_other[:, :3, :3] @ other.first_point + T_other[:, :3, 3]
        local = np.einsum(
            "kji,kj->ki", T_mesh[:, :3, :3], point - T_mesh[:, :3, 3]
        )  # in the mesh's frame
        # only a point within the mesh's box can be inside it: the winding number elsewhere
        # is 0, and a free link is rarely in a fixture's box
        lo, hi = mesh_body._triangle_box
        boxed = np.flatnonzero(np.all((local >= lo) & (local <= hi), axis=1))
        buried[boxed[winding_number(local[boxed], mesh_body._triangles) > 0.5]] = True
    return buried


def distances(
    bodies: list[Body],
    I: np.ndarray,
    J: np.ndarray,
    TI: np.ndarray,
    TJ: np.ndarray,
    max_iterations: int = convex.MAX_ITERATIONS,
    within: float | np.ndarray = np.inf,
    deep_enough: float = np.inf,
    exact_above: float = 0.0,
) -> PairDistance:
    """Exact distances of Q queries: body ``I[q]`` at ``TI[q]`` against ``J[q]`` at ``TJ[q]``.

    Pairs of primitives go through one batched GJK call; pairs with a mesh through
    :func:`pair_distance`, pair by pair.

    Parameters
    ----------
    bodies : list of Body
    I, J : ndarray of int, shape (Q,)
    TI, TJ : ndarray, shape (Q, 4, 4)
        ``T_world_frame`` of each query's bodies.
    max_iterations : int
        GJK's limit; a pair short of it reports a lower bound (see :func:`convex.distance`).
    within : float or ndarray, shape (Q,)
        Distances above this [m] (for all queries, or each) may be reported as inf
        (:func:`pair_distance`).
    deep_enough : float
        Depths above this [m] may be reported as any depth above it (:func:`pair_distance`).
    exact_above : float
        Depths below this [m] may be reported as an upper bound below it (:func:`pair_distance`).
    """
    I, J = np.asarray(I, dtype=int), np.asarray(J, dtype=int)
    Q = len(I)
    out = PairDistance(
        np.zeros(Q), np.zeros(Q), np.zeros((Q, 3)), np.zeros((Q, 3)), np.zeros(Q, dtype=bool)
    )
    if not Q:
        return out
    single = np.array([b.single_piece for b in bodies])
    primitive = single[I] & single[J]
    everything = np.flatnonzero(primitive)
    # widest pairs first, so that a block's pieces are padded to similar vertex counts and a
    # block of large hulls holds fewer queries: memory bounded, whatever Q and the meshes
    counts = _piece_table(bodies).counts
    width = np.maximum(counts[I], counts[J])
    everything = everything[np.argsort(-width[everything], kind="stable")]
    start = 0
    while start < len(everything):
        size = int(np.clip(VERTEX_BUDGET // max(int(width[everything[start]]), 1), 64, BLOCK))
        rows = everything[start : start + size]
        start += size
        res = _local_distance(bodies, I[rows], J[rows], TI[rows], TJ[rows], max_iterations)
        if res is None:  # no compiled kernel: the pieces placed in world, the numpy GJK
            pa = _gather(bodies, I[rows], TI[rows])
            pb = _gather(bodies, J[rows], TJ[rows])
            res = convex.distance(pa, pb, max_iterations)
        out.distance[rows] = res.distance
        out.point_a[rows], out.point_b[rows] = res.point_a, res.point_b
        if res.overlap.any():
            overlapping = np.flatnonzero(res.overlap)
            if np.isfinite(deep_enough) and res.depth_bound is not None:
                # deeper than asked by GJK's own simplex: no depth to measure
                deep = res.depth_bound[overlapping] > deep_enough
                out.depth[rows[overlapping[deep]]] = res.depth_bound[overlapping[deep]]
                overlapping = overlapping[~deep]
            over = rows[overlapping]
            if len(over):
                pa = _gather(bodies, I[over], TI[over])
                pb = _gather(bodies, J[over], TJ[over])
                d, _ = convex.penetration(pa, pb, deep_enough, exact_above=exact_above)
                out.depth[over] = np.maximum(d, 0.0)
    limit = np.broadcast_to(np.asarray(within, dtype=float), (Q,))
    for i, j in {(int(a), int(b)) for a, b in zip(I[~primitive], J[~primitive])}:
        sel = np.flatnonzero((I == i) & (J == j))
        res1 = pair_distance(
            bodies[i],
            bodies[j],
            TI[sel],
            TJ[sel],
            max_iterations,
            limit[sel],
            deep_enough,
            exact_above,
        )
        out.distance[sel], out.depth[sel], out.buried[sel] = res1.distance, res1.depth, res1.buried
        out.point_a[sel], out.point_b[sel] = res1.point_a, res1.point_b
    return out


def _padded(rows: list[np.ndarray], columns: int) -> np.ndarray:
    """Tables of different lengths (each (n_k, columns)) as one (K, max n_k, columns), padded
    with rows of zeros (at least one row)."""
    out = np.zeros((len(rows), max(1, max((len(r) for r in rows), default=0)), columns))
    for k, r in enumerate(rows):
        out[k, : len(r)] = r
    return out

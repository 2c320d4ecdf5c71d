"""Probe targets on material: where a ball-tip probe can touch each feature.

For every feature the owner's polyhedral model (its mesh, or the primitive's)
gives **candidates**: contact points on the actual face, each with the
outward surface normal and the ball centre at contact, keeping ``margin``
(at least the ball radius) from every edge and hole of the face.

* **plane** - the mesh triangles lying in the feature's plane (normal within
  1e-6, distance within 1 um) form the face; a grid over it keeps points
  inside a triangle and ``margin`` from the face's boundary edges (its outline
  and its holes' rims).  The ball centre is the point plus ``radius`` along
  the normal (compensated by ``probe_radius``).
* **line** - a convex edge: the mesh edges lying on the line give its
  extent (points ``margin`` from its ends); the ball comes in along the
  bisector of the two faces' normals, so it first touches the edge itself
  and its centre lies ``radius`` from the line (the measurement's ``offset``
  is that displacement, owner frame).
* **circle** - a hole (material outside the circle below its rim) or a boss
  (inside).  The wall is probed at ``depth`` below the rim, the ball centre at
  ``R - radius`` (hole) or ``R + radius`` (boss) from the axis; a wall gives
  the distance from the axis only.  The wall must exist there (winding
  number of the solid).
* **point** - the point itself, approached along the normal of the face it
  lies on.

All in the owner's frame, SI.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import UserError
from ..geometry import MeshData, shape_mesh, winding_number
from ..model.cell import CellModel, Feature

PLANE_TOLERANCE = 1e-6  # [m]: a triangle within this of the feature's plane is on the face
WALL_CLEARANCE = 5e-4  # [m]: the ball keeps this from a hole's rim and bottom, and the axis
CANDIDATES = 400  # about this many candidate points per face
ANGLES = 72  # candidate angles round a circle


@dataclass
class Candidates:
    """Where a ball of the probe's radius can touch one feature (owner frame, SI).

    Attributes
    ----------
    feature : Feature
    points : ndarray, shape (M, 3)
        Contact points on the surface.
    normals : ndarray, shape (M, 3)
        Unit outward surface normals there: the ball comes in along ``-normals``.
    centres : ndarray, shape (M, 3)
        Ball centres at contact (``points + radius * normals``).
    offset : ndarray, shape (3,) or None
        The ball centres' displacement from the feature beyond ``probe_radius``
        compensation (lines, circles), as the measurement file's ``offset``.
    boss : bool
        Circles: probed from outside.
    depth : float or None
        Circles: the probing depth below the rim [m].
    wall_depth : float or None
        Circles: how far the wall goes below the rim [m].
    """

    feature: Feature
    points: np.ndarray
    normals: np.ndarray
    centres: np.ndarray
    offset: np.ndarray | None = None
    boss: bool = False
    depth: float | None = None
    wall_depth: float | None = None

    def __len__(self) -> int:
        return len(self.points)


def _basis(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    u = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    return u, np.cross(n, u)


def _owner_mesh(cell: CellModel, feature: Feature) -> MeshData:
    owner = cell.objects.get(feature.owner) or cell.devices.get(feature.owner)
    shape = getattr(owner, "shape", None)
    if shape is None:
        raise UserError(
            f"feature '{feature.name}': its owner '{feature.owner}' has no geometry, so there is "
            "no material to probe (give it a geometry)"
        )
    return shape_mesh(shape)


@dataclass
class _Face:
    """A planar face of a mesh: its triangles and boundary edges in 2D plane coordinates."""

    origin: np.ndarray
    u: np.ndarray
    v: np.ndarray
    triangles: np.ndarray  # (F, 3, 2)
    boundary: np.ndarray  # (B, 2, 2)

    def to_2d(self, p: np.ndarray) -> np.ndarray:
        d = np.atleast_2d(p) - self.origin
        return np.stack([d @ self.u, d @ self.v], axis=-1)

    def to_3d(self, xy: np.ndarray) -> np.ndarray:
        return self.origin + xy[:, :1] * self.u + xy[:, 1:] * self.v

    def inside(self, xy: np.ndarray) -> np.ndarray:
        """Points (P, 2) on one of the face's triangles."""
        a, b, c = (self.triangles[None, :, k] for k in range(3))
        p = xy[:, None]

        def cross(o, s, t):
            return (s[..., 0] - o[..., 0]) * (t[..., 1] - o[..., 1]) - (s[..., 1] - o[..., 1]) * (
                t[..., 0] - o[..., 0]
            )

        d1, d2, d3 = cross(a, b, p), cross(b, c, p), cross(c, a, p)
        neg = (d1 < -1e-15) | (d2 < -1e-15) | (d3 < -1e-15)
        pos = (d1 > 1e-15) | (d2 > 1e-15) | (d3 > 1e-15)
        return np.any(~(neg & pos), axis=1)

    def edge_distance(self, xy: np.ndarray) -> np.ndarray:
        """Distance (P,) from each point to the nearest boundary edge [m]."""
        if not len(self.boundary):
            return np.full(len(xy), np.inf)
        a, b = self.boundary[None, :, 0], self.boundary[None, :, 1]
        ab = b - a
        t = np.clip(
            np.einsum("pbi,pbi->pb", xy[:, None] - a, ab) / np.maximum((ab**2).sum(-1), 1e-30),
            0.0,
            1.0,
        )
        nearest = a + t[..., None] * ab
        return np.linalg.norm(xy[:, None] - nearest, axis=2).min(axis=1)

    @property
    def area(self) -> float:
        e1 = self.triangles[:, 1] - self.triangles[:, 0]
        e2 = self.triangles[:, 2] - self.triangles[:, 0]
        return float(np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum() / 2)


def _face(mesh: MeshData, point: np.ndarray, normal: np.ndarray) -> _Face | None:
    """The mesh triangles lying in the plane (point, normal) facing along ``normal``."""
    tri = mesh.triangles()
    fn = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(fn, axis=1)
    ok = length > 0
    fn[ok] /= length[ok, None]
    on = (
        ok
        & (fn @ normal > 1 - 1e-6)
        & (np.abs((tri.mean(axis=1) - point) @ normal) < PLANE_TOLERANCE)
    )
    if not on.any():
        return None
    faces = mesh.faces[on]
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    boundary = unique[counts == 1]
    u, v = _basis(normal)

    def flat(p: np.ndarray) -> np.ndarray:
        d = p.reshape(-1, 3) - point
        return np.stack([d @ u, d @ v], axis=-1)

    return _Face(
        point,
        u,
        v,
        flat(mesh.vertices[faces]).reshape(-1, 3, 2),
        flat(mesh.vertices[boundary]).reshape(-1, 2, 2),
    )


def _grid(face: _Face, margin: float, count: int = CANDIDATES) -> np.ndarray:
    """About ``count`` points (2D) on the face, each ``margin`` or more from its boundary."""
    lo = face.triangles.reshape(-1, 2).min(axis=0)
    hi = face.triangles.reshape(-1, 2).max(axis=0)
    step = max(np.sqrt(face.area / count), 1e-4)
    for _ in range(4):  # a narrow face: refine until some points survive the margin
        gu = np.arange(lo[0] + step / 2, hi[0], step)
        gv = np.arange(lo[1] + step / 2, hi[1], step)
        xy = np.stack(np.meshgrid(gu, gv, indexing="ij"), axis=-1).reshape(-1, 2)
        keep = face.inside(xy)
        xy = xy[keep]
        xy = xy[face.edge_distance(xy) >= margin - 1e-12]
        if len(xy) >= 3:
            return xy
        step /= 3
    return xy


def plane_candidates(mesh: MeshData, feature: Feature, radius: float, margin: float):
    face = _face(mesh, feature.point, feature.direction)
    if face is None:
        raise UserError(
            f"feature '{feature.name}': no face of '{feature.owner}''s geometry lies in its plane "
            "(facing along its normal): check the plane's point and normal against the geometry"
        )
    xy = _grid(face, margin)
    spread = np.linalg.svd(xy - xy.mean(axis=0), compute_uv=False) if len(xy) >= 3 else [0, 0]
    if not len(xy) or spread[1] <= 1e-6 * max(spread[0], 1e-12):
        raise UserError(
            f"feature '{feature.name}': the face leaves "
            + ("no point" if not len(xy) else "points on one line only")
            + f" {margin * 1000:g} mm (the margin) from its edges; the face is "
            f"{face.area * 1e6:.4g} mm^2: a smaller --margin or ball, or another face"
        )
    points = face.to_3d(xy)
    normals = np.repeat(feature.direction[None], len(points), axis=0)
    return Candidates(feature, points, normals, points + radius * normals)


def line_candidates(mesh: MeshData, feature: Feature, radius: float, margin: float) -> Candidates:
    """A convex edge touched by the ball coming in along the bisector of its two faces' normals:
    the first contact is the edge itself, the centre ``radius`` out along the bisector."""
    d, p0 = feature.direction, feature.point
    faces = mesh.faces
    edges = np.unique(
        np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1),
        axis=0,
    )
    ends = mesh.vertices[edges] - p0  # (E, 2, 3)
    off = ends - (ends @ d)[..., None] * d
    on = np.all(np.linalg.norm(off, axis=2) < PLANE_TOLERANCE, axis=1)
    if not on.any():
        raise UserError(
            f"feature '{feature.name}': no edge of '{feature.owner}''s geometry lies on this line"
        )
    s = ends[on] @ d
    s0, s1 = float(s.min()), float(s.max())
    tri = mesh.triangles()
    fn = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    fn /= np.maximum(np.linalg.norm(fn, axis=1), 1e-300)[:, None]
    rel = tri - p0
    near = np.linalg.norm(rel - (rel @ d)[..., None] * d, axis=2) < PLANE_TOLERANCE
    distinct: list[np.ndarray] = []
    for n in fn[near.sum(axis=1) >= 2]:  # triangles with an edge on the line
        if not any(n @ m > 1 - 1e-6 for m in distinct):
            distinct.append(n)
    if len(distinct) != 2:
        raise UserError(
            f"feature '{feature.name}': {len(distinct)} face(s) meet at this edge of "
            f"'{feature.owner}''s geometry; an edge to probe joins two faces"
        )
    bisector = distinct[0] + distinct[1]
    if np.linalg.norm(bisector) < 1e-6:
        raise UserError(f"feature '{feature.name}': the two faces at this edge are opposite")
    bisector /= np.linalg.norm(bisector)
    mid = p0 + 0.5 * (s0 + s1) * d
    eps = 1e-4
    solid = winding_number(np.stack([mid - eps * bisector, mid + eps * bisector]), tri) > 0.5
    if not (solid[0] and not solid[1]):
        raise UserError(
            f"feature '{feature.name}': the edge is concave (an inside corner): a ball cannot "
            "touch it; probe its two faces as planes"
        )
    if s1 - s0 <= 2 * margin:
        raise UserError(
            f"feature '{feature.name}': the edge is {(s1 - s0) * 1000:.4g} mm long, too short for "
            f"points {margin * 1000:g} mm (the margin) from its ends"
        )
    s = np.linspace(s0 + margin, s1 - margin, max(int((s1 - s0) / 1e-3), 2))
    points = p0 + s[:, None] * d
    normals = np.repeat(bisector[None], len(points), axis=0)
    return Candidates(
        feature,
        points,
        normals,
        points + radius * normals,
        offset=radius * bisector if radius > 0 else None,
    )


def circle_candidates(
    mesh: MeshData, feature: Feature, radius: float, depth: float | None
) -> Candidates:
    """A hole's or boss's wall at ``depth`` below the rim (default: half the wall)."""
    c, n, R = feature.point, feature.direction, float(feature.radius)
    u, v = _basis(n)
    tri = mesh.triangles()
    eps = min(2e-4, R / 10)

    def solid(points):
        return winding_number(np.atleast_2d(points), tri) > 0.5

    inner, outer = c - eps * n + (R - eps) * u, c - eps * n + (R + eps) * u
    hole = bool(solid(outer)[0] and not solid(inner)[0])
    boss = bool(solid(inner)[0] and not solid(outer)[0])
    if not (hole or boss):
        raise UserError(
            f"feature '{feature.name}': '{feature.owner}''s geometry has no hole or boss wall at "
            f"the circle (radius {R * 1000:g} mm), below its rim along -normal"
        )
    if solid(c + eps * n + (R + eps if hole else R - eps) * u)[0]:
        raise UserError(
            f"feature '{feature.name}': there is material above the circle: its normal must "
            "point out of the part"
        )
    # how deep the wall goes below the rim, in 0.1 mm steps along one radius
    behind, front = (R + eps, R - eps) if hole else (R - eps, R + eps)
    extent = float(np.ptp(mesh.vertices @ n))
    z = np.arange(eps, extent + 1e-4, 1e-4)
    wall = solid(c - z[:, None] * n + behind * u) & ~solid(c - z[:, None] * n + front * u)
    wall_depth = float(z[np.argmin(wall)]) if not wall.all() else float(z[-1])
    lo, hi = radius + WALL_CLEARANCE, wall_depth - radius - WALL_CLEARANCE
    if hole and radius > R - 2 * WALL_CLEARANCE:
        raise UserError(
            f"feature '{feature.name}': the probe's ball (radius {radius * 1000:g} mm) does not "
            f"fit the hole (radius {R * 1000:g} mm) with {2 * WALL_CLEARANCE * 1000:g} mm to move"
        )
    if hi < lo:
        raise UserError(
            f"feature '{feature.name}': the wall is {wall_depth * 1000:.4g} mm deep, too shallow "
            f"for the ball (radius {radius * 1000:g} mm): it needs "
            f"{(2 * radius + 2 * WALL_CLEARANCE) * 1000:g} mm"
        )
    if depth is None:
        depth = 0.5 * (lo + hi)
    elif not lo <= depth <= hi:
        raise UserError(
            f"feature '{feature.name}': a probing depth of {depth * 1000:g} mm is outside the "
            f"part's wall: the ball fits between {lo * 1000:.4g} and {hi * 1000:.4g} mm below the "
            f"rim (the wall is {wall_depth * 1000:.4g} mm deep)"
        )
    angles = np.linspace(0, 2 * np.pi, ANGLES, endpoint=False)
    radial = np.cos(angles)[:, None] * u + np.sin(angles)[:, None] * v
    centre = c - depth * n
    behind = solid(centre + (R + eps if hole else R - eps) * radial)
    front = solid(centre + (R - eps if hole else R + eps) * radial)
    keep = behind & ~front
    if keep.sum() < 3:
        raise UserError(
            f"feature '{feature.name}': the wall exists at only {int(keep.sum())} of {ANGLES} "
            f"angles at {depth * 1000:g} mm below the rim"
        )
    radial = radial[keep]
    points = centre + R * radial
    normals = -radial if hole else radial
    centres = points + radius * normals
    return Candidates(feature, points, normals, centres, None, boss, float(depth), wall_depth)


def point_candidates(mesh: MeshData, feature: Feature, radius: float) -> Candidates:
    tri = mesh.triangles()
    from ..collision.bodies import point_triangle_distance

    dist = point_triangle_distance(feature.point, tri)
    k = int(np.argmin(dist))
    if dist[k] > PLANE_TOLERANCE:
        raise UserError(
            f"feature '{feature.name}': the point is {dist[k] * 1000:.4g} mm off "
            f"'{feature.owner}''s surface: a probe cannot touch it"
        )
    n = np.cross(tri[k, 1] - tri[k, 0], tri[k, 2] - tri[k, 0])
    n /= np.linalg.norm(n)
    return Candidates(feature, feature.point[None], n[None], (feature.point + radius * n)[None])


def feature_candidates(
    cell: CellModel,
    feature: Feature,
    radius: float,
    margin: float,
    depth: float | None = None,
) -> Candidates:
    """Candidate probe contacts on ``feature`` for a ball of ``radius`` [m] (module docstring).

    Raises
    ------
    UserError
        The feature does not meet its owner's geometry, the ball does not fit, or the depth lies
        outside the wall; the message names the feature and the figure.
    """
    mesh = _owner_mesh(cell, feature)
    if feature.kind == "plane":
        return plane_candidates(mesh, feature, radius, margin)
    if feature.kind == "line":
        return line_candidates(mesh, feature, radius, margin)
    if feature.kind == "circle":
        return circle_candidates(mesh, feature, radius, depth)
    return point_candidates(mesh, feature, radius)


# --------------------------------------------------------------------------- choosing points


def fit_rows(feature, points: np.ndarray) -> np.ndarray:
    """Each contact point's row of the feature fit's design (M, r): a plane's ``[1, u, v]``
    (in-plane coordinates), a circle's ``[1, cos, sin]`` of its angle about the axis, a line's
    ``[1, s]`` along it, a point's ``[1]``.  Points chosen to make these rows' information
    ``sum x x^T`` large (D-optimal) spread in two directions on a face and around a hole."""
    from ..world.feature_targets import in_plane_axes

    d = np.asarray(points, float) - feature.point
    ones = np.ones((len(d), 1))
    if feature.kind == "plane":
        u, v = in_plane_axes(feature.direction)
        return np.hstack([ones, (d @ u)[:, None], (d @ v)[:, None]])
    if feature.kind == "circle":
        u, v = in_plane_axes(feature.direction)
        angle = np.arctan2(d @ v, d @ u)
        return np.hstack([ones, np.cos(angle)[:, None], np.sin(angle)[:, None]])
    if feature.kind == "line":
        return np.hstack([ones, (d @ feature.direction)[:, None]])
    return ones


def next_spread(rows: np.ndarray, information: np.ndarray, pool: np.ndarray) -> int:
    """Of the candidates ``pool`` (indices into ``rows``), the one that adds most to the
    information's log-determinant (the D-optimal increment ``x^T M^-1 x``); ties to the first."""
    M = information + 1e-9 * np.trace(information + np.eye(len(information))) * np.eye(
        len(information)
    )
    X = rows[pool]
    gain = np.einsum("ki,ij,kj->k", X, np.linalg.inv(M), X)
    # ties (symmetric candidates) to the first, whatever the last bits of the arithmetic (BLAS
    # threads differ between executors): the same choice on every machine
    return int(pool[int(np.argmax(np.round(gain / max(float(gain.max()), 1e-300), 9)))])


def spread_set(rows: np.ndarray, n: int, fixed: list[int], pool: np.ndarray) -> list[int]:
    """``n`` candidates - the ``fixed`` ones and the best of ``pool`` - whose rows' information
    has the largest determinant: greedy, then exchanges while one raises it (Fedorov's
    algorithm); the fixed ones are never exchanged."""
    chosen = list(fixed)
    pool = pool[~np.isin(pool, chosen)]
    information = rows[chosen].T @ rows[chosen]
    while len(chosen) < n and len(pool):
        k = next_spread(rows, information, pool)
        chosen.append(k)
        pool = pool[pool != k]
        information += np.outer(rows[k], rows[k])

    def logdet(indices) -> float:  # to 9 decimals: ties the same on every machine
        X = rows[indices]
        return round(float(np.linalg.slogdet(X.T @ X + 1e-12 * np.eye(rows.shape[1]))[1]), 9)

    best = logdet(chosen)
    improved = True
    while improved and len(pool):
        improved = False
        for i in range(len(fixed), len(chosen)):
            trial = [chosen[:i] + [int(k)] + chosen[i + 1 :] for k in pool]
            values = [logdet(t) for t in trial]
            j = int(np.argmax(values))
            if values[j] > best + 1e-6:
                pool = np.append(pool[pool != pool[j]], chosen[i])
                chosen, best, improved = trial[j], values[j], True
    return chosen


def spread_warning(feature, points: np.ndarray) -> str | None:
    """What ``calibrate`` would warn of the chosen contact points: a plane's points almost on a
    line (in-plane spread ratio below 0.05), a hole's within less than 240 deg of its wall."""
    if feature.kind == "plane" and len(points) >= 3:
        d = np.asarray(points) - np.mean(points, axis=0)
        values = np.sort(np.linalg.eigvalsh(d.T @ d))[::-1]
        ratio = float(np.sqrt(max(values[1], 0.0) / max(values[0], 1e-300)))
        if ratio < 0.05:
            return (
                f"the {len(points)} points on {feature.name} lie almost on a line (in-plane "
                f"spread ratio {ratio:.3f}): calibrate will weakly determine its tilt; the face "
                "holds no wider spread within reach"
            )
    if feature.kind == "circle" and len(points) >= 3:
        angles = np.sort(fit_rows(feature, points)[:, 1:] @ np.array([1, 1j]))
        angles = np.sort(np.angle(angles))
        gaps = np.diff(np.r_[angles, angles[0] + 2 * np.pi])
        covered = float(np.degrees(2 * np.pi - gaps.max()))
        if covered < 240.0 - 1.0:  # 3 points 120 deg apart cover 240 deg
            return (
                f"the {len(points)} points on {feature.name} span {covered:.0f} deg of its "
                "circle (under 240): its centre is weakly determined across the gap"
            )
    return None


def farthest_points(points: np.ndarray, n: int, start: int = 0) -> np.ndarray:
    """Indices of ``n`` points spread by farthest-point sampling (uniform coverage)."""
    n = min(n, len(points))
    chosen = [start]
    d = np.linalg.norm(points - points[start], axis=1)
    for _ in range(n - 1):
        k = int(np.argmax(d))
        chosen.append(k)
        d = np.minimum(d, np.linalg.norm(points - points[k], axis=1))
    return np.array(chosen)


def d_optimal(
    rows: list[np.ndarray],
    counts: list[int],
    spacing: list[float],
    positions: list[np.ndarray],
    feasible,
    seeds: list[list[int]] | None = None,
) -> list[list[int]]:
    """Greedy D-optimal choice of probe points for one frame's features.

    Parameters
    ----------
    rows : list of ndarray, shape (M_f, r_f, 6)
        Per feature, each candidate's residual rows with respect to the frame's pose (rotation
        vector, translation), from the maximum-likelihood Jacobian.
    counts : list of int
        Points wanted per feature.
    spacing : list of float
        Per feature, the least distance between two chosen points [m].
    positions : list of ndarray, shape (M_f, 3)
        The candidates' positions (for the spacing).
    feasible : callable(feature index, candidate index) -> bool
        Reachability check, asked lazily for the best candidate (False drops it).
    seeds : list of list of int, optional
        Per feature, candidates to try first, in order: the first three feasible ones are taken
        (a plane's most spread points, so that its own fit is defined).

    Returns
    -------
    list of list of int
        The chosen candidates per feature, in the order chosen.

    Each round adds to every feature still short of its count the candidate that most
    increases ``log det`` of the information matrix ``sum J^T J`` (the inverse of the
    predicted covariance up to sigma^2).
    """
    M = np.eye(6) * 1e-12
    chosen: list[list[int]] = [[] for _ in rows]
    alive = [np.ones(len(r), dtype=bool) for r in rows]
    for f, seed in enumerate(seeds or []):
        for k in seed:
            if len(chosen[f]) >= min(3, counts[f]) or not alive[f][k]:
                continue
            if feasible(f, k):
                chosen[f].append(k)
                M = M + rows[f][k].T @ rows[f][k]
                alive[f] &= np.linalg.norm(positions[f] - positions[f][k], axis=1) >= spacing[f]
            alive[f][k] = False
    while True:
        progressed = False
        for f, R in enumerate(rows):
            if len(chosen[f]) >= counts[f]:
                continue
            Minv = np.linalg.inv(M)
            # det(M + G^T G) / det(M) = det(I + G M^-1 G^T)
            gain = np.linalg.slogdet(
                np.eye(R.shape[1])[None] + np.einsum("mri,ij,msj->mrs", R, Minv, R)
            )[1]
            gain[~alive[f]] = -np.inf
            while np.isfinite(gain).any():
                k = int(np.argmax(gain))
                if feasible(f, k):
                    break
                alive[f][k] = False
                gain[k] = -np.inf
            else:
                continue  # nothing feasible left on this feature
            chosen[f].append(k)
            M = M + R[k].T @ R[k]
            close = np.linalg.norm(positions[f] - positions[f][k], axis=1) < spacing[f]
            alive[f] &= ~close
            alive[f][k] = False
            progressed = True
        if not progressed:
            return chosen

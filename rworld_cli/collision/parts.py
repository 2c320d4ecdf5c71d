"""Convex parts of mesh bodies: each connected part of a closed mesh as its hull where the hull
stands within :data:`HULL_DEVIATION` of the part's surface (else the body keeps its triangles),
cached on disk by the mesh's bytes; and the exact point-triangle distances the checks and the
deviation bound use."""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from ..model.cell import Shape
from ..units import COLLISION_TOLERANCE


def convex_parts(shape: Shape) -> tuple[tuple[np.ndarray, np.ndarray], ...] | None:
    """The convex parts of a closed mesh, or ``None`` when a part is not convex.

    Returns
    -------
    tuple of (vertices (V, 3), axes (3, 3)), or None
        Each part's hull vertices in the owner's frame [m] and its principal axes (rows).

    Why: a mesh that is a union of convex parts is the union of their hulls, so a handful of
    hull pieces replaces hundreds of triangles (and the winding-number test).  A part counts as
    convex when its hull stands off its surface by at most ``HULL_DEVIATION`` (0.5 mm, half
    the default collision tolerance): distances to the hull are then at most that much below
    the exact ones, never above (the hull holds the part), and no hull overlap that shallow is
    a collision.
    """
    if not shape.closed or shape.mesh_file is None:
        return None
    stat = Path(shape.mesh_file).stat()  # the file as it is now: a long process sees edits
    return _convex_parts(
        str(shape.mesh_file),
        float(shape.mesh_scale),
        shape.T_owner_shape.tobytes(),
        stat.st_mtime_ns,
        stat.st_size,
    )


HULL_DEVIATION = COLLISION_TOLERANCE / 2  # [m] how far a part's hull may stand off its surface


# what the cached convex parts depend on besides the file, its scale and placement: this
# module's code (the deviation test) and its constant
PARTS_FORMAT = f"parts|{HULL_DEVIATION!r}"


@functools.lru_cache(maxsize=256)
def _convex_parts(mesh_file: str, scale: float, T_bytes: bytes, mtime_ns: int = 0, size: int = 0):
    """:func:`convex_parts` of a mesh file: in the process on (path, mtime, size), on disk on
    the file's content (``rworld_cli.cache``, kind ``meshes``): the hulls and the deviation
    test cost seconds for a vendor's dense link meshes."""
    import hashlib

    from .. import cache

    content = Path(mesh_file).read_bytes()
    key = hashlib.sha256(
        f"{PARTS_FORMAT}|{scale!r}|".encode() + _code() + T_bytes + b"|" + content
    ).hexdigest()[:40]
    data = cache.arrays(
        "meshes",
        f"parts-{key}.npz",
        ("convex", "counts", "vertices", "axes"),
        lambda: _parts_arrays(_hull_parts(mesh_file, scale, T_bytes)),
    )
    if not bool(data["convex"][0]):
        return None
    vertices = np.split(data["vertices"], np.cumsum(data["counts"])[:-1])
    return tuple(zip(vertices, list(data["axes"])))


def _parts_arrays(parts) -> dict[str, np.ndarray]:
    """Convex parts (or None: not convex) as plain arrays: a flag, each part's vertex count,
    the vertices one after another, the axes."""
    if parts is None:
        return {
            "convex": np.array([False]),
            "counts": np.zeros(0, dtype=np.int64),
            "vertices": np.zeros((0, 3)),
            "axes": np.zeros((0, 3, 3)),
        }
    return {
        "convex": np.array([True]),
        "counts": np.array([len(v) for v, _ in parts], dtype=np.int64),
        "vertices": np.concatenate([v for v, _ in parts]),
        "axes": np.stack([a for _, a in parts]),
    }


@functools.cache
def _code() -> bytes:
    """This module's code: what cached parts depend on besides the mesh (the deviation test)."""
    return Path(__file__).read_bytes()


def _hull_parts(mesh_file: str, scale: float, T_bytes: bytes):
    """The convex parts of a mesh file (:func:`convex_parts`), computed."""
    import trimesh

    T = np.frombuffer(T_bytes).reshape(4, 4)
    mesh = trimesh.load(mesh_file, force="mesh")
    mesh.apply_scale(scale)
    mesh.apply_transform(T)
    out = []
    for part in mesh.split(only_watertight=False):  # type: ignore[attr-defined]
        if not part.is_watertight:
            return None
        hull = part.convex_hull
        if (
            hull_deviation(hull.triangles, part.triangles, stop_above=HULL_DEVIATION)
            > HULL_DEVIATION
        ):
            return None
        vertices = np.asarray(hull.vertices, dtype=float)
        centred = vertices - vertices.mean(axis=0)
        _, _, axes = np.linalg.svd(centred, full_matrices=False)
        out.append((vertices, axes))
    return tuple(out) if out else None


def _planes(tri: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit normals (F, 3), offsets (F,) [m] and areas (F,) [m^2] of triangles."""
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    double = np.linalg.norm(cross, axis=1)
    normal = cross / np.maximum(double, 1e-300)[:, None]
    return normal, np.einsum("fi,fi->f", normal, tri[:, 0]), 0.5 * double


def _uncovered(hull: np.ndarray, bridging: np.ndarray, part: np.ndarray) -> float:
    """The radius [m] of a disc with the largest area a flat hull face leaves uncovered by the
    part's faces in its plane: a hole through a plate opens its top face, which the points of
    :func:`hull_deviation` may all miss.  A slit counts as the disc of its area (the safe side:
    the part is then taken as not convex, and checked by its triangles)."""
    nh, dh, ah = _planes(hull)
    npart, dpart, apart = _planes(part)
    worst = 0.0
    done: list[tuple[np.ndarray, float]] = []
    for k in np.flatnonzero(bridging):
        if any(abs(n @ nh[k] - 1) < 1e-9 and abs(d - dh[k]) < 1e-9 for n, d in done):
            continue
        done.append((nh[k], dh[k]))
        in_hull = (np.abs(nh @ nh[k] - 1) < 1e-9) & (np.abs(dh - dh[k]) < 1e-9)
        in_part = (np.abs(npart @ nh[k] - 1) < 1e-9) & (np.abs(dpart - dh[k]) < 1e-9)
        if not in_part.any():  # the face bridges a dent: the points measure it
            continue
        gap = ah[in_hull].sum() - apart[in_part].sum()
        worst = max(worst, float(np.sqrt(max(gap, 0.0) / np.pi)))
    return worst


def hull_deviation(
    hull: np.ndarray, part: np.ndarray, per_edge: int = 3, stop_above: float = np.inf
) -> float:
    """How far a hull stands off the solid it wraps: the largest distance from points on the
    hull's faces to the part's surface [m], over a barycentric grid of ``per_edge`` + 1 points a
    side on each hull face that is not a face of the part itself; and, for a flat face the part
    covers only in part (a plate's top with holes through it), the radius of the disc of the
    area left open (:func:`_uncovered`).

    Parameters
    ----------
    hull, part : ndarray, shape (F, 3, 3)
        Triangles of the hull and of the part.
    stop_above : float
        Return as soon as a distance above this is found (a part that is not convex is told in
        its first chunk of points, not after all of them).
    """

    def keys(tri: np.ndarray) -> set:
        rounded = np.round(tri, 9)
        return {tuple(sorted(map(tuple, t))) for t in rounded}

    own = keys(part)
    bridging = np.array(
        [tuple(sorted(map(tuple, t))) not in own for t in np.round(hull, 9)], dtype=bool
    )
    if not bridging.any():
        return 0.0
    opening = _uncovered(hull, bridging, part)
    if opening > stop_above:
        return opening
    n = per_edge
    weights = np.array(
        [(i / n, j / n, 1 - (i + j) / n) for i in range(n + 1) for j in range(n + 1 - i)]
    )
    points = np.einsum("wk,fki->fwi", weights, hull[bridging]).reshape(-1, 3)
    best = np.full(len(points), np.inf)
    for start in range(0, len(points), 256):  # (256, F) at a time
        chunk = points[start : start + 256]
        best[start : start + 256] = point_triangle_distance(chunk[:, None, :], part[None]).min(1)
        if best[start : start + 256].max() > stop_above:
            break
    return max(opening, float(best[np.isfinite(best)].max(initial=0.0)))


def point_triangle_distance(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Distance from points to triangles, broadcast (Ericson, *Real-Time Collision Detection*,
    5.1.5: the closest point by the Voronoi region of the triangle it falls in).

    Parameters
    ----------
    p : ndarray, shape (..., 3)
    tri : ndarray, shape (..., 3, 3)

    Returns
    -------
    ndarray, shape (...)
    """
    a, b, c = tri[..., 0, :], tri[..., 1, :], tri[..., 2, :]
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = (ab * ap).sum(-1), (ac * ap).sum(-1)
    bp, cp = p - b, p - c
    d3, d4 = (ab * bp).sum(-1), (ac * bp).sum(-1)
    d5, d6 = (ab * cp).sum(-1), (ac * cp).sum(-1)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    # a zero-area triangle (a sliver meshes from CAD often hold) has no face region: its
    # divisions are 0/0 and its distance is that of its nearest edge, below
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        denom = va + vb + vc
        v_in, w_in = vb / denom, vc / denom
        t_ab = d1 / (d1 - d3)
        t_ac = d2 / (d2 - d6)
        t_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        closest = a + v_in[..., None] * ab + w_in[..., None] * ac  # inside the face
        rules = [  # later rules take precedence where their region applies
            ((vc <= 0) & (d1 >= 0) & (d3 <= 0), a + t_ab[..., None] * ab),
            ((vb <= 0) & (d2 >= 0) & (d6 <= 0), a + t_ac[..., None] * ac),
            ((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0), b + t_bc[..., None] * (c - b)),
            ((d6 >= 0) & (d5 <= d6), c),
            ((d3 >= 0) & (d4 <= d3), b),
            ((d1 <= 0) & (d2 <= 0), a),
        ]
        for region, point in rules:
            closest = np.where(region[..., None], np.broadcast_to(point, closest.shape), closest)
        out = np.linalg.norm(p - closest, axis=-1)
    bad = ~np.isfinite(out)
    if bad.any():
        edges = np.minimum(
            np.minimum(_segment_distance(p, a, b), _segment_distance(p, b, c)),
            _segment_distance(p, c, a),
        )
        out = np.where(bad, edges, out)
    return out


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance from points to segments a-b, broadcast (a point segment included)."""
    ab = b - a
    length2 = (ab * ab).sum(-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.clip(((p - a) * ab).sum(-1) / length2, 0.0, 1.0)
    t = np.where(length2 > 0, t, 0.0)
    return np.linalg.norm(p - (a + t[..., None] * ab), axis=-1)

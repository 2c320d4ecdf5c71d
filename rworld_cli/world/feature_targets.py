"""Targets on features: the tool frames that feature steps aim at, in the feature owner's frame.

A feature is fixed in its owner's natural frame (``model.cell.Feature``); calibration moves
the owner, never the feature.  So a target given here as ``T_owner_target`` moves with every
correction of the owner's pose, exactly, and a program written on features needs no frame
placed by hand beside them (``docs/programs.md``).

Frames, in the owner's axes (SI):

* **plane** - origin at the plane's ``point`` (or ``at = [u, v]`` from it along the in-plane
  axes ``u``, ``v``), moved ``standoff`` out along the normal ``n``; z = -n (the tool points
  into the surface), x = u.  ``u`` is the owner's x axis projected onto the plane (its y axis
  when x is within 25 deg of the normal), ``v = n x u``.
* **circle** - the same at the centre, on its axis.
* **line** - origin at ``point + s d`` (``at = s``); x = d along the line, z at right angles
  to it towards ``toward`` (the owner's centre of mass: the tool comes at an edge from
  outside the material), ``standoff`` back from the line against z.
* **point** - origin at the point, ``standoff`` along the owner's z; z = -z_owner, x = x_owner.

The rotation left free by the feature - about z for planes, circles and points, about the line
for lines - is ``spin`` (:func:`spun`); feature steps choose it for reach, or take it given.

The *outward* frame of a held object's feature (:func:`outward_frame`: a peg's tip, a part's
bottom face) has z = +n (out of the material): an insertion or a placement brings it onto
the target feature's frame, z on z.
"""

from __future__ import annotations

import numpy as np

from ..model.cell import Feature

SPINS = np.radians(np.arange(0.0, 360.0, 15.0))  # the free rotation's candidates, 24
_NEAR_NORMAL = np.cos(np.radians(25.0))  # |x . n| above this: x is too near the normal


def in_plane_axes(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The in-plane axes (u, v) of a plane with unit ``normal`` (owner frame): u the owner's
    x axis projected onto the plane (its y axis when x is within 25 deg of the normal), v = n x u.
    """
    n = np.asarray(normal, dtype=float)
    base = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < _NEAR_NORMAL else np.array([0.0, 1.0, 0.0])
    u = base - (base @ n) * n
    u /= np.linalg.norm(u)
    return u, np.cross(n, u)


def _frame(x: np.ndarray, z: np.ndarray, origin: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = x, np.cross(z, x), z, origin
    return T


def feature_frame(
    feature: Feature,
    at: float | tuple[float, float] | np.ndarray | None = None,
    standoff: float = 0.0,
    toward: np.ndarray | None = None,
) -> np.ndarray:
    """``T_owner_target``: the tool frame a step aims at on ``feature`` (module docstring),
    before the free rotation.

    Parameters
    ----------
    feature : Feature
        In its owner's frame.
    at : float or (2,) array, optional
        A line: the distance along it from its point [m]; a plane: [u, v] from its point [m].
    standoff : float
        [m] out of the material: along a plane's or circle's normal, back from a line.
    toward : ndarray, shape (3,), optional
        A line's material side (owner frame); default the owner's origin.

    Returns
    -------
    ndarray, shape (4, 4)
    """
    p = np.asarray(feature.point, dtype=float)
    if feature.kind in ("plane", "circle"):
        n = np.asarray(feature.direction, dtype=float)
        u, v = in_plane_axes(n)
        if at is not None:
            a = np.asarray(at, dtype=float)
            p = p + a[0] * u + a[1] * v
        return _frame(u, -n, p + standoff * n)
    if feature.kind == "line":
        d = np.asarray(feature.direction, dtype=float)
        p = p + (float(np.asarray(at)) if at is not None else 0.0) * d
        target = np.zeros(3) if toward is None else np.asarray(toward, dtype=float)
        w = target - p
        w = w - (w @ d) * d
        if np.linalg.norm(w) < 1e-9:  # the material's centre on the line: come from above
            w = np.array([0.0, 0.0, -1.0]) - d[2] * d
            if np.linalg.norm(w) < 1e-9:
                w = np.array([-1.0, 0.0, 0.0]) - d[0] * d
        z = w / np.linalg.norm(w)
        return _frame(d, z, p - standoff * z)
    # a point
    return _frame(np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, -1.0]), p + [0, 0, standoff])


def outward_frame(feature: Feature) -> np.ndarray:
    """``T_owner_feature`` of a held object's feature, z out of its material: a circle's or
    plane's normal, a line's direction (an axis points out of the tip); origin at its point,
    x the in-plane axis u (for a line, u of the plane normal to it)."""
    z = np.asarray(feature.direction if feature.direction is not None else [0, 0, 1], dtype=float)
    x, _ = in_plane_axes(z)
    return _frame(x, z, np.asarray(feature.point, dtype=float))


def spin_axis(kind: str) -> int:
    """The axis of the free rotation in the target frame: 0 (x, along a line) or 2 (z)."""
    return 0 if kind == "line" else 2


def spun(T: np.ndarray, kind: str, spins: np.ndarray | float) -> np.ndarray:
    """``T`` turned about its own free axis (:func:`spin_axis`) by each of ``spins`` [rad].

    Returns
    -------
    ndarray, shape (S, 4, 4), or (4, 4) for a single spin
    """
    angles = np.atleast_1d(np.asarray(spins, dtype=float))
    c, s = np.cos(angles), np.sin(angles)
    R = np.zeros((len(angles), 4, 4))
    R[:, 3, 3] = 1.0
    if spin_axis(kind) == 2:
        R[:, 0, 0], R[:, 0, 1], R[:, 1, 0], R[:, 1, 1], R[:, 2, 2] = c, -s, s, c, 1.0
    else:
        R[:, 0, 0], R[:, 1, 1], R[:, 1, 2], R[:, 2, 1], R[:, 2, 2] = 1.0, c, -s, s, c
    out = T @ R
    return out[0] if np.ndim(spins) == 0 else out


def along(T: np.ndarray, distance: float) -> np.ndarray:
    """``T`` moved ``distance`` [m] along its own z axis (into the material for a target)."""
    out = np.array(T, dtype=float)
    out[..., :3, 3] += distance * out[..., :3, 2]
    return out


def plane_coordinates(feature: Feature, point: np.ndarray) -> np.ndarray:
    """[u, v] of ``point`` (owner frame) projected onto a plane or circle feature [m]."""
    u, v = in_plane_axes(np.asarray(feature.direction, dtype=float))
    w = np.asarray(point, dtype=float) - feature.point
    return np.array([w @ u, w @ v])

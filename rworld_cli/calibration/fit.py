"""Feature equations from probe points by total least squares (calibration report, section 3).

The report fits a plane by minimising the sum of squared perpendicular
distances: the plane passes through the centroid (its eq. 7) and its normal
solves the "type equations" (8) for the least root S of the determinantal
equation - that is, the normal is the eigenvector of the points' scatter
matrix with the smallest eigenvalue, and S is the mean square residual.
A line is the same with the largest eigenvalue; a circle in 3D is a plane
fit, then a circle fit in that plane (algebraic, refined geometrically).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


class FitError(Exception):
    """The points cannot define the feature; the message gives the figure."""


@dataclass
class FeatureFit:
    """A fitted feature in world coordinates (SI).

    Attributes
    ----------
    point : ndarray, shape (3,)
        The point; the line's or plane's centroid; the circle's centre.
    direction : ndarray, shape (3,) or None
        Unit line direction or plane / circle normal.
    oriented : bool
        The direction's sign is measured (a plane's 'above' point, a line's probing order).
    radius : float or None
    residuals : ndarray, shape (N,)
        Signed distances of the probe points from the fitted feature [m].
    rms : float
    outliers : list of int
        Points farther than 3 rms from the feature.
    condition : float
        How well the points define the feature: for planes and circles the ratio of the
        in-plane spreads (1 = round, 0 = collinear); for lines 1 - (cross spread / along spread).
    warnings : list of str
    axis_only : bool
        A circle probed on its wall at one depth: where its axis crosses that depth is measured,
        not the axis' direction (the points lie in whatever plane the probe moved in).
    """

    feature: str
    kind: str
    point: np.ndarray
    direction: np.ndarray | None
    oriented: bool
    radius: float | None
    residuals: np.ndarray
    rms: float
    outliers: list[int]
    condition: float
    n_points: int
    points: np.ndarray
    warnings: list[str] = field(default_factory=list)
    axis_only: bool = False  # a circle's wall probed at one depth: its axis direction unmeasured


def _scatter(points: np.ndarray):
    centroid = points.mean(axis=0)
    X = points - centroid
    values, vectors = np.linalg.eigh(X.T @ X / len(points))  # ascending: the report's roots S
    return centroid, np.maximum(values, 0.0), vectors


def _outliers(residuals: np.ndarray) -> tuple[float, list[int]]:
    rms = float(np.sqrt(np.mean(residuals**2))) if len(residuals) else 0.0
    if len(residuals) < 5 or rms == 0.0:
        return rms, []
    return rms, [int(i) for i in np.nonzero(np.abs(residuals) > 3.0 * rms)[0]]


def fit_plane(
    name: str, points: np.ndarray, above=None, probe_radius: float = 0.0, side=None
) -> FeatureFit:
    """Total-least-squares plane; normal toward ``above`` (or ``side``, a hint vector) when given.

    ``probe_radius`` moves the plane from the probe-ball centres to the surface, against the normal.
    """
    if len(points) < 3:
        raise FitError(f"a plane needs at least 3 points, got {len(points)}")
    centroid, values, vectors = _scatter(points)
    spread = np.sqrt(values)
    if spread[2] == 0 or spread[1] / spread[2] < 1e-6:
        raise FitError(
            "the points are collinear (in-plane spread ratio "
            f"{spread[1] / max(spread[2], 1e-300):.2g}); a plane needs points spread in two "
            "directions"
        )
    normal = vectors[:, 0]
    oriented = above is not None
    reference = np.asarray(above, float) - centroid if above is not None else side
    if reference is not None and normal @ reference < 0:
        normal = -normal
    warnings = []
    if above is not None and abs(normal @ (np.asarray(above) - centroid)) < 3 * spread[0] + 1e-9:
        warnings.append("the 'above' point lies on the plane: it gives no side")
        oriented = False
    residuals = (points - centroid) @ normal
    if probe_radius:
        if reference is None:
            raise FitError(
                "probe-radius compensation needs the plane's outside: give an 'above' point"
            )
        centroid = centroid - probe_radius * normal
    rms, outliers = _outliers(residuals)
    condition = float(spread[1] / spread[2])
    if condition < 0.05:
        warnings.append(
            f"the points lie almost on a line (in-plane spread ratio {condition:.3f}): the "
            "plane's tilt about it is weakly determined"
        )
    return FeatureFit(
        name,
        "plane",
        centroid,
        normal,
        oriented,
        None,
        residuals,
        rms,
        outliers,
        condition,
        len(points),
        points,
        warnings,
    )


def fit_line(name: str, points: np.ndarray, ordered: bool = False) -> FeatureFit:
    """Total-least-squares line; directed first -> last point when ``ordered``."""
    if len(points) < 2:
        raise FitError(f"a line needs at least 2 points, got {len(points)}")
    centroid, values, vectors = _scatter(points)
    direction = vectors[:, 2]
    if values[2] <= 0:
        raise FitError("all points coincide: they give no direction")
    if ordered and direction @ (points[-1] - points[0]) < 0:
        direction = -direction
    offsets = points - centroid
    perp = offsets - np.outer(offsets @ direction, direction)
    residuals = np.linalg.norm(perp, axis=1)
    rms, outliers = _outliers(residuals)
    condition = float(1.0 - np.sqrt(values[1] / values[2]))
    warnings = (
        [] if len(points) >= 3 else ["2 points define the line but leave no residual to check it"]
    )
    return FeatureFit(
        name,
        "line",
        centroid,
        direction,
        ordered,
        None,
        residuals,
        rms,
        outliers,
        condition,
        len(points),
        points,
        warnings,
    )


def fit_circle(
    name: str,
    points: np.ndarray,
    above=None,
    probe_radius: float = 0.0,
    side=None,
    boss: bool = False,
) -> FeatureFit:
    """Circle in 3D: the plane of the points, then a circle in it (algebraic, refined
    geometrically).

    ``probe_radius``: the points are ball centres touching the inside of a hole (the rim's radius is
    larger by it) or, with ``boss``, the outside of a boss (smaller by it).
    """
    from scipy.optimize import least_squares

    if len(points) < 3:
        raise FitError(f"a circle needs at least 3 points, got {len(points)}")
    plane = fit_plane(name, points, above, 0.0, side)
    n = plane.direction
    u = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    xy = np.stack([(points - plane.point) @ u, (points - plane.point) @ v], axis=1)
    A = np.column_stack([2 * xy, np.ones(len(xy))])
    sol, *_ = np.linalg.lstsq(
        A, (xy**2).sum(axis=1), rcond=None
    )  # Kasa: x^2 + y^2 = 2 a x + 2 b y + c
    c0 = sol[:2]
    r0 = np.sqrt(max(sol[2] + c0 @ c0, 0.0))
    res = least_squares(
        lambda p: np.linalg.norm(xy - p[:2], axis=1) - p[2],
        np.r_[c0, r0],
        xtol=1e-15,
        ftol=1e-15,
        gtol=1e-15,
    )
    cx, cy, r = res.x
    center = plane.point + cx * u + cy * v
    residuals = np.linalg.norm(xy - [cx, cy], axis=1) - r
    angles = np.sort(np.arctan2(xy[:, 1] - cy, xy[:, 0] - cx))
    gaps = np.diff(np.r_[angles, angles[0] + 2 * np.pi])
    span = 2 * np.pi - gaps.max()
    rms, outliers = _outliers(residuals)
    warnings = list(plane.warnings)
    if span < np.radians(120):
        warnings.append(
            f"the points cover only {np.degrees(span):.0f} deg of the circle: its centre is "
            "weakly determined; spread them round the rim"
        )
    return FeatureFit(
        name,
        "circle",
        center,
        n,
        plane.oriented,
        float(r - probe_radius if boss else r + probe_radius),
        residuals,
        rms,
        outliers,
        float(span / (2 * np.pi)),
        len(points),
        points,
        warnings,
    )


def fit_point(name: str, points: np.ndarray) -> FeatureFit:
    """A point feature: the mean of repeated probes."""
    if len(points) < 1:
        raise FitError("a point needs at least one probe")
    center = points.mean(axis=0)
    residuals = np.linalg.norm(points - center, axis=1)
    rms, outliers = _outliers(residuals)
    return FeatureFit(
        name,
        "point",
        center,
        None,
        False,
        None,
        residuals,
        rms,
        outliers,
        1.0,
        len(points),
        points,
        [],
    )

"""The pinhole camera with OpenCV's distortion: projection and what a camera can see.

The model is OpenCV's (``cv2.projectPoints`` with five coefficients), written out so that it
runs vectorised over any number of points and views, and so that its derivatives are exact:

    x' = X/Z,  y' = Y/Z,  r^2 = x'^2 + y'^2
    x'' = x' (1 + k1 r^2 + k2 r^4 + k3 r^6) + 2 p1 x' y' + p2 (r^2 + 2 x'^2)
    y'' = y' (1 + k1 r^2 + k2 r^4 + k3 r^6) + p1 (r^2 + 2 y'^2) + 2 p2 x' y'
    u = fx x'' + cx,  v = fy y'' + cy
"""

from __future__ import annotations

import numpy as np

from ..model.vision import CameraModel


def project(intrinsics, points) -> np.ndarray:
    """Pixel positions of points in the camera's frame.

    Parameters
    ----------
    intrinsics : array_like, shape (9,)
        ``fx fy cx cy k1 k2 p1 p2 k3`` [px, px, px, px, -, -, -, -, -].
    points : array_like, shape (..., 3)
        Points in the camera frame [m] (any length unit: only ratios enter).

    Returns
    -------
    ndarray, shape (..., 2)
        ``(u, v)`` [px]; points at or behind the lens give non-finite or meaningless values
        (see :func:`visible`).
    """
    fx, fy, cx, cy, k1, k2, p1, p2, k3 = np.asarray(intrinsics, dtype=float)
    P = np.asarray(points, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        x = P[..., 0] / P[..., 2]
        y = P[..., 1] / P[..., 2]
        r2 = x * x + y * y
        radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        xy = x * y
        xd = x * radial + 2.0 * p1 * xy + p2 * (r2 + 2.0 * x * x)
        yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * xy
        return np.stack([fx * xd + cx, fy * yd + cy], axis=-1)


def radial_limit(distortion) -> float:
    """The normalised radius (``r = |(X, Y)| / Z``) up to which the distortion maps radii
    one-to-one (its radial factor times r still increasing); ``inf`` where it never turns.

    Beyond it a point's distorted position folds back into the image: a real lens does not
    see it there, and neither does :func:`visible`.
    """
    k1, k2, _p1, _p2, k3 = np.asarray(distortion, dtype=float)
    # d/dr [r (1 + k1 r^2 + k2 r^4 + k3 r^6)] = 1 + 3 k1 s + 5 k2 s^2 + 7 k3 s^3, s = r^2;
    # terms below 1e-15 dropped (a fold beyond r ~ 1e5 is no camera's)
    coefficients = [1.0, 3.0 * k1, 5.0 * k2, 7.0 * k3]
    while len(coefficients) > 1 and abs(coefficients[-1]) < 1e-15:
        coefficients.pop()
    roots: np.ndarray = (
        np.polynomial.polynomial.polyroots(coefficients) if len(coefficients) > 1 else np.zeros(0)
    )
    s = [r.real for r in np.atleast_1d(roots) if abs(r.imag) < 1e-12 and r.real > 0]
    return float(np.sqrt(min(s))) if s else float("inf")


def visible(camera: CameraModel, points, margin: float = 0.0) -> np.ndarray:
    """Which points the camera's image holds: in front of the lens, within the distortion's
    one-to-one range and inside the image by ``margin`` [px].

    Parameters
    ----------
    points : array_like, shape (..., 3)
        Points in the camera frame [m].

    Returns
    -------
    ndarray of bool, shape (...)

    Notes
    -----
    Occlusion by other bodies is not looked at here.
    """
    P = np.asarray(points, dtype=float)
    front = P[..., 2] > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.hypot(P[..., 0], P[..., 1]) / P[..., 2]
    uv = project(camera.intrinsics, P)
    inside = (
        (uv[..., 0] >= -0.5 + margin)
        & (uv[..., 0] <= camera.width - 0.5 - margin)
        & (uv[..., 1] >= -0.5 + margin)
        & (uv[..., 1] <= camera.height - 0.5 - margin)
    )
    return front & (r < radial_limit(camera.distortion)) & inside


def transform_points(T, points) -> np.ndarray:
    """``T @ p`` for points, shape (..., 4, 4) with (M, 3) -> (..., M, 3)."""
    T = np.asarray(T, dtype=float)
    return np.matmul(points, np.swapaxes(T[..., :3, :3], -1, -2)) + T[..., None, :3, 3]

"""Cameras and calibration boards as plain SI data (``docs/vision.md``)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: OpenCV's distortion coefficients, in its order.
DISTORTION_NAMES = ("k1", "k2", "p1", "p2", "k3")


@dataclass(frozen=True)
class CameraModel:
    """A pinhole camera with OpenCV's distortion (``k1 k2 p1 p2 k3``), no skew.

    The camera frame is OpenCV's: origin at the projection centre, +z along the optical axis
    (into the scene), +x along the image rows (to the right), +y down the image. Pixel
    coordinates are OpenCV's: the centre of the top-left pixel is (0, 0).

    Attributes
    ----------
    width, height : int
        Image size [px].
    fx, fy, cx, cy : float
        Focal lengths and principal point [px].
    distortion : ndarray, shape (5,)
        ``k1 k2 p1 p2 k3`` (dimensionless).
    """

    name: str
    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    distortion: np.ndarray = field(default_factory=lambda: np.zeros(5))

    @property
    def matrix(self) -> np.ndarray:
        """The camera matrix K, shape (3, 3) [px]."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def intrinsics(self) -> np.ndarray:
        """``fx fy cx cy k1 k2 p1 p2 k3``, shape (9,)."""
        return np.r_[self.fx, self.fy, self.cx, self.cy, self.distortion]

    def with_intrinsics(self, values) -> CameraModel:
        """The same camera with ``fx fy cx cy k1 k2 p1 p2 k3`` replaced."""
        v = np.asarray(values, dtype=float)
        fx, fy, cx, cy = (float(x) for x in v[:4])
        return CameraModel(self.name, self.width, self.height, fx, fy, cx, cy, v[4:9].copy())


@dataclass(frozen=True)
class BoardModel:
    """A planar calibration board and the points a detector reports on it.

    The board's frame is OpenCV's: +x along the first row of corners (``columns`` of them),
    +y along the columns (``rows`` of them), +z into the board (away from a camera that sees
    the pattern); its origin at the first inner corner the detector reports on a chessboard,
    at the board's outer corner on a ChArUco board (its first corner one square in along x
    and y, as ``cv2.aruco.CharucoBoard`` places them).

    An AprilTag grid (Kalibr's ``aprilgrid``, OpenCV's ``aruco.GridBoard``): ``columns`` x
    ``rows`` tags, tag ``k`` at column ``k % columns``, row ``k // columns``; its points are
    each tag's four outer corners (clockwise from the top-left as the detector reports them,
    point ``4 k + c``), the origin at tag 0's top-left corner.

    Attributes
    ----------
    pattern : str
        ``chessboard``, ``charuco`` or ``aprilgrid``.
    columns, rows : int
        Squares along x and y for a ChArUco board; inner corners for a chessboard; tags for
        an AprilTag grid.
    square : float
        Edge of a square, or of a tag [m].
    marker : float or None
        Edge of a ChArUco marker [m].
    dictionary : str or None
        The ArUco dictionary of a ChArUco board (OpenCV's name, ``DICT_5X5_100``) or the tag
        family of an AprilTag grid (``DICT_APRILTAG_36h11``).
    spacing : float or None
        The gap between an AprilTag grid's tags [m].
    """

    name: str
    pattern: str
    columns: int
    rows: int
    square: float
    marker: float | None = None
    dictionary: str | None = None
    spacing: float | None = None

    @property
    def corner_grid(self) -> tuple[int, int]:
        """Inner corners along x and y."""
        if self.pattern == "charuco":
            return self.columns - 1, self.rows - 1
        return self.columns, self.rows

    @property
    def points(self) -> np.ndarray:
        """The corners in the board's frame, shape (N, 3) [m], row by row (x fastest); an
        AprilTag grid's tag by tag, four a tag."""
        if self.pattern == "aprilgrid":
            pitch = self.square + float(self.spacing or 0.0)
            k = np.arange(self.columns * self.rows)
            x0, y0 = (k % self.columns) * pitch, (k // self.columns) * pitch
            s = self.square
            corners = np.array([[0.0, 0.0], [s, 0.0], [s, s], [0.0, s]])
            pts = np.zeros((len(k) * 4, 3))
            pts[:, 0] = (x0[:, None] + corners[None, :, 0]).ravel()
            pts[:, 1] = (y0[:, None] + corners[None, :, 1]).ravel()
            return pts
        nx, ny = self.corner_grid
        ix, iy = np.meshgrid(np.arange(nx), np.arange(ny))
        pts = np.zeros((nx * ny, 3))
        first = 1 if self.pattern == "charuco" else 0
        pts[:, 0] = (ix.ravel() + first) * self.square
        pts[:, 1] = (iy.ravel() + first) * self.square
        return pts

    @property
    def outline(self) -> np.ndarray:
        """The printed pattern's four outer corners in the board's frame, shape (4, 3) [m]:
        the corner grid with one square around it (a detector needs the outer squares); an
        AprilTag grid's tags with one gap around them (a tag needs its white border)."""
        if self.pattern == "aprilgrid":
            gap = float(self.spacing or 0.0)
            pitch = self.square + gap
            x0 = y0 = -gap
            x1, y1 = self.columns * pitch, self.rows * pitch
        else:
            nx, ny = self.corner_grid
            first = 1 if self.pattern == "charuco" else 0
            x0, y0 = (first - 1) * self.square, (first - 1) * self.square
            x1, y1 = (first + nx) * self.square, (first + ny) * self.square
        return np.array([[x0, y0, 0.0], [x1, y0, 0.0], [x1, y1, 0.0], [x0, y1, 0.0]])

    @property
    def centre(self) -> np.ndarray:
        """The middle of the board's points, shape (3,) [m]."""
        pts = self.points
        return (pts.min(axis=0) + pts.max(axis=0)) / 2

    @property
    def span(self) -> float:
        """The points' shorter extent plus a square [m] (a chessboard's: its inner corners
        along the shorter side times the square): how far views aim around the centre."""
        pts = self.points
        return float(min(np.ptp(pts[:, 0]), np.ptp(pts[:, 1]))) + self.square

    @property
    def width(self) -> float:
        """The printed pattern's extent along x [m] (:attr:`outline`)."""
        return float(np.ptp(self.outline[:, 0]))

"""Board corners found in images by OpenCV: a chessboard by ``findChessboardCornersSB``
(sub-pixel, its own accuracy mode), a ChArUco board by ``aruco.CharucoDetector``; each
image's result or the reason it is not used.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.vision import BoardModel

#: a chessboard whose edges are wider than this (OpenCV's sharpness: the mean width of the
#: black-white transitions, px) is refused as blurred. The real images of tests/data/vision
#: have 2.6-2.8 px; blurred by a Gaussian of 2 px they have 6.0 px and their corners move by
#: up to 0.1 px
MAX_EDGE_WIDTH = 5.0
#: fewest corners a ChArUco view needs to give its pose
MIN_CHARUCO_CORNERS = 6
#: fewest tags an AprilTag grid's view needs (their 8 corners give its pose)
MIN_APRILGRID_TAGS = 2


@dataclass(frozen=True)
class Detection:
    """One image's corners.

    Attributes
    ----------
    corners : ndarray, shape (N, 2)
        The board's corners [px] in :attr:`BoardModel.points` order, NaN where not seen; all
        NaN when refused.
    refused : str or None
        Why the image is not used: ``board not found``, ``partly seen``, ``blurred``.
    detail : str
        The figure behind a refusal (the edge width, how much of the board was seen).
    sharpness : float or None
        OpenCV's mean edge width [px] for a chessboard found.
    """

    name: str
    corners: np.ndarray
    refused: str | None = None
    detail: str = ""
    sharpness: float | None = None

    @property
    def seen(self) -> int:
        return int(np.count_nonzero(np.isfinite(self.corners[:, 0])))


def _none(board: BoardModel) -> np.ndarray:
    return np.full((len(board.points), 2), np.nan)


def detect_chessboard(name: str, grey: np.ndarray, board: BoardModel) -> Detection:
    """Find the chessboard's inner corners in a grey image ``(H, W)`` uint8."""
    import cv2

    size = board.corner_grid
    flags = cv2.CALIB_CB_EXHAUSTIVE | cv2.CALIB_CB_ACCURACY
    found, corners = cv2.findChessboardCornersSB(grey, size, flags=flags)
    if not found:
        # some grid of corners where the whole is not: the board runs out of the image or is
        # covered; else no board (or too small, or another size than the file says)
        partly, part, meta = cv2.findChessboardCornersSBWithMeta(grey, (4, 4), cv2.CALIB_CB_LARGER)
        if partly and part is not None:
            rows, cols = np.shape(meta)
            return Detection(
                name,
                _none(board),
                "partly seen",
                f"a {cols}x{rows} grid of corners found, not the board's "
                f"{size[0]}x{size[1]}: it runs out of the image or is covered",
            )
        return Detection(
            name,
            _none(board),
            "board not found",
            f"no grid of inner corners ({size[0]}x{size[1]} wanted)",
        )
    corners = corners.reshape(-1, 2).astype(float)
    sharpness = cv2.estimateChessboardSharpness(grey, size, corners.astype(np.float32))
    width = float(np.ravel(sharpness[0])[0])  # (mean edge width, ...), then brightness
    if width > MAX_EDGE_WIDTH:
        return Detection(
            name,
            _none(board),
            "blurred",
            f"edges {width:.2f} px wide (at most {MAX_EDGE_WIDTH:g})",
            sharpness=width,
        )
    return Detection(name, _orient(corners, size), sharpness=width)


def _orient(corners: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """OpenCV orders a chessboard's corners from either end; keep the order whose first corner
    is nearer the image's top-left, so that one board's views agree (a board turned by more
    than 90 degrees between views is beyond this rule: the calibration renumbers such views
    by the robot's motion, ``vision/calibrate.orient_to_robot``)."""
    if corners[0, 0] + corners[0, 1] > corners[-1, 0] + corners[-1, 1]:
        return corners[::-1].copy()
    return corners


def _charuco_board(board: BoardModel):
    import cv2

    dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, str(board.dictionary)))
    return cv2.aruco.CharucoBoard(
        (board.columns, board.rows), board.square, float(board.marker or 0), dictionary
    )


def detect_charuco(name: str, grey: np.ndarray, board: BoardModel) -> Detection:
    """Find a ChArUco board's corners (each identified by its markers: partial views count)."""
    import cv2

    detector = cv2.aruco.CharucoDetector(_charuco_board(board))
    corners, ids, _marker_corners, _marker_ids = detector.detectBoard(grey)
    out = _none(board)
    if ids is None or len(ids) < MIN_CHARUCO_CORNERS:
        n = 0 if ids is None else len(ids)
        return Detection(
            name,
            out,
            "board not found",
            f"{n} ChArUco corners identified, {MIN_CHARUCO_CORNERS} needed",
        )
    out[np.asarray(ids).ravel()] = np.asarray(corners, dtype=float).reshape(-1, 2)
    return Detection(name, out)


def _aprilgrid_board(board: BoardModel):
    import cv2

    dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, str(board.dictionary)))
    return cv2.aruco.GridBoard(
        (board.columns, board.rows), board.square, float(board.spacing or 0.0), dictionary
    )


def refine_tag_corners(grey: np.ndarray, quad: np.ndarray, samples: int = 16) -> np.ndarray:
    """A tag's four corners (4, 2) [px] from its four edges: across each side of the
    detector's quad, intensity profiles (bilinear, a quarter pixel apart) at ``samples``
    places between 15 and 85 % of the side; the edge at each where the profile crosses the
    mean of its dark (the tag's border) and bright (the white around it) ends; a line fitted
    through them (total least squares); the corners where adjacent lines meet.

    An outer corner of a dark square on white is not a saddle point: OpenCV's corner
    refinements pull it into the square when the image is blurred (0.4 px inward, 0.58 px rms
    on a rendered grid at 5 px a cell); a blurred edge's mid level is where the edge is, so
    the lines' corners are not (0.08 px rms on that image; ``docs/vision.md``).  The quad is
    kept where a side has fewer than three edge points or a corner would move by more than
    2 px (a tag too small or too dim to refine)."""
    from scipy.ndimage import map_coordinates

    img = np.asarray(grey, dtype=float)
    side = float(np.linalg.norm(np.roll(quad, -1, axis=0) - quad, axis=1).mean())
    half = max(2.5, 0.09 * side)  # about 0.7 of a cell of the tag's 8 across
    steps = np.linspace(-half, half, int(np.ceil(2 * half / 0.25)) + 1)
    quarter = max(1, len(steps) // 4)
    centre = quad.mean(axis=0)
    lines = []
    for k in range(4):
        a, b = quad[k], quad[(k + 1) % 4]
        d = (b - a) / np.linalg.norm(b - a)
        n = np.array([d[1], -d[0]])
        if n @ (centre - a) > 0:  # the normal out of the tag
            n = -n
        base = a + np.linspace(0.15, 0.85, samples)[:, None] * (b - a)
        pts = base[:, None, :] + steps[None, :, None] * n  # (S, P, 2): x, y
        profile = map_coordinates(img, [pts[..., 1], pts[..., 0]], order=1, mode="nearest")
        dark = profile[:, :quarter].mean(axis=1)
        bright = profile[:, -quarter:].mean(axis=1)
        # each profile's mid-level crossing nearest the middle, all profiles at once
        p = profile - ((dark + bright) / 2)[:, None]
        rising = (p[:, :-1] < 0) & (p[:, 1:] >= 0)  # (S, P - 1)
        gap = np.where(rising, np.abs(np.arange(len(steps) - 1) - len(steps) // 2), len(steps))
        i = np.argmin(gap, axis=1)
        rows = np.arange(samples)
        good = rising[rows, i] & (bright - dark >= 20)
        if good.sum() < 3:
            return quad
        i, rows = i[good], rows[good]
        f = -p[rows, i] / (p[rows, i + 1] - p[rows, i])
        points = base[rows] + (steps[i] + f * (steps[1] - steps[0]))[:, None] * n
        middle = points.mean(axis=0)
        direction = np.linalg.svd(points - middle)[2][0]
        lines.append((middle, direction))
    out = np.empty((4, 2))
    for k in range(4):  # corner k: where side k-1 (into it) meets side k (out of it)
        (p1, d1), (p2, d2) = lines[(k - 1) % 4], lines[k]
        along = np.linalg.solve(np.array([d1, -d2]).T, p2 - p1)
        out[k] = p1 + along[0] * d1
    if not np.all(np.isfinite(out)) or np.abs(out - quad).max() > 2.0:
        return quad
    return out


def detect_aprilgrid(name: str, grey: np.ndarray, board: BoardModel) -> Detection:
    """Find an AprilTag grid's tags (each identified by its code: partial views count) and
    their four corners: OpenCV's ArUco detector with the AprilTag family, each tag's corners
    then from its edges (:func:`refine_tag_corners`); tags of other ids are passed over."""
    import cv2

    parameters = cv2.aruco.DetectorParameters()
    parameters.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, str(board.dictionary)))
    corners, ids, _rejected = cv2.aruco.ArucoDetector(dictionary, parameters).detectMarkers(grey)
    out = _none(board)
    tags = board.columns * board.rows
    found = [] if ids is None else [int(i) for i in np.ravel(ids)]
    mine = [(k, tag) for k, tag in enumerate(found) if tag < tags]
    if len(mine) < MIN_APRILGRID_TAGS:
        return Detection(
            name,
            out,
            "board not found",
            f"{len(mine)} of the grid's tags identified, {MIN_APRILGRID_TAGS} needed",
        )
    for k, tag in mine:
        quad = np.asarray(corners[k], dtype=float).reshape(4, 2)
        out[4 * tag : 4 * tag + 4] = refine_tag_corners(grey, quad)
    return Detection(name, out)


def detect(name: str, grey: np.ndarray, board: BoardModel) -> Detection:
    """The board's corners in one grey image."""
    if board.pattern == "charuco":
        return detect_charuco(name, grey, board)
    if board.pattern == "aprilgrid":
        return detect_aprilgrid(name, grey, board)
    return detect_chessboard(name, grey, board)


def aprilgrid_image(board: BoardModel, pixels_per_metre: float, margin: int = 0) -> np.ndarray:
    """The AprilTag grid's printable image (grey uint8), as OpenCV draws it: ``margin`` white
    pixels around the tags' extent."""
    pitch = board.square + float(board.spacing or 0.0)
    size = (
        int(round((board.columns * pitch - float(board.spacing or 0.0)) * pixels_per_metre))
        + 2 * margin,
        int(round((board.rows * pitch - float(board.spacing or 0.0)) * pixels_per_metre))
        + 2 * margin,
    )
    return _aprilgrid_board(board).generateImage(size, marginSize=margin)


def charuco_image(board: BoardModel, pixels_per_square: int, margin: int = 0) -> np.ndarray:
    """The ChArUco board's printable image (grey uint8), as OpenCV draws it."""
    size = (
        board.columns * pixels_per_square + 2 * margin,
        board.rows * pixels_per_square + 2 * margin,
    )
    return _charuco_board(board).generateImage(size, marginSize=margin)

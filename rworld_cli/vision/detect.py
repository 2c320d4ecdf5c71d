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
    than 90 degrees between views is beyond this rule: use a ChArUco board)."""
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


def detect(name: str, grey: np.ndarray, board: BoardModel) -> Detection:
    """The board's corners in one grey image."""
    if board.pattern == "charuco":
        return detect_charuco(name, grey, board)
    return detect_chessboard(name, grey, board)


def charuco_image(board: BoardModel, pixels_per_square: int, margin: int = 0) -> np.ndarray:
    """The ChArUco board's printable image (grey uint8), as OpenCV draws it."""
    size = (
        board.columns * pixels_per_square + 2 * margin,
        board.rows * pixels_per_square + 2 * margin,
    )
    return _charuco_board(board).generateImage(size, marginSize=margin)

"""Corners found in real images by OpenCV, and the images refused with their reason."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from rworld_cli.model.vision import BoardModel
from rworld_cli.vision.detect import charuco_image, detect

cv2 = pytest.importorskip("cv2")

DATA = Path(__file__).resolve().parents[1] / "data" / "vision" / "kuka2"
BOARD = BoardModel("board", "chessboard", 24, 17, 0.015)


def _vendored(view: str, folder: Path = DATA) -> np.ndarray:
    """The corners vendored for ``view`` in ``folder``'s corners.csv, (N, 2) [px]."""
    lines = (line for line in open(folder / "corners.csv") if not line.startswith("#"))
    rows = list(csv.reader(lines))[1:]
    return np.array([[float(r[2]), float(r[3])] for r in rows if r[0] == view])


@pytest.fixture(scope="module")
def image() -> np.ndarray:
    return cv2.imread(str(DATA / "images" / "im_13.png"), cv2.IMREAD_GRAYSCALE)


def test_a_real_image_gives_the_corners_found_in_the_shipped_bmp(image):
    found = detect("im_13.png", image, BOARD)
    assert found.refused is None and found.seen == 408
    # corners.csv holds the detection in the shipped BMP, at 4 decimals
    assert np.abs(found.corners - _vendored("im_13.png")).max() < 6e-5
    assert 2.0 < found.sharpness < 3.5
    # the first corner is the one nearer the image's top-left, the rows run along +x
    c = found.corners
    assert c[0].sum() < c[-1].sum() and c[1, 0] > c[0, 0]


def test_a_blurred_image_is_refused_with_its_edge_width(image):
    found = detect("blurred", cv2.GaussianBlur(image, (0, 0), 4.0), BOARD)
    assert found.refused == "blurred"
    assert "px wide (at most 5)" in found.detail and np.all(np.isnan(found.corners))
    assert found.sharpness > 5


def test_a_board_half_covered_is_partly_seen_and_one_painted_over_not_found(image):
    covered = image.copy()
    covered[:, 900:] = 128
    found = detect("half", covered, BOARD)
    assert found.refused == "partly seen", found.detail
    assert "not the board's 24x17" in found.detail
    blank = image.copy()
    corners = _vendored("im_13.png")
    lo, hi = corners.min(axis=0).astype(int) - 40, corners.max(axis=0).astype(int) + 40
    blank[lo[1] : hi[1], lo[0] : hi[0]] = 128
    found = detect("blank", blank, BOARD)
    assert found.refused == "board not found", found.detail


def test_a_charuco_board_is_found_whole_and_in_part():
    board = BoardModel("ch", "charuco", 7, 5, 0.04, 0.03, "DICT_5X5_100")
    from rworld_cli.vision.detect import _charuco_board

    # the board's points are OpenCV's object points for it (float32 there)
    opencv = np.asarray(_charuco_board(board).getChessboardCorners(), dtype=float)
    assert np.abs(opencv - board.points).max() < 1e-7
    printed = charuco_image(board, 100, margin=20)  # 740 x 540 px: 100 px a square
    # seen at an angle: a homography of the print into a 1280 x 1024 image, blurred, noisy
    src = np.float32([[0, 0], [740, 0], [740, 540], [0, 540]])
    dst = np.float32([[250, 200], [1050, 260], [1000, 850], [220, 780]])
    Hm = cv2.getPerspectiveTransform(src, dst)
    view = cv2.warpPerspective(printed, Hm, (1280, 1024), flags=cv2.INTER_AREA, borderValue=90)
    view = cv2.GaussianBlur(view, (0, 0), 0.8)
    rng = np.random.default_rng(0)
    view = np.clip(view + rng.normal(0, 2.0, view.shape), 0, 255).astype(np.uint8)
    # the true corners: the board's points (metres) at 100 px per 4 cm, margin 20, mapped
    # (OpenCV's pixel centres are at whole numbers: an edge between pixels 119 and 120 of the
    # print is at 119.5; OpenCV 4.12's ChArUco corners were half a pixel off this, 4.14's not)
    truth = board.points[:, :2] / 0.04 * 100 + 20 - 0.5
    truth = cv2.perspectiveTransform(truth[None].astype(np.float64), Hm)[0]
    found = detect("charuco", view, board)
    assert found.refused is None and found.seen == 24
    assert np.nanmax(np.linalg.norm(found.corners - truth, axis=1)) < 0.3
    half = view.copy()
    half[:, 640:] = 90
    part = detect("charuco-half", half, board)
    assert part.refused is None and 6 <= part.seen < 24  # a ChArUco corner knows its place
    seen = np.isfinite(part.corners[:, 0])
    assert np.max(np.linalg.norm(part.corners[seen] - truth[seen], axis=1)) < 0.3


def test_a_real_charuco_image_gives_every_corner_in_the_vendored_order():
    # Ali et al.'s kuka_3: a calib.io board of 12 x 9 squares of 60 mm, DICT_5X5_100 markers
    # (45 mm, measured in the image: 0.76 of a square), at 3.1 m from a 1928 x 1208 camera
    folder = DATA.parent / "kuka3"
    board = BoardModel("board", "charuco", 12, 9, 0.06, 0.045, "DICT_5X5_100")
    grey = cv2.imread(str(folder / "images" / "01.png"), cv2.IMREAD_GRAYSCALE)
    found = detect("01.png", grey, board)
    assert found.refused is None and found.seen == 88  # 11 x 8 inner corners
    assert np.abs(found.corners - _vendored("01.png", folder)).max() < 6e-5
    # corner 0 at the board's first square (top-left in this view), the rows along +x
    c = found.corners
    assert c[0].sum() < c[-1].sum() and c[1, 0] > c[0, 0]


def test_tabb_and_ahmad_yousefs_image_gives_the_vendored_corners():
    # their data set 1: a 640 x 480 Sony camera on a Denso arm, a chessboard of 9 x 7 squares
    # of 28.5 mm about 2 m away (8 x 6 inner corners); image44 as the detector reads it
    folder = DATA.parent / "tabb1"
    board = BoardModel("board", "chessboard", 8, 6, 0.0285)
    grey = cv2.imread(str(folder / "images" / "image44.png"), cv2.IMREAD_GRAYSCALE)
    found = detect("image44.png", grey, board)
    assert found.refused is None and found.seen == 48
    assert np.abs(found.corners - _vendored("image44.png", folder)).max() < 6e-5
    # the board stands upright in this view: its 8-corner rows run down the image
    c = found.corners
    assert c[0].sum() < c[-1].sum() and abs(c[1, 1] - c[0, 1]) > abs(c[1, 0] - c[0, 0])

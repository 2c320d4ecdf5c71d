"""AprilTag grids (Kalibr's ``aprilgrid``, OpenCV's ``aruco.GridBoard``): the board's points
are OpenCV's, the tags' corners found in a rendered image lie where the exact projection puts
them (each tag's corners from its edges: OpenCV's corner refinements pull a blurred tag's
corners inward), a view with part of the grid outside the image gives the tags it holds, the
grid calibrates the camera through the whole loop, and its file errors are located."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import run_cli
from tests.vision.test_sense_camera import CELL

cv2 = pytest.importorskip("cv2")

CHESSBOARD = """    geometry: {box: [0.3, 0.21, 0.004], origin: {xyz: [0.12, 0.075, 0.002]}}
    board: {pattern: chessboard, columns: 9, rows: 6, square: 0.03}"""
GRID = """    geometry: {box: [0.324, 0.22, 0.004], origin: {xyz: [0.15, 0.098, 0.002]}}
    board: {pattern: aprilgrid, columns: 6, rows: 4, square: 0.04, spacing: 0.012}"""


def grid_cell(folder: Path, board: str = GRID) -> Path:
    """The vision test cell with a 6 x 4 grid of 40 mm tags, 12 mm apart, for its chessboard."""
    shutil.copytree(CELL, folder)
    text = (folder / "cell.yaml").read_text()
    assert CHESSBOARD in text
    (folder / "cell.yaml").write_text(text.replace(CHESSBOARD, board))
    return folder


@pytest.fixture(scope="module")
def cell(tmp_path_factory) -> Path:
    return grid_cell(tmp_path_factory.mktemp("aprilgrid") / "cell")


def _exact_and_found(cell: Path, camera: str, image: Path, joints=None):
    from rworld_cli.api import render_camera
    from rworld_cli.schema.loader import load_cell
    from rworld_cli.vision.detect import detect
    from rworld_cli.vision.emulate import seen_corners
    from rworld_cli.world.tree import World

    model = load_cell(str(cell)).cell
    render_camera(str(cell), camera, str(image), joints, seed=0)
    world = World(model)
    if joints:
        world.set_joints("ur5", np.asarray(joints["ur5"]))
    board = model.objects["board"].board
    exact = seen_corners(model.sensors[camera].camera, board, world.T(camera, "board"))
    grey = cv2.imread(str(image), cv2.IMREAD_GRAYSCALE)
    return board, exact, detect(image.name, grey, board)


def test_the_grids_points_are_opencvs_and_its_corners_are_found_where_they_are(cell, tmp_path):
    from rworld_cli.vision.detect import _aprilgrid_board

    board, exact, found = _exact_and_found(cell, "overhead", tmp_path / "overhead.png")
    assert board.dictionary == "DICT_APRILTAG_36h11"
    opencv = np.asarray(_aprilgrid_board(board).getObjPoints(), dtype=float).reshape(-1, 3)
    assert np.abs(opencv - board.points).max() < 1e-7
    assert found.refused is None
    assert np.isfinite(found.corners[:, 0]).all() and len(found.corners) == 96
    error = np.linalg.norm(found.corners - exact, axis=1)
    # OpenCV's own refinement: 0.58 px rms, 1.6 px at most, 0.4 px inward (docs/vision.md)
    assert np.sqrt(np.mean(error**2)) < 0.1 and error.max() < 0.2, error


def test_a_view_holding_part_of_the_grid_gives_the_tags_it_holds(cell, tmp_path):
    # the overhead camera moved 0.6 m along x: the grid runs out of the image's left edge
    moved = tmp_path / "cell"
    shutil.copytree(cell, moved)
    poses = (moved / "poses.yaml").read_text()
    old = "overhead: {xyz: [0.6, 0, 1.0], rpy: [180, 0, 0]}"
    assert old in poses
    (moved / "poses.yaml").write_text(poses.replace(old, old.replace("0.6, 0, 1.0", "1.2, 0, 1.0")))
    _board, exact, found = _exact_and_found(moved, "overhead", tmp_path / "cut.png")
    seen = np.isfinite(exact[:, 0]).reshape(-1, 4).all(axis=1)
    assert 2 <= seen.sum() < 24, seen.sum()  # a part of the grid in view
    got = np.isfinite(found.corners[:, 0]).reshape(-1, 4).all(axis=1)
    assert found.refused is None and got.sum() >= 2
    assert not (got & ~seen).any()  # no tag reported that the camera does not see whole
    error = np.linalg.norm(found.corners - exact, axis=1)[np.repeat(got, 4)]
    assert error.max() < 0.3, error


def test_the_loop_calibrates_the_wrist_camera_on_a_grid(cell, tmp_path):
    from rworld_cli.api import calibrate_camera, plan_views, render_camera

    work = tmp_path / "cell"
    shutil.copytree(cell, work)
    captures = work / "captures.yaml"
    run = plan_views(str(work), "wrist_camera", 6, candidates=150, captures=str(captures))
    for k, q in enumerate(run.joints):
        image = work / f"view{k + 1:02d}.png"
        render_camera(str(work), "wrist_camera", str(image), {"ur5": q.tolist()}, seed=k)
    result = calibrate_camera(str(captures)).result
    assert result.rms < 0.1
    X = result.T_mount_camera
    assert np.abs(X[:3, 3] * 1000 - [0.0, 60.0, 30.0]).max() < 0.2, X
    from rworld_cli import spatial

    assert np.degrees(np.linalg.norm(spatial.rotation_vector(X[:3, :3]))) < 0.05


@pytest.mark.parametrize(
    "board, message",
    [
        (
            "    board: {pattern: aprilgrid, columns: 6, rows: 4, square: 0.04}",
            "an AprilTag grid needs 'spacing' (between tags)",
        ),
        (
            "    board: {pattern: aprilgrid, columns: 6, rows: 6, square: 0.04, spacing: 0.01, "
            "dictionary: DICT_APRILTAG_16h5}",
            "6 x 6 tags: DICT_APRILTAG_16h5 holds 30",
        ),
        (
            "    board: {pattern: aprilgrid, columns: 6, rows: 4, square: 0.04, spacing: 0.01, "
            "dictionary: DICT_APRILTAG_36h12}",
            "unknown AprilTag family 'DICT_APRILTAG_36h12'",
        ),
        (
            "    board: {pattern: chessboard, columns: 9, rows: 6, square: 0.03, spacing: 0.01}",
            "'spacing' is for AprilTag grids",
        ),
    ],
)
def test_a_grids_problems_are_located(tmp_path, board, message):
    folder = grid_cell(
        tmp_path / "cell",
        "    geometry: {box: [0.324, 0.22, 0.004], origin: {xyz: [0.15, 0.098, 0.002]}}\n" + board,
    )
    r = run_cli(["validate", str(folder / "cell.yaml")])
    assert r.exit_code == 2
    line = next(k for k, t in enumerate((folder / "cell.yaml").read_text().splitlines(), 1)
                if "pattern:" in t)  # fmt: skip
    assert f"cell.yaml:{line}:" in r.output and message in r.output, r.output

"""Rendered camera images: OpenCV's detector finds the corners where the exact projection puts
them, bodies in front of a board hide it, ChArUco prints read back."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import run_cli

cv2 = pytest.importorskip("cv2")

CELL = Path(__file__).resolve().parents[1] / "data" / "vision" / "cell"


def _cell(tmp_path: Path, poses=lambda t: t, cell=lambda t: t) -> Path:
    (tmp_path / "cell.yaml").write_text(cell((CELL / "cell.yaml").read_text()))
    (tmp_path / "poses.yaml").write_text(poses((CELL / "poses.yaml").read_text()))
    return tmp_path / "cell.yaml"


def _render_and_read(cell: Path, tmp_path: Path):
    from rworld_cli.api import load_world, render_camera, sense
    from rworld_cli.vision.detect import detect

    out = tmp_path / "view.png"
    result = render_camera(str(cell), "overhead", str(out))
    image = cv2.imread(str(out), cv2.IMREAD_GRAYSCALE)
    assert image.shape == (1024, 1280) and result["written"] == [str(out)]
    world, _ = load_world(str(cell))
    board = world.cell.objects["board"].board
    _, readings = sense(str(cell))
    exact = readings[0].image["boards"]["board"]["pixels"]
    exact = np.array([p if p is not None else [np.nan, np.nan] for p in exact])
    return image, detect("view", image, board), exact


def test_the_detector_finds_the_rendered_corners_where_the_projection_puts_them(tmp_path):
    image, found, exact = _render_and_read(CELL / "cell.yaml", tmp_path)
    assert found.refused is None and found.seen == 54
    # the detector's order starts at the corner nearer the image's top-left: the board's
    # first corner here (its +x along the image's columns, +y down)
    error = np.linalg.norm(found.corners - exact, axis=1)
    assert error.max() < 0.12 and np.sqrt(np.mean(error**2)) < 0.06, error.max()


def test_a_post_in_front_of_the_board_is_drawn_over_it(tmp_path):
    cell = _cell(
        tmp_path,
        lambda t: t.replace("post: {xyz: [0.6, 0.25, 0.0]}", "post: {xyz: [0.57, -0.175, 0.004]}"),
    )
    image, found, exact = _render_and_read(cell, tmp_path)
    assert found.refused in ("partly seen", "board not found")
    hidden = np.isnan(exact[:, 0])
    assert 1 <= hidden.sum() <= 8
    from rworld_cli.vision.render import BODY

    for u, v in np.rint(_exact_all(cell)[hidden]).astype(int):
        assert abs(int(image[v, u]) - BODY) < 15  # the post's grey, noise and blur aside


def _exact_all(cell: Path) -> np.ndarray:
    """Every corner's projection, hidden or not."""
    from rworld_cli import spatial
    from rworld_cli.api import load_world
    from rworld_cli.vision.camera import project, transform_points

    world, _ = load_world(str(cell))
    cam = world.cell.sensors["overhead"].camera
    T = spatial.invert_transform(world.T_world("overhead")) @ world.T_world("board")
    return project(cam.intrinsics, transform_points(T, world.cell.objects["board"].board.points))


def test_a_charuco_board_renders_and_reads_back(tmp_path):
    cell = _cell(
        tmp_path,
        cell=lambda t: t.replace(
            "board: {pattern: chessboard, columns: 9, rows: 6, square: 0.03}",
            "board: {pattern: charuco, columns: 8, rows: 6, square: 0.035, marker: 0.026, "
            "dictionary: DICT_5X5_100}",
        ),
    )
    image, found, exact = _render_and_read(cell, tmp_path)
    assert found.refused is None and found.seen == 35
    error = np.linalg.norm(found.corners - exact, axis=1)
    assert error.max() < 0.25, error.max()


def test_render_camera_refuses_what_is_not_a_camera(tmp_path):
    r = run_cli(["render", str(CELL), "--camera", "overhed", "-o", str(tmp_path / "x.png")])
    assert r.exit_code == 2 and "'overhed' is not a camera sensor" in r.stderr
    assert "did you mean 'overhead'" in r.stderr
    r = run_cli(["render", str(CELL), "--camera", "overhead", "-o", str(tmp_path / "x.glb")])
    assert r.exit_code == 2 and "--camera writes one PNG image" in r.output
    assert not list(tmp_path.iterdir())


def test_the_depth_of_the_boards_seen_is_written_in_millimetres(tmp_path):
    r = run_cli(
        [
            "render",
            str(CELL),
            "--camera",
            "overhead",
            "-o",
            str(tmp_path / "v.png"),
            "--depth",
            str(tmp_path / "d.png"),
            "--json",
        ]
    )
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    depth = cv2.imread(str(tmp_path / "d.png"), cv2.IMREAD_UNCHANGED)
    assert depth.dtype == np.uint16 and depth.shape == (1024, 1280)
    # the print lies flat 996 mm under the lens (the camera at 1 m, the board's face at 4 mm)
    assert set(np.unique(depth)) == {0, 996}
    assert int((depth > 0).sum()) == out["board_pixels"]
    r = run_cli(["render", str(CELL), "-o", str(tmp_path / "x.png"), "--depth", "d.png"])
    assert r.exit_code == 2 and "--depth is for --camera" in r.output

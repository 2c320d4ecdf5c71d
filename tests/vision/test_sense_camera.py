"""Camera sensors in a cell: their intrinsics from pose files, what they see of boards and
point features (exact against OpenCV), what hides a corner, and the files' errors."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import run_cli

cv2 = pytest.importorskip("cv2")

CELL = Path(__file__).resolve().parents[1] / "data" / "vision" / "cell"


def _copy(tmp_path: Path, edit_poses=lambda t: t, edit_cell=lambda t: t) -> Path:
    (tmp_path / "cell.yaml").write_text(edit_cell((CELL / "cell.yaml").read_text()))
    (tmp_path / "poses.yaml").write_text(edit_poses((CELL / "poses.yaml").read_text()))
    return tmp_path / "cell.yaml"


def _sense(cell: Path):
    from rworld_cli.api import sense

    _, readings = sense(str(cell))
    return {r.sensor: r for r in readings}


def test_the_overhead_camera_sees_the_board_where_opencv_projects_it():
    readings = _sense(CELL / "cell.yaml")
    seen = readings["overhead"].image["boards"]["board"]
    assert seen["seen"] == seen["total"] == 54
    # by hand from poses.yaml: the camera at (0.6, 0, 1) turned 180 deg about x; the board on
    # the table (0.6, 0, 0) at (-0.15, -0.1, 0.004), turned 180 deg about x
    nx, ny = np.meshgrid(np.arange(9), np.arange(6))
    corners = np.c_[nx.ravel() * 0.03, ny.ravel() * 0.03, np.zeros(54)]
    flip = np.diag([1.0, -1.0, -1.0])
    world = corners @ flip.T + [0.45, -0.1, 0.004]
    in_camera = (world - [0.6, 0, 1.0]) @ flip  # flip is its own inverse and transpose
    K = np.array([[1000.0, 0, 639.5], [0, 1000.0, 511.5], [0, 0, 1]])
    theirs = cv2.projectPoints(
        in_camera, np.zeros(3), np.zeros(3), K, np.array([-0.1, 0.05, 0, 0, 0])
    )[0][:, 0]
    assert np.abs(np.array(seen["pixels"]) - theirs).max() < 1e-9
    mark = readings["overhead"].image["points"]["board.mark"]
    assert mark["seen"] == 1
    # the wrist camera at the UR5's home looks elsewhere: nothing of the board in its image
    wrist = readings["wrist_camera"].image["boards"]["board"]
    assert wrist["seen"] == 0 and wrist["outside"] + wrist["behind"] == 54


def test_a_post_over_the_board_hides_the_corners_behind_it(tmp_path):
    # the post (r 20 mm, 0.3 m tall) stood on the board's middle, under the overhead camera
    cell = _copy(
        tmp_path,
        lambda t: t.replace("post: {xyz: [0.6, 0.25, 0.0]}", "post: {xyz: [0.57, -0.175, 0.004]}"),
    )
    seen = _sense(cell)["overhead"].image["boards"]["board"]
    hidden = seen["hidden_by"]
    assert set(hidden) == {"post"} and 1 <= hidden["post"] <= 8
    assert seen["seen"] == 54 - hidden["post"]
    # the hidden ones are those whose line of sight passes within the post's radius
    pixels = np.array([p if p is not None else [np.nan, np.nan] for p in seen["pixels"]])
    gone = np.isnan(pixels[:, 0])
    nx, ny = np.meshgrid(np.arange(9), np.arange(6))
    world = np.c_[0.45 + nx.ravel() * 0.03, -0.1 - ny.ravel() * 0.03]
    eye = np.array([0.6, 0.0, 1.0])
    # where the sight line from the eye to the corner (z 0.004) is at the post's top (0.304)
    s = (1.0 - 0.304) / (1.0 - 0.004)
    at_top = eye[:2] + s * (world - eye[:2])
    # the line meets the cylinder when it enters its circle anywhere between top and board;
    # the circle seen from above: the line's closest approach to the axis over that span
    t = np.linspace(0, 1, 200)[:, None, None]
    path = at_top[None] + t * (world - at_top)[None]
    near = np.min(np.linalg.norm(path - [0.57, -0.175], axis=2), axis=0) < 0.02
    assert np.array_equal(gone, near)


def test_a_camera_under_the_table_sees_nothing_through_it(tmp_path):
    cell = _copy(
        tmp_path,
        lambda t: t.replace(
            "overhead: {xyz: [0.6, 0, 1.0], rpy: [180, 0, 0]}", "overhead: {xyz: [0.6, 0, -1.0]}"
        ),
    )
    seen = _sense(cell)["overhead"].image["boards"]["board"]
    assert seen["seen"] == 0
    assert seen["hidden_by"] == {"table": 54}


def test_the_sense_command_names_what_each_camera_sees(tmp_path):
    r = run_cli(["sense", str(CELL / "cell.yaml")])
    assert r.exit_code == 0, r.output
    assert "overhead (camera 1280x1024 px):" in r.stdout
    assert "board: 54 of 54 corners seen" in r.stdout
    assert "board: 0 of 54 corners seen (54 outside the image)" in r.stdout


@pytest.mark.parametrize(
    "edit_poses, edit_cell, message",
    [
        (lambda t: t[: t.index("cameras:")], lambda t: t, "no intrinsics for camera 'overhead' in"),
        (
            lambda t: t.replace("  wrist_camera: {resolution", "  wrist_cam: {resolution"),
            lambda t: t,
            "'wrist_cam' is not a camera sensor of the cell (did you mean",
        ),
        (
            lambda t: t,
            lambda t: t.replace("pattern: chessboard", "pattern: charuco"),
            "a ChArUco board needs 'marker' and 'dictionary'",
        ),
        (lambda t: t.replace("[1280, 1024]", "[1280, 0]"), lambda t: t, "resolution"),
    ],
)
def test_camera_and_board_errors_are_located(tmp_path, edit_poses, edit_cell, message):
    cell = _copy(tmp_path, edit_poses, edit_cell)
    r = run_cli(["validate", str(cell)])
    assert r.exit_code == 2
    assert any(message in line and (".yaml:" in line) for line in r.stderr.splitlines()), r.stderr


def test_calibrate_cameras_pose_file_gives_a_cell_its_camera(tmp_path):
    """The pose file calibrate-camera writes, listed after the cell's, moves the camera sensor
    of its name and gives it the calibrated intrinsics."""
    data = Path(__file__).resolve().parents[1] / "data" / "vision" / "kuka2"
    for name in ("captures.yaml", "corners.csv"):
        shutil.copy(data / name, tmp_path / name)
    captures = tmp_path / "captures.yaml"
    captures.write_text(
        captures.read_text()
        .replace("name: camera", "name: wrist_camera", 1)
        .replace("mount: flange", "mount: ur5.tool")
    )
    out = tmp_path / "camera_poses.yaml"
    r = run_cli(["calibrate-camera", str(captures), "--exact-robot", "--write-poses", str(out)])
    assert r.exit_code == 0, r.output
    text = out.read_text()
    assert "\ncameras:\n  wrist_camera: {resolution: [1920, 1200]" in text
    # the board's frame in the capture file is 'board' in 'base': the cell's board sits on the
    # table, so only the camera's lines go into the cell's overlay
    lines = [line for line in text.splitlines() if not line.startswith("  board:")]
    (tmp_path / "overlay.yaml").write_text("\n".join(lines) + "\n")
    cell = _copy(
        tmp_path / "",
        edit_cell=lambda t: t.replace(
            "pose_files: [poses.yaml]", "pose_files: [poses.yaml, overlay.yaml]"
        ),
    )
    from rworld_cli.api import load_world

    world, _ = load_world(str(cell))
    camera = world.cell.sensors["wrist_camera"].camera
    assert 1040 < camera.fx < 1060 and camera.width == 1920
    assert "wrist_camera" in world.cell.calibrated
    T = world.T("ur5.tool", "wrist_camera") if hasattr(world, "T") else None
    if T is not None:
        assert abs(np.linalg.norm(T[:3, 3]) - 0.137) < 0.001


def test_a_programs_sense_step_records_what_the_wrist_camera_sees():
    """A run takes the wrist camera to view1 over the board and reads it: the event holds every
    corner where OpenCV projects it from view1's pose (worked out here with scipy), to the IK's
    tolerance. (Its arm has no link shapes: the run's collision sweep took such a cell for a
    bug, exit 3, before this test.)"""
    from scipy.spatial.transform import Rotation

    r = run_cli(["simulate", str(CELL), str(CELL / "runs" / "look.yaml"), "--json"])
    assert r.exit_code == 0, r.output
    import json

    events = [e for e in json.loads(r.stdout)["events"] if e["kind"] == "sense"]
    assert len(events) == 1 and events[0]["detail"].startswith("wrist_camera: active")
    seen = events[0]["reading"]["image"]["boards"]["board"]
    assert seen["seen"] == 54
    R_view = Rotation.from_euler("xyz", [180, 0, 90], degrees=True).as_matrix()
    R_board = Rotation.from_euler("xyz", [180, 0, 0], degrees=True).as_matrix()
    nx, ny = np.meshgrid(np.arange(9), np.arange(6))
    corners = np.c_[nx.ravel() * 0.03, ny.ravel() * 0.03, np.zeros(54)]
    world = corners @ R_board.T + [0.45, -0.1, 0.004]
    in_camera = (world - [0.57, -0.175, 0.45]) @ R_view
    K = np.array([[1050.0, 0, 960], [0, 1050.0, 600], [0, 0, 1]])
    theirs = cv2.projectPoints(in_camera, np.zeros(3), np.zeros(3), K, np.zeros(5))[0][:, 0]
    assert np.abs(np.array(seen["pixels"]) - theirs).max() < 1e-3


# the general segment-triangle test (Moller-Trumbore, any starts), the reference of the sight
# lines' one below; it was rworld_cli.geometry's until the camera's readings and renderer took
# the shared-start form
def segments_hit_triangles(
    starts: np.ndarray, ends: np.ndarray, triangles: np.ndarray, chunk: int = 2_000_000
) -> np.ndarray:
    """Which segments cross a triangle strictly between their ends (Moller-Trumbore).

    Parameters
    ----------
    starts, ends : ndarray, shape (M, 3)
        The segments [m].
    triangles : ndarray, shape (K, 3, 3)
        Triangles' corners [m], in the segments' frame.
    chunk : int
        At most this many segment-triangle pairs at once (memory).

    Returns
    -------
    ndarray of bool, shape (M,)
        True where the segment meets a triangle at a parameter in (1e-9, 1 - 1e-6): an end
        that lies on a surface (a corner on its own board) does not count.
    """
    starts = np.asarray(starts, dtype=float)
    d = np.asarray(ends, dtype=float) - starts
    hit = np.zeros(len(starts), dtype=bool)
    if len(triangles) == 0 or len(starts) == 0:
        return hit
    a = triangles[:, 0]
    e1 = triangles[:, 1] - a
    e2 = triangles[:, 2] - a
    step = max(1, chunk // len(triangles))
    for lo in range(0, len(starts), step):
        s, dd = starts[lo : lo + step, None, :], d[lo : lo + step, None, :]
        p = np.cross(dd, e2[None])
        det = np.einsum("mkj,kj->mk", p, e1)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            t0 = s - a[None]
            u = np.einsum("mkj,mkj->mk", t0, p) * inv
            q = np.cross(t0, e1[None])
            v = np.einsum("mkj,mkj->mk", dd, q) * inv
            t = np.einsum("kj,mkj->mk", e2, q) * inv
            ok = (np.abs(det) > 1e-18) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 1e-9)
            ok &= t < 1 - 1e-6
        hit[lo : lo + step] = ok.any(axis=1)
    return hit


def triangles_in_sight(origin, ends, triangles):
    """The camera reading's cull of a body's triangles: their bounding spheres against the cone
    of the sight lines (``geometry.sight_cone``, ``triangle_spheres``, ``spheres_in_sight``)."""
    from rworld_cli.geometry import sight_cone, spheres_in_sight, triangle_spheres

    cone = sight_cone(origin, ends)
    if cone is None:
        return np.ones(len(triangles), dtype=bool)
    return spheres_in_sight(origin, cone, *triangle_spheres(triangles))


@pytest.mark.parametrize("seed", range(6))
def test_the_sight_cull_keeps_every_triangle_a_sight_line_meets(seed):
    """The camera reading's cull of a body's triangles against the cone of its sight lines
    drops no triangle that a segment from the camera meets: the hits with and without the cull
    are the same, over random scenes where both happen."""

    rng = np.random.default_rng(seed)
    origin = rng.normal(0, 0.2, 3)
    aim = origin + rng.normal(0, 1, 3)
    ends = aim + rng.normal(0, 0.15 * (1 + seed % 3), (60, 3))
    centres = (
        origin + rng.uniform(-1.5, 1.5, (3000, 1)) * (aim - origin) + rng.normal(0, 0.4, (3000, 3))
    )
    triangles = centres[:, None] + rng.normal(0, 0.03 * (1 + seed % 2), (3000, 3, 3))
    keep = triangles_in_sight(origin, ends, triangles)
    starts = np.broadcast_to(origin, ends.shape)
    everything = segments_hit_triangles(starts, ends, triangles)
    assert everything.any() and (~everything).any()  # a scene that tests something
    assert 0 < keep.sum() < len(triangles)
    assert np.array_equal(segments_hit_triangles(starts, ends, triangles[keep]), everything)
    # and per triangle: none dropped that a segment meets
    dropped = triangles[~keep]
    for k in range(0, len(dropped), 500):
        assert not segments_hit_triangles(starts, ends, dropped[k : k + 500]).any()
    # the sight lines' own test (one matrix product for a shared start) is the general one's,
    # triangle by triangle
    from rworld_cli.geometry import sight_lines_hit_triangles

    assert np.array_equal(sight_lines_hit_triangles(origin, ends, triangles), everything)
    for k in range(0, 3000, 97):
        one = triangles[k : k + 1]
        assert np.array_equal(
            sight_lines_hit_triangles(origin, ends, one), segments_hit_triangles(starts, ends, one)
        )

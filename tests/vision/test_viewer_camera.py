"""Cameras in the viewer: a camera sensor's node carries its field of view (lines from the lens
to the image's corners at 0.25 m and the rectangle there), whose angles are OpenCV's field of
view of the intrinsics (``cv2.calibrationMatrixValues``), moving with the camera; a program's
captures are marks on the timeline; the page draws them in a real browser (headless Chromium;
skipped without it)."""

from __future__ import annotations

import numpy as np
import pytest

from rworld_cli.schema.gltf import accessor_array, read_glb, scene_glb
from tests.vision.test_sense_camera import CELL

cv2 = pytest.importorskip("cv2")


@pytest.fixture(scope="module")
def look(tmp_path_factory):
    """The test cell's run that takes the wrist camera over the board and takes an image."""
    from rworld_cli.api import simulate_run
    from rworld_cli.simulate.scene import run_scene

    root = tmp_path_factory.mktemp("look")
    program = root / "look.yaml"
    program.write_text(
        "device: ur5\nunits: {length: mm, angle: deg}\nsteps:\n"
        "  - move: {to: view1, tcp: wrist_camera}\n  - capture: wrist_camera\n"
    )
    loaded, result = simulate_run(str(CELL), str(program))
    return loaded, result, run_scene(loaded.cell, result)


def _angle(a, b) -> float:
    return float(np.degrees(np.arccos(a @ b / np.linalg.norm(a) / np.linalg.norm(b))))


def test_a_cameras_field_of_view_is_drawn_as_opencv_gives_it(look):
    loaded, _, scene = look
    gltf, blob = read_glb(scene_glb(scene), "look.glb")
    names = [n["name"] for n in gltf["nodes"]]
    for camera in ("wrist_camera", "overhead"):
        node = gltf["nodes"][names.index(f"{camera}.frustum")]
        assert node["name"] in [gltf["nodes"][c]["name"] for c in
                                gltf["nodes"][names.index(camera)]["children"]]  # fmt: skip
        primitive = gltf["meshes"][node["mesh"]]["primitives"][0]
        assert primitive["mode"] == 1  # LINES
        points = accessor_array(gltf, blob, primitive["attributes"]["POSITION"]).astype(float)
        segments = points.reshape(8, 2, 3)
        assert np.allclose(segments[:4, 0], 0.0)  # four rays from the lens
        rim = segments[4:, 0]
        assert np.allclose(rim[:, 2], 0.25, atol=1e-6)
        # the field of view, between the middles of the rim's opposite edges
        left, right = (rim[0] + rim[3]) / 2, (rim[1] + rim[2]) / 2
        top, bottom = (rim[0] + rim[1]) / 2, (rim[2] + rim[3]) / 2
        cam = loaded.cell.sensors[camera].camera
        fovx, fovy, *_ = cv2.calibrationMatrixValues(cam.matrix, (cam.width, cam.height), 1.0, 1.0)
        # OpenCV's spans the image from pixel 0 to W, rworld's from -0.5 to W - 0.5
        assert abs(_angle(left, right) - fovx) < 1e-3
        assert abs(_angle(top, bottom) - fovy) < 1e-3


def test_a_capture_is_a_mark_on_the_timeline(look):
    _, result, scene = look
    captures = [m for m in scene.info["marks"] if m["kind"] == "capture"]
    assert len(captures) == 1
    assert captures[0]["t"] == next(e.t for e in result.events if e.kind == "capture")
    assert "54/54 corners of board" in captures[0]["text"]


def test_the_page_draws_the_cameras_view(look, tmp_path):
    from rworld_cli.viewer.chromium import Browser, chromium
    from rworld_cli.viewer.page import viewer_page

    if chromium() is None:
        pytest.skip("no Chromium (install Debian's 'chromium', or set RWORLD_CHROMIUM)")
    _, result, scene = look
    path = tmp_path / "look.html"
    path.write_text(viewer_page(scene_glb(scene), scene.info), encoding="utf-8")
    browser = Browser(900, 600)
    try:
        browser.open(path.as_uri(), "window.rworld && window.rworld.ready")
        assert browser.evaluate("window.rworld.errors") == []
        t = next(e.t for e in result.events if e.kind == "capture")
        browser.evaluate(f"rworld.seek({t})")
        browser.evaluate("rworld.frameDrawn()")
        # the field of view drawn where the camera is at the capture: its lines' vertices
        drawn = np.array(browser.evaluate("rworld.frustumPoints('wrist_camera')"))
        node = next(n for n in scene.nodes if n.name == "wrist_camera")
        k = int(np.searchsorted(scene.times, t))
        T = node.poses[k]
        expected = node.lines.reshape(-1, 3) @ T[:3, :3].T + T[:3, 3]
        assert drawn.shape == (16, 3)
        assert np.abs(drawn - expected).max() < 1e-5  # float32 in the glTF
        assert browser.evaluate("document.querySelectorAll('#marks .mark-capture').length") == 1
        # the camera's own node is still the frame's (labels, positions): at its pose
        lens = np.array(browser.evaluate("rworld.worldPosition('wrist_camera')"))
        assert np.abs(lens - T[:3, 3]).max() < 1e-5
        assert browser.console_errors() == []
    finally:
        browser.close()

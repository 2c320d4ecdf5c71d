"""The viewer page of paper_fig9 transfer in a real browser (headless Chromium): it loads with no
console error, draws a known body where it must be at three instants, the picture changes between
them, and playback moves the run on.  Frame times are a figure of bench/viewer.py, never asserted
here.  Skipped, with the reason, where Chromium is missing (.ci/run installs Debian's chromium, so
CI runs these)."""

from __future__ import annotations

import io

import numpy as np
import pytest

from rworld_cli.viewer.chromium import Browser, chromium

pytestmark = pytest.mark.skipif(
    chromium() is None,
    reason="no Chromium (install Debian's 'chromium', or set RWORLD_CHROMIUM): browser tests "
    "skipped",
)

BACKGROUND = np.array([0xF4, 0xF5, 0xF7])  # the page's scene background


@pytest.fixture(scope="module")
def page(fig9_page):
    browser = Browser(1200, 800)
    try:
        browser.open(fig9_page.as_uri(), "window.rworld && window.rworld.ready")
        yield browser
    finally:
        browser.close()


def pixels(png: bytes) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)


def test_the_page_loads_without_console_errors(page):
    assert page.evaluate("window.rworld.errors") == []
    assert page.console_errors() == []
    assert page.evaluate("document.querySelectorAll('#marks .mark').length") > 20
    assert page.evaluate("document.querySelectorAll('#plots canvas').length") == 4


def test_a_known_body_is_drawn_where_it_is_and_moves(page, fig9_run):
    _, result = fig9_run
    page.evaluate("rworld.showLabels(false)")
    shots, centres = [], []
    for t in (1.0, 6.0, 12.0):
        page.evaluate(f"rworld.seek({t})")
        page.evaluate("rworld.frameDrawn()")
        assert abs(page.evaluate("rworld.time()") - t) < 1e-9
        # the page's node where the simulator puts it (cell coordinates, z up)
        k = int(np.argmin(np.abs(result.times - t)))
        tcp = result.devices["robot"].tcp[k][:3, 3]
        shown = np.array(page.evaluate("rworld.worldPosition('robot.tool_plate')"))
        assert np.abs(shown - tcp).max() < 1e-4  # tool_plate is the robot's TCP here
        x, y = page.evaluate("rworld.bodyPixel('robot.link2')")
        image = pixels(page.screenshot())
        patch = image[int(y) - 2 : int(y) + 3, int(x) - 2 : int(x) + 3]
        assert np.abs(patch - BACKGROUND).sum(axis=-1).min() > 30, (t, x, y)  # drawn there
        shots.append(image)
        centres.append((x, y))
    view_width = int(page.evaluate("document.getElementById('view').clientWidth"))
    for a, b in ((0, 1), (1, 2), (0, 2)):
        changed = np.abs(shots[a][:, :view_width] - shots[b][:, :view_width]).sum(axis=-1) > 30
        assert changed.sum() > 500, (a, b)  # the robot moved in the picture
    assert len({(round(x), round(y)) for x, y in centres}) == 3
    page.evaluate("rworld.showLabels(true)")


def test_playback_advances_the_run_and_draws_it_where_the_simulator_puts_it(page, fig9_run):
    """Playing moves the clock and the bodies with it; how fast the page draws is a figure of
    bench/viewer.py, never asserted here (a busy machine draws slower and is not wrong)."""
    _, result = fig9_run
    page.evaluate("rworld.seek(0.5)")
    page.evaluate("rworld.play()")
    page.evaluate(
        "new Promise((done) => { const wait = () => rworld.time() > 1.0 ? done() : "
        "requestAnimationFrame(wait); wait(); })",
        timeout=120,
    )
    page.evaluate("rworld.pause()")
    t = page.evaluate("rworld.time()")
    assert 1.0 < t < result.times[-1]
    page.evaluate("rworld.frameDrawn()")
    shown = np.array(page.evaluate("rworld.worldPosition('robot.tool_plate')"))
    k = np.searchsorted(result.times, t)  # the shown pose lies between the samples around t
    around = result.devices["robot"].tcp[max(k - 1, 0) : k + 1, :3, 3]
    lo, hi = around.min(axis=0) - 1.01e-4, around.max(axis=0) + 1.01e-4  # glTF: 0.1 mm
    assert np.all((lo <= shown) & (shown <= hi)), (t, shown, around)
    assert page.evaluate("window.rworld.errors") == []
    assert page.console_errors() == []


def test_hostile_text_in_the_data_stays_text(fig9_scene, tmp_path):
    """A title, a step and a mark holding `</script>`, `<!--`, `&` and a lone surrogate: the page
    still loads and plays, and shows them as the text they are (the data is JSON with \\u
    escapes)."""
    import copy

    from rworld_cli.schema.gltf import scene_glb
    from rworld_cli.viewer.page import viewer_page

    hostile = "a</script><script>window.pwned=1</script><!-- & \u2028 --> \ud800"
    info = copy.deepcopy(fig9_scene.info)
    info["title"] = hostile
    info["marks"][0]["text"] = hostile
    device = next(iter(info["devices"].values()))
    device["steps"][0]["text"] = hostile
    path = tmp_path / "hostile.html"
    path.write_text(viewer_page(scene_glb(fig9_scene), info), encoding="utf-8")
    browser = Browser(1000, 700)
    try:
        browser.open(path.as_uri(), "window.rworld && window.rworld.ready")
        assert browser.evaluate("window.pwned === undefined")
        shown = hostile.replace("\ud800", "?")  # a lone surrogate: UTF-8 cannot carry it
        assert browser.evaluate("document.getElementById('title').textContent") == shown
        assert browser.evaluate("window.rworld.errors") == []
        assert browser.console_errors() == []
    finally:
        browser.close()


@pytest.fixture(scope="module")
def probing_page(example_run, tmp_path_factory):
    """The probing cell's feature probes: three TCPs close together on the Puma's hand, and
    twelve recorded contacts."""
    from rworld_cli.schema.gltf import scene_glb
    from rworld_cli.simulate.scene import run_scene
    from rworld_cli.viewer.page import viewer_page

    loaded, result = example_run("probing", "probe_features")
    scene = run_scene(loaded.cell, result)
    path = tmp_path_factory.mktemp("probing") / "probing.html"
    path.write_text(viewer_page(scene_glb(scene), scene.info), encoding="utf-8")
    browser = Browser(1200, 800)
    try:
        browser.open(path.as_uri(), "window.rworld && window.rworld.ready")
        yield browser, result
    finally:
        browser.close()


def test_recorded_contacts_are_marked_from_their_instant(probing_page):
    """Issue 50: each contact a probe step recorded is a dot from its instant on."""
    page, result = probing_page
    times = [e.t for e in result.events if e.kind == "probe"]
    assert len(times) == 12
    for t, expected in ((0.0, 0), (times[2] + 1e-3, 3), (result.cycle_time, 12)):
        page.evaluate(f"rworld.seek({t})")
        page.evaluate("rworld.frameDrawn()")
        assert page.evaluate("rworld.contactsShown()") == expected, t
    assert page.console_errors() == []


def test_labels_do_not_overlap(probing_page):
    """Issue 50: the hand's TCP labels (tool, probe, gripper within 20 mm) stacked on each
    other; now each sits below those it would cover."""
    page, result = probing_page
    page.evaluate("rworld.showLabels(true)")
    for t in (0.0, result.cycle_time / 2):
        page.evaluate(f"rworld.seek({t})")
        page.evaluate("rworld.frameDrawn()")
        assert page.evaluate("rworld.labelOverlaps()") == 0, t

"""Frame times of the HTML run viewer during playback, in headless Chromium.

Run:  .venv/bin/python bench/viewer.py [--seconds 3] [--repeat 3]

Builds the viewer page of `paper_fig9 transfer` (the example with the most bodies), plays it in
headless Chromium (Debian's `chromium`, or $RWORLD_CHROMIUM) and prints, per repetition, the
page's own work per frame (mean, 95th percentile) and the interval between frames, beside the
CPU model and the WebGL renderer that drew them.  The ratio column divides by the 16.7 ms a
frame has at 60 Hz.  With no GPU, Chromium rasterises WebGL in software (SwiftShader): the
interval is then set by rasterising, not by the page, and grows with a busy machine.  The
browser tests assert what the page shows; this script is where its speed is measured.
"""

from __future__ import annotations

import argparse
import platform
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
FRAME_AT_60_HZ = 1000.0 / 60.0  # ms

RENDERER = """(() => {
  const gl = document.createElement("canvas").getContext("webgl");
  if (!gl) return "no WebGL";
  const info = gl.getExtension("WEBGL_debug_renderer_info");
  return info ? gl.getParameter(info.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER);
})()"""


def build_page(folder: Path) -> Path:
    """The viewer page of paper_fig9 transfer, as `simulate --view` writes it."""
    from rworld_cli.api import simulate_run
    from rworld_cli.schema.gltf import scene_glb
    from rworld_cli.simulate.scene import run_scene
    from rworld_cli.viewer.page import viewer_page

    loaded, result = simulate_run(str(REPO / "workcells" / "paper_fig9"), "transfer")
    scene = run_scene(loaded.cell, result)
    path = folder / "fig9.html"
    path.write_text(viewer_page(scene_glb(scene), scene.info), encoding="utf-8")
    return path


def main() -> None:
    from machine import cpu_model

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=3.0, help="playback measured per repeat")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()

    from rworld_cli.viewer.chromium import Browser, chromium

    if chromium() is None:
        sys.exit("no Chromium: install Debian's 'chromium' or set RWORLD_CHROMIUM")
    with tempfile.TemporaryDirectory() as tmp:
        page_path = build_page(Path(tmp))
        size_mb = page_path.stat().st_size / 1e6
        browser = Browser(1200, 800)
        try:
            browser.open(page_path.as_uri(), "window.rworld && window.rworld.ready")
            version = browser.call("Browser.getVersion").get("product", "?")
            print(f"CPU: {cpu_model()}, {platform.machine()}")
            print(f"browser: {version}; WebGL renderer: {browser.evaluate(RENDERER)}")
            print(f"page: paper_fig9 transfer, {size_mb:.2f} MB; window 1200 x 800")
            print(
                f"{'repeat':>6s} {'frames':>7s} {'work mean':>10s} {'work p95':>9s} "
                f"{'p95 / 16.7':>11s} {'interval median':>16s} {'interval p95':>13s}  [ms]"
            )
            for k in range(args.repeat):
                stats = browser.evaluate(
                    f"rworld.measure({int(args.seconds * 1000)})", timeout=60 + args.seconds
                )
                print(
                    f"{k + 1:6d} {stats['frames']:7d} {stats['work_mean']:10.2f} "
                    f"{stats['work_p95']:9.2f} {stats['work_p95'] / FRAME_AT_60_HZ:11.2f} "
                    f"{stats['gap_median']:16.1f} {stats['gap_p95']:13.1f}"
                )
            errors = browser.evaluate("window.rworld.errors") + browser.console_errors()
            if errors:
                print("page errors:", *errors, sep="\n  ")
        finally:
            browser.close()


if __name__ == "__main__":
    main()

"""simulate --glb / --view, rworld view RUN_DIR and render --html on the example cells; damaged run
directories exit 2 and write nothing; a cell without geometry for some bodies still views."""

from __future__ import annotations

import json
import shutil

import yaml

from rworld_cli.schema.gltf import read_glb
from tests.conftest import WORKCELLS, run_cli


def test_simulate_writes_glb_page_and_scene_files(tmp_path):
    out = tmp_path / "run"
    result = run_cli(
        [
            "simulate", str(WORKCELLS / "puma560"), "pick_place", "-o", str(out),
            "--glb", str(tmp_path / "run.glb"), "--view", str(tmp_path / "run.html"),
        ]
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    gltf, _ = read_glb((tmp_path / "run.glb").read_bytes(), "run.glb")
    assert gltf["animations"][0]["channels"]
    assert (out / "run.glb").read_bytes() == (tmp_path / "run.glb").read_bytes()
    html = (tmp_path / "run.html").read_text(encoding="utf-8")
    assert '<script type="importmap">' in html and "rworld-glb" in html
    result = run_cli(["view", str(out), "--json"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.output)["written"] == [str(out / "view.html")]
    assert (out / "view.html").read_text(encoding="utf-8") == html  # the same page


def test_a_damaged_run_directory_exits_2_and_writes_nothing(tmp_path):
    out = tmp_path / "run"
    assert (
        run_cli(["simulate", str(WORKCELLS / "puma560"), "pick_place", "-o", str(out)]).exit_code
        == 0
    )
    page = tmp_path / "page.html"
    page.write_text("the old page", encoding="utf-8")
    glb = (out / "run.glb").read_bytes()
    import re

    declared = re.search(rb'"buffers": ?\[\{"byteLength": ?(\d+)\}\]', glb)
    negative = glb.replace(declared.group(1), b"-5".ljust(len(declared.group(1))), 1)
    cases = {
        "run.glb": (glb[: len(glb) // 2], "run.glb: not a valid glTF binary file: the header says"),
        "run.glb ": (negative, "'buffers' is not one buffer with a whole byteLength >= 0"),
        "view.json": (b'{"title": "x",\n  "t": [1, 2,,]}', "view.json:2:14: not valid JSON"),
    }
    for name, (damage, message) in cases.items():
        name = name.strip()  # the same file damaged two ways
        original = (out / name).read_bytes()
        (out / name).write_bytes(damage)
        result = run_cli(["view", str(out), "-o", str(page)])
        assert result.exit_code == 2, result.output
        assert message in result.output, result.output
        assert page.read_text(encoding="utf-8") == "the old page"  # untouched
        (out / name).write_bytes(original)
    (out / "view.json").unlink()
    result = run_cli(["view", str(out)])
    assert result.exit_code == 2 and "view.json: missing" in result.output
    assert not (out / "view.html").exists()
    result = run_cli(["view", str(tmp_path / "nowhere")])
    assert result.exit_code == 2 and "no such directory" in result.output


def test_bodies_without_geometry_are_drawn_as_axes_and_listed(tmp_path):
    cell = tmp_path / "puma560"
    shutil.copytree(WORKCELLS / "puma560", cell)
    data = yaml.safe_load((cell / "cell.yaml").read_text())
    stripped = []
    for device in data["devices"]:
        for link in device.get("links", []):
            if link.pop("geometry", None) is not None:
                stripped.append(f"{device['name']}.{link['name']}")
    assert stripped
    (cell / "cell.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    result = run_cli(["simulate", str(cell), "pick_place", "--glb", str(tmp_path / "r.glb"),
                      "--view", str(tmp_path / "r.html"), "--no-collisions"])  # fmt: skip
    assert result.exit_code == 0, result.output
    gltf, _ = read_glb((tmp_path / "r.glb").read_bytes(), "r.glb")
    names = {n["name"]: n for n in gltf["nodes"]}
    for frame in stripped:
        assert "mesh" not in names[frame] and f"{frame}.axes" in names
    info = (tmp_path / "r.html").read_text(encoding="utf-8")
    assert all(frame in info for frame in stripped)


def test_render_html_is_the_same_viewer_for_one_state(tmp_path):
    result = run_cli(["render", str(WORKCELLS / "paper_fig9"), "--html", str(tmp_path / "c.html")])
    assert result.exit_code == 0, result.output
    assert "rworld-glb" in (tmp_path / "c.html").read_text(encoding="utf-8")
    result = run_cli(["render", str(WORKCELLS / "paper_fig9"), "--html", str(tmp_path / "c.png")])
    assert result.exit_code == 2 and "does not end in .html" in result.output

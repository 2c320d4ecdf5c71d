"""Hostile names and paths in every slot rworld writes into YAML or reads from URDF: reading back
what was written gives the same data, nothing becomes YAML, and URDF reads as XML says.

The hostile texts hold what ends a YAML scalar or comment (a newline, ``: ``, ``#``, quotes), what
YAML reads as something else (``no``, ``null``, ``1e3``), and what breaks pages and terminals
(``</script>``, a carriage return, U+2028)."""

from __future__ import annotations

import shutil
from types import SimpleNamespace

import numpy as np
import pytest

from rworld_cli.schema.yamlio import parse_yaml_text
from tests.conftest import WORKCELLS, run_cli

HOSTILE = [
    "plain_name",
    "no",
    "null",
    "1e3",
    "x: y",
    "#not a comment",
    'it\'s "quoted"',
    "line\ngravity: [0, 0, 98.1]\n#",
    "cr\r\nlf",
    "</script><!--",
    "\u2028sep\u2029",
    "\u00fcml\u00e4ut",
    "tab\there",
    "- item",
    "[1, 2]",
    "{a: 1}",
    "&anchor",
    "*alias",
    "!!python/object",
    "",
]


@pytest.mark.parametrize("text", HOSTILE)
def test_measurement_files_give_back_what_was_written(text):
    from rworld_cli.model.measurements import FeatureProbes
    from rworld_cli.schema.measurements import measurement_text

    features = {"block.f1": FeatureProbes(np.eye(3), comment=text)}
    written = measurement_text(features, text, [text, "second line"], instrument=text, date=text)
    doc = parse_yaml_text(written, "m.yaml").data
    assert doc["cell"] == text and doc["instrument"] == text and doc["date"] == text
    assert doc["features"]["block.f1"]["points"] == (np.eye(3) * 1000).tolist()
    assert sum(line.startswith("#") for line in written.splitlines()) == 2  # two, as given


@pytest.mark.parametrize("text", HOSTILE)
def test_overlays_give_back_their_provenance(text):
    from rworld_cli.schema.poses import overlay_text

    result = SimpleNamespace(overlay={"block": np.eye(4)}, solutions={})
    written = overlay_text(result, [{"path": text, "sha256": "ab" * 32}])
    doc = parse_yaml_text(written, "o.yaml").data
    assert doc["provenance"]["measurements"] == [{"path": text, "sha256": "ab" * 32}]
    assert list(doc["poses"]) == ["block"] and "gravity" not in doc


@pytest.mark.parametrize("text", HOSTILE)
def test_programs_written_from_data_read_back_the_same(text):
    from rworld_cli.schema.programs import program_text

    name = text if text and "\n" not in text else "no"  # frame names come from cells
    steps = [
        ({"move": {"to": name, "offset": {"xyz": [0.0, 1.5, -2.0]}}}, text),
        ({"probe": name}, None),
    ]
    doc = {"header": [text], "device": name, "description": text, "steps": steps}
    read = parse_yaml_text(program_text(doc), "p.yaml").data
    assert read["device"] == name and read["description"] == text
    assert read["steps"] == [s for s, _ in steps]


def test_path_files_with_new_knots_keep_their_data(tmp_path):
    from rworld_cli.schema.paths import write_path_with_knots

    source = tmp_path / "odd\nname: x #.yaml"
    shutil.copy(WORKCELLS / "puma560" / "paths" / "reference.yaml", source)
    out = tmp_path / "out.yaml"
    write_path_with_knots(str(source), [0, 0.3, 0.7, 1.0], str(out), note="a\nb: c")
    before = parse_yaml_text(source.read_text(), "a").data
    after = parse_yaml_text(out.read_text(), "b").data
    assert after["waypoints"] == before["waypoints"] and after["units"] == before["units"]
    assert set(after) <= {"device", "units", "waypoints", "knots", "boundary"}


def test_a_urdf_in_iso_8859_1_reads_as_it_declares(tmp_path):
    text = (
        '<?xml version="1.0" encoding="ISO-8859-1"?>\n<robot name="r\u00fcb">'
        '<link name="b\u00e4se"><inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0"'
        ' iyy="0.01" iyz="0" izz="0.01"/></inertial></link>'
        '<link name="l1"><inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" '
        'iyy="0.01" iyz="0" izz="0.01"/></inertial></link>'
        '<joint name="j\u00f6" type="revolute"><parent link="b\u00e4se"/><child link="l1"/>'
        '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        "</robot>\n"
    )
    (tmp_path / "r.urdf").write_bytes(text.encode("latin-1"))
    out = run_cli(["import", "urdf", str(tmp_path / "r.urdf"), "-o", str(tmp_path / "cell")])
    assert out.exit_code == 0, out.output
    # the names the cell shows, with where (the base link's name shows nowhere: the device's)
    assert "r\u00fcb -> r_b: the device r_b" in out.output
    assert "j\u00f6 -> j_: joint r_b.j_" in out.output


@pytest.mark.parametrize(
    "element, message",
    [
        ("<mass/>", "needs 'value'"),
        ('<mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"/>', "needs 'ixy'"),
    ],
)
def test_urdf_attributes_urdf_requires_are_required(tmp_path, element, message):
    inertial = (
        element
        if "inertia " in element
        else element + '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>'
    )
    text = (
        f'<robot name="r"><link name="b"><inertial>{inertial}</inertial></link>'
        '<link name="l1"/><joint name="j" type="revolute"><parent link="b"/><child link="l1"/>'
        '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>'
    )
    (tmp_path / "r.urdf").write_text(text)
    out = run_cli(["import", "urdf", str(tmp_path / "r.urdf"), "-o", str(tmp_path / "cell")])
    assert out.exit_code == 2 and message in out.output, out.output
    assert not (tmp_path / "cell").exists()


@pytest.mark.parametrize(
    "folder", ["cell\n</script><!--\r", b"cell\xff\xfe".decode("utf-8", "surrogateescape")]
)
def test_a_run_in_a_hostile_folder_views(tmp_path, folder):
    """A folder name holding a newline, `</script>`, `<!--`, a carriage return, or bytes that are
    not UTF-8: the run's view data stays valid JSON, `rworld view` reads it back, and the page's
    embedded data parses as the same JSON."""
    import json
    import os
    import re

    root = tmp_path / folder
    os.makedirs(os.fsencode(root))
    cell = root / "puma560"
    shutil.copytree(WORKCELLS / "puma560", cell)
    out = tmp_path / "out"
    result = run_cli(
        ["simulate", str(cell), "pick_place", "-o", str(out), "--view", str(out / "a.html")]
    )
    assert result.exit_code == 0, result.output
    assert run_cli(["view", str(out), "-o", str(out / "b.html")]).exit_code == 0
    for page in ("a.html", "b.html"):
        html = (out / page).read_text(encoding="utf-8")
        [data] = re.findall(
            r'<script type="application/json" id="rworld-info">(.*?)</script>', html, re.S
        )
        info = json.loads(data)
        steps = info["devices"]["puma"]["steps"]
        assert all(
            s["where"].endswith(f"pick_place.yaml:{s['where'].rsplit(':', 1)[1]}") for s in steps
        )
        assert "\n" in steps[0]["where"] or "cell??" in steps[0]["where"]  # the name, kept

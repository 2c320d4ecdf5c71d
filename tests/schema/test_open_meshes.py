"""A vendor's open meshes said once (issue 62): the import closes what trimesh can close and
marks the rest 'surface: true'; later commands then say one note for all of them, and
nothing with the global --quiet.  Before, every command repeated each mesh's warning."""

from __future__ import annotations

import numpy as np
import trimesh
import yaml

from rworld_cli.schema.loader import load_cell
from tests.conftest import REPO

UR = REPO / "tests" / "data" / "universal_robots"
MARKED = "mesh(es) marked 'surface: true' are open surfaces"


def _import_ur20(cli, folder):
    result = cli(
        ["import", "urdf", str(UR / "ur_description" / "urdf" / "ur.urdf.xacro")]
        + ["--package-path", str(UR), "--xacro-arg", "ur_type:=ur20", "--xacro-arg", "name:=ur20"]
        + ["-o", str(folder)]
    )
    assert result.exit_code == 0, result.output
    return result


def test_the_ur20s_open_meshes_are_said_at_import_then_in_one_note(cli, tmp_path):
    cell = tmp_path / "ur20"
    imported = _import_ur20(cli, cell)
    said = [line for line in imported.output.splitlines() if "trimesh cannot close it" in line]
    assert len(said) == 3 and all("edges shared by more than two faces" in s for s in said)
    doc = yaml.safe_load((cell / "cell.yaml").read_text())
    marked = [
        link["name"]
        for link in doc["devices"][0]["links"]
        if link.get("geometry", {}).get("mesh", {}).get("surface")
    ]
    assert marked == ["upper_arm_link", "forearm_link", "wrist_3_link"]
    shown = cli(["validate", str(cell / "cell.yaml")])
    lines = [line for line in shown.output.splitlines() if "surface" in line]
    assert shown.exit_code == 0 and len(lines) == 1 and "note:" in lines[0], shown.output
    assert MARKED in lines[0] and "not closed (watertight)" not in shown.output
    quiet = cli(["--quiet", "validate", str(cell / "cell.yaml")])
    assert quiet.exit_code == 0 and MARKED not in quiet.output and "note:" not in quiet.output
    # the cell still treats them as surfaces (what the collision checks read)
    loaded = load_cell(str(cell))
    device = loaded.cell.devices["ur20"]
    assert [link.shape.closed for link in device.links] == [True, False, False, True, True, False]
    [note] = [w for w in loaded.warnings if w.severity == "note"]
    assert note.format().startswith(f"{cell / 'cell.yaml'}:")


def test_an_unmarked_open_mesh_warns_with_the_way_to_say_it_once(cli, tmp_path):
    cell = tmp_path / "ur20"
    _import_ur20(cli, cell)
    text = (cell / "cell.yaml").read_text()
    (cell / "cell.yaml").write_text(text.replace("        surface: true\n", ""))
    shown = cli(["validate", str(cell / "cell.yaml")])
    warned = [line for line in shown.output.splitlines() if "is not closed (watertight)" in line]
    assert len(warned) == 3 and all("'surface: true' in its mesh entry" in w for w in warned)
    assert MARKED not in shown.output


def test_a_mesh_with_a_hole_trimesh_can_fill_is_closed_at_import(cli, tmp_path):
    """A box link whose mesh lacks one triangle: filled, written as the link's STL, and the
    cell loads without any open-mesh word."""
    box = trimesh.creation.box(extents=[0.1, 0.2, 0.3])
    holed = trimesh.Trimesh(box.vertices, box.faces[1:], process=False)
    assert not holed.is_watertight
    holed.export(tmp_path / "holed.stl")
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(
        '<robot name="ur_arm"><link name="base"/>'
        '<link name="l1"><collision><geometry><mesh filename="holed.stl"/></geometry>'
        "</collision></link>"
        '<joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>'
        '<limit lower="-1" upper="1" velocity="1" effort="1"/></joint></robot>'
    )
    result = cli(["import", "urdf", str(urdf), "-o", str(tmp_path / "cell")])
    assert result.exit_code == 0, result.output
    assert "the mesh of 'l1' was no closed surface (3 open edges): closed, its seams" in (
        result.output
    )
    loaded = load_cell(str(tmp_path / "cell"))
    assert not [w for w in loaded.warnings if "closed" in w.message or "surface" in w.message]
    [link] = loaded.cell.devices["ur_arm"].links
    assert link.shape.closed
    closed = trimesh.load(tmp_path / "cell" / "meshes" / "l1.stl")
    np.testing.assert_allclose(closed.volume, 0.1 * 0.2 * 0.3, rtol=1e-6)  # float32 STL

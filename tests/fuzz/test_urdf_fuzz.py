"""`rworld import urdf` on seeded mutations of a small real-shaped URDF (box, cylinder, sphere and
an STL mesh; revolute, prismatic and fixed joints).

Thresholds: 0 internal errors, 0 tracebacks, 0 damaged meshes accepted, nothing written on
refusal (no cell folder, no staging debris), and every accepted cell validates with the
gravity of the cell (nothing from a name can become YAML).
"""

from __future__ import annotations

import random
import shutil
import struct

import pytest
from lxml import etree

from tests.conftest import run_cli

BASE = """<?xml version="1.0"?>
<robot name="arm">
  <link name="base">
    <inertial><origin xyz="0 0 0.05" rpy="0 0 0"/><mass value="2.0"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
    <collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision>
  </link>
  <link name="link1">
    <inertial><origin xyz="0 0 0.1" rpy="0 0 0"/><mass value="1.0"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
    <visual><geometry><cylinder radius="0.03" length="0.2"/></geometry></visual>
    <collision><origin xyz="0 0 0.1" rpy="0 0 0"/>
      <geometry><mesh filename="meshes/part.stl" scale="1 1 1"/></geometry></collision>
  </link>
  <link name="link2">
    <inertial><origin xyz="0.1 0 0" rpy="0 0 0"/><mass value="0.5"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial>
    <collision><geometry><sphere radius="0.04"/></geometry></collision>
  </link>
  <link name="tool0"/>
  <joint name="j1" type="revolute">
    <parent link="base"/><child link="link1"/>
    <origin xyz="0 0 0.1" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="20" velocity="2"/>
    <dynamics damping="0.1" friction="0.2"/>
  </joint>
  <joint name="j2" type="prismatic">
    <parent link="link1"/><child link="link2"/>
    <origin xyz="0 0 0.2" rpy="0 1.5707963 0"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="0.3" effort="50" velocity="0.5"/>
  </joint>
  <joint name="j3" type="fixed">
    <parent link="link2"/><child link="tool0"/>
    <origin xyz="0.2 0 0" rpy="0 0 0"/>
  </joint>
</robot>
"""

HOSTILE_VALUES = [
    "", "abc", "1e300", "-1e300", "nan", "inf", "-inf", "1 2", "0 0 0 0", "1e-300", "-0",
    "\u0661\u0662", "1_0", "0x10", "  3 ", "9" * 400, "true", "null", "x" * 3000,
    "a\nb: c", "link1\ngravity: [0, 0, 98.1]\n#", "{x: 1}", "- item", "*alias", "&anchor x",
    "!!python/object x", "'quoted'",
]  # fmt: skip
HOSTILE_NAMES = [
    "link1\ngravity: [0, 0, 98.1]\n#", "a: b", "x'y\"z", "#c", "- d", "\u00fc", "a b", "", "world",
    "base", "l\r\nx", "\u2028", "tab\tname",
]  # fmt: skip
SEEDS = range(4)
CASES = 60


def _mutate(rng: random.Random, text: str) -> str:
    root = etree.fromstring(text.encode())
    elements = [e for e in root.iter() if isinstance(e.tag, str)]
    kind = rng.choice(["attr", "attr", "attr", "delete", "dup", "name"])
    el = rng.choice(elements)
    if kind == "attr" and el.attrib:
        el.set(rng.choice(list(el.attrib)), rng.choice(HOSTILE_VALUES))
    elif kind == "name":
        named = [e for e in elements if "name" in e.attrib or "link" in e.attrib]
        target = rng.choice(named)
        target.set("name" if "name" in target.attrib else "link", rng.choice(HOSTILE_NAMES))
    elif kind == "delete" and el is not root:
        el.getparent().remove(el)
    elif kind == "dup" and el is not root:
        el.getparent().append(etree.fromstring(etree.tostring(el)))
    return etree.tostring(root, xml_declaration=True, encoding="utf-8").decode()


def _cube_stl() -> bytes:
    import trimesh

    return bytes(trimesh.creation.box([0.05] * 3).export(file_type="stl"))


def _damaged_mesh(rng: random.Random, good: bytes) -> bytes:
    count = struct.unpack_from("<I", good, 80)[0]
    blob = bytearray(good)
    k = rng.randrange(7)
    if k == 0:
        return b""
    if k == 1:
        return good[: rng.randrange(1, len(good))]
    if k == 2:
        return bytes(rng.randrange(256) for _ in range(rng.randrange(1, 400)))
    if k == 3:
        return b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nendloop\nendfacet\n"
    if k == 4:  # a corner that is not a number
        at = 84 + 12 + rng.randrange(count) * 50 + 4 * rng.randrange(9)
        blob[at : at + 4] = struct.pack("<f", float("nan"))
        return bytes(blob)
    if k == 5:  # a header that counts more triangles than the file holds
        blob[80:84] = struct.pack("<I", count + rng.randrange(1, 10**6))
        return bytes(blob)
    return b"\x00" * 84  # no triangles


def _import(tmp_path, text: str, mesh: bytes):
    case = tmp_path / "case"
    if case.exists():
        shutil.rmtree(case)
    (case / "meshes").mkdir(parents=True)
    (case / "robot.urdf").write_bytes(text.encode("utf-8"))
    (case / "meshes" / "part.stl").write_bytes(mesh)
    result = run_cli(["import", "urdf", str(case / "robot.urdf"), "-o", str(case / "cell")])
    assert result.exit_code in (0, 2), result.output
    assert "Traceback" not in result.output and "internal error" not in result.output
    if result.exit_code == 2:
        assert not (case / "cell").exists()
        assert sorted(p.name for p in case.iterdir()) == ["meshes", "robot.urdf"]
    else:
        loaded = run_cli(["validate", str(case / "cell"), "--json"])
        assert loaded.exit_code == 0, loaded.output
        import json

        from rworld_cli.schema.loader import load_cell

        assert load_cell(case / "cell").cell.gravity.tolist() == [0.0, 0.0, -9.81]
        assert json.loads(loaded.stdout)["valid"] is True
    return result


@pytest.mark.parametrize("seed", SEEDS)
def test_mutated_urdfs_import_or_are_refused_cleanly(tmp_path, seed):
    rng = random.Random(seed)
    good = _cube_stl()
    outcomes = {0: 0, 2: 0}
    for _ in range(CASES):
        text = BASE
        for _ in range(rng.choice([1, 1, 2, 3])):
            text = _mutate(rng, text)
        outcomes[_import(tmp_path, text, good).exit_code] += 1
    assert outcomes[0] and outcomes[2]  # the mutations reach both outcomes


@pytest.mark.parametrize("seed", SEEDS)
def test_damaged_meshes_are_refused_at_their_element(tmp_path, seed):
    rng = random.Random(1000 + seed)
    good = _cube_stl()
    for _ in range(CASES // 3):
        result = _import(tmp_path, BASE, _damaged_mesh(rng, good))
        assert result.exit_code == 2
        assert "robot.urdf:13:17:" in result.output and "part.stl" in result.output


def test_a_name_cannot_become_yaml(tmp_path):
    """The issue's case: a link named with newlines once ended a comment and set gravity."""
    text = BASE.replace('name="link1"', 'name="link1&#10;gravity: [0, 0, 98.1]&#10;#"').replace(
        'link="link1"', 'link="link1&#10;gravity: [0, 0, 98.1]&#10;#"'
    )
    result = _import(tmp_path, text, _cube_stl())
    assert result.exit_code == 0, result.output
    head = (tmp_path / "case" / "cell" / "cell.yaml").read_text().split("\nname:")[0]
    assert "\ngravity" not in head and "\\ngravity" in head  # escaped inside the comment


def test_a_long_chain_imports(tmp_path):
    n = 300
    links = "".join(
        f'<link name="l{i}"><inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" '
        f'iyy="0.01" iyz="0" izz="0.01"/></inertial></link>'
        for i in range(n + 1)
    )
    joints = "".join(
        f'<joint name="j{i}" type="revolute"><parent link="l{i}"/><child link="l{i + 1}"/>'
        f'<origin xyz="0 0 0.1"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="10" '
        f'velocity="1"/></joint>'
        for i in range(n)
    )
    assert _import(tmp_path, f'<robot name="snake">{links}{joints}</robot>', b"").exit_code == 0

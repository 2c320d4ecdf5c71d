"""Meshes are solids: a body inside a closed mesh collides; mesh distances equal primitives'."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from rworld_cli.collision.bodies import Body, pair_distance
from rworld_cli.model.cell import Box, Shape


def body(label, shape) -> Body:
    box = shape.bounding_box
    return Body(
        label, label, label, shape, box.T_owner_box[:3, 3], float(np.linalg.norm(box.half_extents))
    )


def box_shape(size) -> Shape:
    size = np.asarray(size, dtype=float)
    return Shape("box", np.eye(4), size, Box(np.eye(4), size / 2))


def mesh_shape(path, size, closed=True) -> Shape:
    size = np.asarray(size, dtype=float)
    return Shape("mesh", np.eye(4), size, Box(np.eye(4), size / 2), mesh_file=path, closed=closed)


@pytest.fixture
def cube_mesh(tmp_path):
    path = tmp_path / "cube.stl"
    trimesh.creation.box(extents=[0.4, 0.3, 0.2]).export(path)
    return path


def poses(n, seed, spread=0.4):
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, :3, :3] = Rotation.random(n, random_state=seed).as_matrix()
    T[:, :3, 3] = np.random.default_rng(seed).uniform(-spread, spread, (n, 3))
    return T


def test_a_body_buried_in_a_closed_mesh_collides(cube_mesh):
    solid = body("block", mesh_shape(cube_mesh, [0.4, 0.3, 0.2]))
    small = body("pin", box_shape([0.02, 0.02, 0.02]))
    T = np.tile(np.eye(4), (3, 1, 1))
    T[1, :3, 3] = [0.05, 0.02, 0.01]  # inside, touching no triangle
    T[2, :3, 3] = [0.5, 0.0, 0.0]  # outside: 0.5 - 0.2 - 0.01 away
    res = pair_distance(solid, small, np.tile(np.eye(4), (3, 1, 1)), T)
    assert res.buried[0] and res.buried[1] and not res.buried[2]
    assert res.overlap[:2].all()
    assert res.depth[1] == pytest.approx(0.1 - 0.01 - 0.01, abs=1e-7)  # z: at least this deep
    assert res.distance[2] == pytest.approx(0.29, abs=1e-7)  # STL holds float32 vertices
    # an open mesh cannot tell inside from outside: checked as a surface only
    surface = body("sheet", mesh_shape(cube_mesh, [0.4, 0.3, 0.2], closed=False))
    open_res = pair_distance(surface, small, np.eye(4)[None], T[1:2])
    assert not open_res.buried[0] and not open_res.overlap[0]


def test_mesh_distances_equal_the_primitive_they_mesh(cube_mesh):
    """The same box as a mesh and as a primitive, against a box at random poses."""
    mesh = body("mesh", mesh_shape(cube_mesh, [0.4, 0.3, 0.2]))
    prim = body("prim", box_shape([0.4, 0.3, 0.2]))
    other = body("other", box_shape([0.1, 0.05, 0.3]))
    T = poses(400, 3, 0.45)
    I = np.tile(np.eye(4), (400, 1, 1))
    a = pair_distance(mesh, other, I, T)
    b = pair_distance(prim, other, I, T)
    assert np.array_equal(a.overlap, b.overlap)
    sep = ~b.overlap
    assert sep.sum() > 100 and (~sep).sum() > 50
    assert np.max(np.abs(a.distance[sep] - b.distance[sep])) < 1e-7  # float32 in the STL


def test_point_triangle_distance_against_dense_sampling():
    from rworld_cli.collision.bodies import point_triangle_distance

    rng = np.random.default_rng(5)
    tri = rng.normal(size=(300, 3, 3))
    p = rng.normal(size=(300, 3)) * 2
    d = point_triangle_distance(p, tri)
    n = 60
    w = np.array([(i / n, j / n, 1 - (i + j) / n) for i in range(n + 1) for j in range(n + 1 - i)])
    pts = np.einsum("wk,fki->fwi", w, tri)
    brute = np.linalg.norm(pts - p[:, None], axis=2).min(axis=1)
    spacing = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).max(axis=1) / n
    assert np.all(d <= brute + 1e-12)  # never above a point of the triangle
    assert np.all(brute - d <= spacing)  # and within the grid's spacing of it


def test_a_mesh_of_convex_parts_is_checked_as_their_hulls(tmp_path):
    """A closed mesh made of convex parts (a box and a sphere, as a link mesh joined by 'import
    urdf') becomes two hull pieces; distances equal the triangle-by-triangle ones, or fall short of
    them by at most the hull deviation (never above); a non-convex part keeps the triangles."""
    from rworld_cli.collision.bodies import HULL_DEVIATION, convex_parts

    parts = trimesh.util.concatenate(
        [
            trimesh.creation.box(extents=[0.2, 0.1, 0.1]),
            trimesh.creation.icosphere(subdivisions=2, radius=0.06).apply_translation([0.3, 0, 0]),
        ]
    )
    path = tmp_path / "parts.stl"
    parts.export(path)
    shape = mesh_shape(path, [0.5, 0.12, 0.12])
    hulls = convex_parts(shape)
    assert hulls is not None and len(hulls) == 2
    as_hulls = Body("link", "link", "link", shape, np.array([0.1, 0, 0]), 0.3, hulls)
    as_triangles = body("link", shape)
    other = body("pin", box_shape([0.03, 0.02, 0.05]))
    T = poses(200, seed=9, spread=0.35)
    fast = pair_distance(as_hulls, other, np.tile(np.eye(4), (200, 1, 1)), T)
    exact = pair_distance(as_triangles, other, np.tile(np.eye(4), (200, 1, 1)), T)
    assert np.all(fast.distance <= exact.distance + 1e-9)
    assert np.all(fast.distance >= exact.distance - HULL_DEVIATION)
    assert np.array_equal(fast.overlap, exact.overlap)
    # an L-shaped part is not convex: its triangles stay
    ell = trimesh.boolean.union(
        [
            trimesh.creation.box(extents=[0.3, 0.1, 0.1]),
            trimesh.creation.box(extents=[0.1, 0.3, 0.1]).apply_translation([0.1, 0.1, 0]),
        ],
        engine="manifold",
    )
    ell_path = tmp_path / "ell.stl"
    ell.export(ell_path)
    assert convex_parts(mesh_shape(ell_path, [0.3, 0.3, 0.1])) is None


def test_zero_area_triangles_have_their_edges_distance():
    """A sliver (collinear corners) has no face region: its distance is its nearest edge's."""
    from rworld_cli.collision.bodies import point_triangle_distance

    sliver = np.array([[[0.0, 0, 0], [1, 0, 0], [2, 0, 0]], [[1.0, 1, 1], [1, 1, 1], [1, 1, 1]]])
    p = np.array([[0.5, 1.0, 0.0], [1.0, 1.0, 3.0]])
    with np.errstate(all="raise"):
        got = point_triangle_distance(p, sliver)
    np.testing.assert_allclose(got, [1.0, 2.0])


@pytest.mark.filterwarnings("error")
def test_a_vendor_mesh_with_slivers_loads_and_checks_without_warnings(cli, tmp_path):
    """ABB's IRB 4600 wrist (ROS-Industrial) holds zero-area triangles; they once gave NaN
    hull deviations and a numpy RuntimeWarning on every command."""
    import shutil

    from tests.conftest import REPO

    (tmp_path / "meshes").mkdir()
    shutil.copy(REPO / "tests/data/abb_irb4600/link_6.stl", tmp_path / "meshes/link_6.stl")
    (tmp_path / "cell.yaml").write_text(
        "name: wrist\nunits: {length: m, angle: deg}\nobjects:\n"
        "  - {name: wrist, mass: 1, geometry: {mesh: {file: meshes/link_6.stl}}}\n"
        "  - {name: block, mass: 1, geometry: {box: [0.1, 0.1, 0.1]}}\n"
    )
    (tmp_path / "poses.yaml").write_text(
        "units: {length: m, angle: deg}\nposes:\n  wrist: {xyz: [0, 0, 0]}\n"
        "  block: {xyz: [0.5, 0, 0]}\n"
    )
    out = cli(["validate", str(tmp_path)])
    assert out.exit_code == 0 and "warning" not in out.output.lower(), out.output
    out = cli(["clearance", str(tmp_path), "--json"])
    assert out.exit_code == 0, out.output
    import json

    [pair] = json.loads(out.stdout)["pairs"]
    assert 0.2 < pair["distance"] < 0.5


def test_convex_parts_are_kept_on_disk_by_content(tmp_path, monkeypatch):
    """A vendor link's hull parts (the deviation test costs seconds on dense meshes) are
    stored in the user's cache: read back equal without computing, a damaged entry computed
    again."""
    from rworld_cli.collision import bodies as B
    from rworld_cli.schema.loader import load_cell
    from tests.conftest import REPO

    monkeypatch.setenv("RWORLD_CACHE_DIR", str(tmp_path / "cache"))
    cell = load_cell(str(REPO / "tests/data/vendor_cells/gp7/cell.yaml")).cell
    shape = next(
        link.shape
        for link in cell.devices["motoman_gp7"].links
        if link.shape is not None and link.shape.kind == "mesh"
    )
    B._convex_parts.cache_clear()
    first = B.convex_parts(shape)
    assert first is not None
    [entry] = (tmp_path / "cache" / "meshes").glob("parts-*.npz")

    def computing(*args):
        raise AssertionError("computed, not read")

    real = B._hull_parts
    monkeypatch.setattr(B, "_hull_parts", computing)
    B._convex_parts.cache_clear()
    second = B.convex_parts(shape)
    assert len(second) == len(first)
    for (v1, a1), (v2, a2) in zip(first, second):
        np.testing.assert_array_equal(v1, v2)
        np.testing.assert_array_equal(a1, a2)
    entry.write_bytes(entry.read_bytes()[:-7])  # torn: fails authentication, a miss
    monkeypatch.setattr(B, "_hull_parts", real)
    B._convex_parts.cache_clear()
    third = B.convex_parts(shape)
    np.testing.assert_array_equal(third[0][0], first[0][0])
    B._convex_parts.cache_clear()

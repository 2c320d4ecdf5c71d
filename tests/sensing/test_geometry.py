"""Interference of sensor cells with solids: exact against overlap volumes; tolerance; broad
phase.
"""

from __future__ import annotations

import zlib

import numpy as np
import pytest
import trimesh

from rworld_cli import spatial
from rworld_cli.geometry import (
    box_triangle_overlap,
    grid_interference,
    obb_overlap,
    winding_number,
)
from rworld_cli.sensing.exact import holed_box, icosphere, truth_grid

SOLIDS = {"icosphere": icosphere, "holed_box": holed_box}


def random_pose(rng, spread=0.03):
    return spatial.make_transform(
        spatial.rpy_to_matrix(rng.uniform(-0.6, 0.6, 3)), rng.uniform(-spread, spread, 3)
    )


@pytest.mark.parametrize("solid", SOLIDS)
@pytest.mark.parametrize("counts", [(8, 8, 1), (16, 12, 1), (1, 1, 6)])
def test_zero_wrong_cells_against_overlap_volumes(solid, counts):
    vertices, faces, manifold = SOLIDS[solid]()
    rng = np.random.default_rng(
        zlib.crc32(repr((solid, counts)).encode())
    )  # str hashes change per process
    size = np.array([0.08, 0.08, 0.012]) if counts[2] == 1 else np.array([0.03, 0.03, 0.09])
    hits = cells = 0
    for _ in range(4):  # pads cutting into the solid at random poses, partly buried
        T_solid_sensor = random_pose(rng)
        T = np.linalg.inv(T_solid_sensor)
        tri = (vertices @ T[:3, :3].T + T[:3, 3])[faces]
        ours = grid_interference(size, counts, tri, tolerance=1e-9)
        truth = truth_grid(size, counts, manifold.transform(T[:3, :].tolist()))
        assert (ours != truth).sum() == 0
        hits, cells = hits + truth.sum(), cells + truth.size
    assert 0 < hits < cells  # the trials met the solid and missed it too


def test_buried_cells_count_surface_only_methods_miss_them():
    """A pad entirely inside the holed box meets no triangle; every cell still interferes."""
    vertices, faces, manifold = holed_box()
    T = np.linalg.inv(
        spatial.make_transform(p=[0.0, 0.0, -0.027])
    )  # pad inside the lower wall, below the hole
    tri = (vertices @ T[:3, :3].T + T[:3, 3])[faces]
    size, counts = np.array([0.08, 0.08, 0.004]), (8, 8, 1)
    hit = grid_interference(size, counts, tri, tolerance=1e-9)
    assert hit.all()
    touching_surface = np.zeros(counts, dtype=bool)  # what a surface-only test sees
    lo, d = np.array([-0.04, -0.04, 0.0]), size / np.array(counts)
    for idx in np.ndindex(*counts):
        c = lo + (np.array(idx) + 0.5) * d
        touching_surface[idx] = box_triangle_overlap(
            np.repeat(c[None], len(tri), 0), np.repeat((d / 2)[None], len(tri), 0), tri
        ).any()
    assert not touching_surface.any()
    assert truth_grid(size, counts, manifold.transform(T[:3, :].tolist())).all()


@pytest.mark.parametrize(
    "gap, touching", [(0.0, True), (0.5e-6, True), (2e-6, False), (1e-3, False)]
)
def test_touching_is_decided_by_the_tolerance(gap, touching):
    """A box face parallel to the pad's base face, ``gap`` below it; tolerance 1 um."""
    box = trimesh.creation.box(extents=[0.2, 0.2, 0.1])
    box.apply_translation([0, 0, -0.05 - gap])  # top face at z = -gap
    tri = np.asarray(box.vertices)[box.faces]
    hit = grid_interference(np.array([0.05, 0.05, 0.01]), (4, 4, 1), tri, tolerance=1e-6)
    assert hit.all() == touching and hit.any() == touching


def test_box_triangle_cases():
    h = np.array([[0.5, 0.5, 0.5]])
    c = np.zeros((1, 3))
    cases = {
        "inside": ([0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1], True),
        "crossing a face": ([0.3, 0, 0], [0.9, 0, 0], [0.3, 0.3, 0.2], True),
        "beside": ([0.6, 0, 0], [0.9, 0, 0], [0.7, 0.3, 0.2], False),
        "only an edge axis separates": ([1.2, 0, 0], [0, 1.2, 0], [0.6, 0.6, 0.4], False),
        "spanning the whole box": ([-5, -5, 0], [5, -5, 0], [0, 5, 0], True),
        "degenerate, a point inside": ([0.1, 0.1, 0.1], [0.1, 0.1, 0.1], [0.1, 0.1, 0.1], True),
    }
    for name, (a, b, cc, expected) in cases.items():
        tri = np.array([[a, b, cc]], float)
        assert box_triangle_overlap(c, h, tri)[0] == expected, name


def test_winding_number_inside_outside():
    vertices, faces, _ = holed_box()
    tri = vertices[faces]
    points = np.array(
        [[0, 0, -0.025], [0, 0, 0.0], [0.045, 0.0, 0.0], [0.2, 0, 0]]
    )  # wall, hole, side wall, outside
    w = winding_number(points, tri)
    np.testing.assert_allclose(w, [1, 0, 1, 0], atol=1e-9)


def test_winding_number_equals_the_solid_angle_sum_and_the_mesh_containment():
    """The component form against Van Oosterom & Strackee written with vectors, on many blocks
    (more points than a block holds), and against trimesh's containment test."""
    vertices, faces, _ = holed_box()
    tri = vertices[faces]
    points = np.random.default_rng(8).uniform(-0.07, 0.07, (700, 3))
    a, b, c = (tri[None, :, k, :] - points[:, None, :] for k in range(3))
    la, lb, lc = (np.linalg.norm(x, axis=-1) for x in (a, b, c))
    num = np.einsum("mfi,mfi->mf", a, np.cross(b, c))
    den = (
        la * lb * lc
        + np.einsum("mfi,mfi->mf", a, b) * lc
        + np.einsum("mfi,mfi->mf", b, c) * la
        + np.einsum("mfi,mfi->mf", c, a) * lb
    )
    reference = (2.0 * np.arctan2(num, den)).sum(axis=1) / (4 * np.pi)
    w = winding_number(points, tri)
    assert np.abs(w - reference).max() < 1e-12
    inside = trimesh.Trimesh(vertices, faces).contains(points)
    assert np.array_equal(w > 0.5, inside)
    assert winding_number(np.empty((0, 3)), tri).shape == (0,)


def test_obb_broad_phase_agrees_with_overlap_volumes():
    import manifold3d as m3

    rng = np.random.default_rng(3)
    Ta, Tb, ha, hb, truth = [], [], [], [], []
    for _ in range(200):
        A, B = random_pose(rng, 0.2), random_pose(rng, 0.2)
        a, b = rng.uniform(0.02, 0.15, 3), rng.uniform(0.02, 0.15, 3)
        ma = m3.Manifold.cube((2 * a).tolist(), center=True).transform(A[:3, :].tolist())
        mb = m3.Manifold.cube((2 * b).tolist(), center=True).transform(B[:3, :].tolist())
        Ta.append(A), Tb.append(B), ha.append(a), hb.append(b)
        truth.append((ma ^ mb).volume() > 1e-15)
    got = obb_overlap(np.array(Ta), np.array(ha), np.array(Tb), np.array(hb))
    assert (got == np.array(truth)).all()

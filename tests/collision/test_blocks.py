"""Batched distances over a vendor's link meshes (issue 46's GP7 plan: 7.8 GB before): queries
are sorted widest first and blocked under a vertex budget, each block's pieces padded only to
its widest. The answers are those of each query asked alone, whatever the budget."""

from __future__ import annotations

import numpy as np
import pytest

from rworld_cli import spatial
from rworld_cli.api.robots import import_urdf
from rworld_cli.collision import bodies as bodies_module
from rworld_cli.collision.bodies import _gather, _piece_table, collision_model, distances
from rworld_cli.schema.loader import load_cell
from tests.conftest import REPO

MOTOMAN = REPO / "tests" / "data" / "motoman"


@pytest.fixture(scope="module")
def gp7_bodies(tmp_path_factory):
    folder = tmp_path_factory.mktemp("gp7") / "cell"
    gp7 = MOTOMAN / "motoman_gp7_support" / "urdf" / "gp7.xacro"
    import_urdf(str(gp7), str(folder), package_paths=[str(MOTOMAN)], overlap_states=0)
    model = collision_model(load_cell(str(folder)).cell)
    return list(model.bodies)


def random_queries(bodies, count, seed):
    rng = np.random.default_rng(seed)
    single = [i for i, b in enumerate(bodies) if b.single_piece]
    I, J = rng.choice(single, count), rng.choice(single, count)
    T = np.zeros((2, count, 4, 4))
    for side in range(2):
        T[side] = np.eye(4)
        T[side, :, :3, :3] = [spatial.rpy_to_matrix(a) for a in rng.uniform(-3, 3, (count, 3))]
        T[side, :, :3, 3] = rng.uniform(-0.3, 0.3, (count, 3))
    return I, J, T[0], T[1]


def test_blocks_give_each_query_its_own_answer(gp7_bodies, monkeypatch):
    counts = _piece_table(gp7_bodies).counts
    assert counts.max() > 1000  # the vendor's hulls: thousands of vertices
    I, J, TI, TJ = random_queries(gp7_bodies, 300, seed=3)
    batched = distances(gp7_bodies, I, J, TI, TJ)
    monkeypatch.setattr(bodies_module, "VERTEX_BUDGET", 20_000)  # many blocks of 64 to 2000
    small = distances(gp7_bodies, I, J, TI, TJ)
    np.testing.assert_array_equal(small.distance, batched.distance)
    np.testing.assert_array_equal(small.depth, batched.depth)
    for q in range(0, 300, 7):
        alone = distances(gp7_bodies, I[q : q + 1], J[q : q + 1], TI[q : q + 1], TJ[q : q + 1])
        assert alone.distance[0] == pytest.approx(batched.distance[q], abs=1e-12)
        assert alone.depth[0] == pytest.approx(batched.depth[q], abs=1e-12)
        np.testing.assert_allclose(alone.point_a[0], batched.point_a[q], atol=1e-12)
    assert (batched.depth > 0).any() and (batched.distance > 0).any()


def test_a_block_of_small_pieces_is_not_padded_to_the_largest_hull(gp7_bodies):
    small = [
        i for i, b in enumerate(gp7_bodies) if b.single_piece and len(b.local_piece.vertices) < 600
    ]
    widest = max(len(gp7_bodies[i].local_piece.vertices) for i in small)
    pieces = _gather(gp7_bodies, np.array(small), np.broadcast_to(np.eye(4), (len(small), 4, 4)))
    assert pieces.vertices.shape[1] == widest < _piece_table(gp7_bodies).counts.max()

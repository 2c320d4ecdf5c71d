"""MotionBenchMaker's Panda problems as vendored (``tests/data/mbm``, SOURCE.md there) and read
as rworld cells (:mod:`tests.planning.mbm_cells`; ``bench/motion.py --mbm`` plans them): the
archive holds its 7 x 100 problems, and a problem of each family loads as a cell whose start
and goal are free by rworld's check, with the scene's primitives where MoveIt puts them."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from tests.planning import mbm_cells


def test_the_archive_is_the_one_vendored_and_holds_every_problem():
    digest = hashlib.sha256(mbm_cells.ARCHIVE.read_bytes()).hexdigest()
    assert digest in (mbm_cells.ARCHIVE.parent / "SOURCE.md").read_text()
    count = {family: 0 for family in mbm_cells.FAMILIES}
    for problem in mbm_cells.problems(limit=100):
        count[problem["family"]] += 1
        assert len(problem["start"]) == len(problem["goal"]) == 7
    assert count == {family: 100 for family in mbm_cells.FAMILIES}


@pytest.fixture(scope="module")
def robot(tmp_path_factory):
    return mbm_cells.robot_cell(tmp_path_factory.mktemp("mbm"))


@pytest.mark.parametrize("family", mbm_cells.FAMILIES)
def test_a_problem_of_each_family_is_a_cell_with_free_ends(family, robot, tmp_path):
    from rworld_cli.api import device_context
    from rworld_cli.collision.bodies import collision_model
    from rworld_cli.planning.motion import WorldChecks

    problem = next(mbm_cells.problems([family], limit=1))
    folder = mbm_cells.write_cell(problem, tmp_path / family, robot)
    ctx = device_context(str(folder), "panda")
    cell = ctx.world.cell
    assert {o["name"] for o in problem["objects"]} == set(cell.objects)
    for item in problem["objects"]:  # each primitive where the scene put it
        assert np.allclose(ctx.world.T_world(item["name"]), item["pose"], atol=1e-9)
    lower, upper = ctx.device.limit_array("lower"), ctx.device.limit_array("upper")
    for q in (problem["start"], problem["goal"]):
        assert (np.array(q) >= lower).all() and (np.array(q) <= upper).all()
    checks = WorldChecks(ctx.world, collision_model(cell), "panda", 1e-3)
    usable, why = checks.problem(np.array(problem["start"]), np.array(problem["goal"]))
    assert why is None and len(usable) == 1, why


def test_cylinders_walked_compiled_measure_as_every_triangle_does(robot, tmp_path):
    """The cans of a shelf (cylinders) against the Panda's links (meshes checked triangle by
    triangle) go through the compiled tree walk (the cylinder's own GJK support, placed in the
    mesh's frame): each distance equals the least over every triangle measured alone, in
    world, to 1e-11 m; and the arm's states are free by the fused free-only check exactly
    where the nearest check says so."""
    from scipy.spatial.transform import Rotation

    from rworld_cli.api import device_context
    from rworld_cli.collision import bodies as B
    from rworld_cli.collision import convex

    problem = next(mbm_cells.problems(["bookshelf_small"], limit=1))
    folder = mbm_cells.write_cell(problem, tmp_path / "shelf", robot)
    ctx = device_context(str(folder), "panda")
    model = B.collision_model(ctx.world.cell)
    cylinders = [b for b in model.bodies if b.shape.kind == "cylinder"]
    links = [b for b in model.bodies if b.is_mesh]
    assert cylinders and links and all(b.walk_side is not None for b in cylinders)
    rng = np.random.default_rng(3)
    K = 60
    for cylinder in cylinders[:2]:
        for link in links[::3]:
            Ta = np.tile(np.eye(4), (K, 1, 1))
            Ta[:, :3, :3] = Rotation.random(K, random_state=rng.integers(1 << 30)).as_matrix()
            Tb = np.tile(np.eye(4), (K, 1, 1))
            Tb[:, :3, :3] = Rotation.random(K, random_state=rng.integers(1 << 30)).as_matrix()
            Tb[:, :3, 3] = rng.normal(scale=0.08, size=(K, 3))
            walked = B.pair_distance(link, cylinder, Ta, Tb)
            tri = link._triangles
            world = np.einsum("kij,tvj->ktvi", Ta[:, :3, :3], tri) + Ta[:, None, None, :3, 3]
            every = convex.distance(
                convex.triangles(world.reshape(-1, 3, 3)),
                cylinder.pieces(Tb).take(np.repeat(np.arange(K), len(tri))),
            ).distance.reshape(K, len(tri))
            apart = every.min(axis=1) > 0
            assert apart.sum() > K // 4 and (~apart).sum() > 0
            assert np.allclose(walked.distance[apart], every.min(axis=1)[apart], atol=1e-11)
            assert (walked.distance[~apart] == 0).all()
    # the arm's states: the fused free-only check (cylinders in its one compiled call) says
    # free exactly where the nearest check, every pair measured, finds nothing within the
    # margin
    from rworld_cli.collision.configurations import ConfigurationChecker

    checker = ConfigurationChecker(ctx.world, model, "panda", tolerance=1e-3, clearance=0.005)
    assert checker._fused is not None and not len(checker._fused["rest"])
    lower, upper = ctx.device.limit_array("lower"), ctx.device.limit_array("upper")
    Q = rng.uniform(lower, upper, size=(300, 7))
    fast = checker.check(Q, nearest=False)
    every = checker.check(Q)
    assert (fast.free == every.free).all() and 30 < fast.free.sum() < 290

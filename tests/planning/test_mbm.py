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

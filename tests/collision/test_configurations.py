"""Configuration checks (``collision/configurations.py``) against every pair's exact distance.

At random joint states of the example Puma and of a vendor robot (non-convex meshes beside a
holed plate): the nearest pair and its signed distance equal the least of ``rworld
clearance``'s pairs (every pair measured, no broad phase) over the pairs the device may not
touch; and ``nearest=False`` (free or not, what a planner asks) decides every state alike.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from rworld_cli.collision.bodies import collision_model
from rworld_cli.collision.configurations import ConfigurationChecker
from rworld_cli.collision.static import pair_clearances
from rworld_cli.schema.loader import load_cell
from rworld_cli.world.tree import World

REPO = Path(__file__).resolve().parents[2]


def checker(cell_file: Path, **options):
    loaded = load_cell(str(cell_file))
    cell = getattr(loaded, "cell", loaded)
    world, model = World(cell), collision_model(cell)
    device = next(iter(cell.devices))
    limits = np.array(
        [(j.limits.lower, j.limits.upper) for j in cell.devices[device].joints], dtype=float
    )
    limits = np.clip(limits, -np.pi, np.pi)
    return world, model, device, limits, ConfigurationChecker(world, model, device, **options)


@pytest.mark.parametrize(
    "cell_file, states",
    [
        (REPO / "workcells/puma560/cell.yaml", 24),
        (REPO / "tests/data/vendor_cells/gp7/cell.yaml", 6),
    ],
)
def test_the_nearest_pair_is_every_pairs_least(cell_file, states):
    world, model, device, limits, check = checker(cell_file)
    q = np.random.default_rng(5).uniform(limits[:, 0], limits[:, 1], (states, len(limits)))
    report = check.check(q)
    index = model.index()
    for k in range(states):
        world.set_joints(device, q[k])
        pairs = [
            p
            for p in pair_clearances(world, model)
            if p.allowed is None and (check.moving[index[p.a]] or check.moving[index[p.b]])
        ]
        signed = [p.distance if p.distance > 0 else -p.depth for p in pairs]
        least = int(np.argmin(signed))
        assert report.distance[k] == pytest.approx(signed[least], abs=1e-9)
        labels = {model.bodies[i].label for i in report.pair[k]}
        # another pair may tie with it (two links touching the same part)
        tied = [{p.a, p.b} for p, s in zip(pairs, signed) if abs(s - signed[least]) <= 1e-9]
        assert labels in tied
        collided = any((s < -check.tolerance) or p.buried for p, s in zip(pairs, signed))
        assert report.free[k] == (not collided)
    assert (~report.free).any() and report.free.any()


def test_free_only_decides_alike_with_a_clearance():
    _, _, _, limits, check = checker(
        REPO / "tests/data/vendor_cells/iiwa14/cell.yaml", clearance=0.01
    )
    q = np.random.default_rng(6).uniform(limits[:, 0], limits[:, 1], (24, len(limits)))
    full, quick = check.check(q), check.check(q, nearest=False)
    np.testing.assert_array_equal(full.free, quick.free)
    assert (~full.free).any() and full.free.any()
    within = full.distance <= 0.01
    np.testing.assert_allclose(quick.distance[within], full.distance[within], atol=1e-9)
    assert (quick.distance[~within] > 0.01).all()

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


@pytest.mark.parametrize("cell", ["tx2_60", "iiwa14", "gp7"])
def test_the_compiled_walk_decides_as_the_exact_distances(cell):
    """``nearest=False`` walks each pair's trees and measures their leaves in one compiled
    call (``compiled_bvh.contacts``): at 40 random states of each vendor robot, and at the
    two ends of the last of 12 bisections (1/4096 of the way) towards the first contact on
    lines from 40 free states to colliding ones, it decides as the exact nearest distances
    do, and its distances of touches (overlaps within the tolerance) are theirs."""
    _, _, _, limits, check = checker(REPO / "tests/data/vendor_cells" / cell / "cell.yaml")
    rng = np.random.default_rng(11)
    q = rng.uniform(limits[:, 0], limits[:, 1], (240, len(limits)))
    first = check.check(q, nearest=False).free
    free, hit = q[first][:40], q[~first][:40]
    count = min(len(free), len(hit))
    free, hit = free[:count], hit[:count]
    lo, hi = np.zeros(count), np.ones(count)
    for _ in range(12):
        mid = 0.5 * (lo + hi)
        bad = ~check.check(free + mid[:, None] * (hit - free), nearest=False).free
        hi, lo = np.where(bad, mid, hi), np.where(bad, lo, mid)
    edge = [free + s[:, None] * (hit - free) for s in (lo, hi)]
    states = np.concatenate([q[:40], *edge])
    exact, quick = check.check(states), check.check(states, nearest=False)
    np.testing.assert_array_equal(quick.free, exact.free)
    assert quick.free.sum() > 30 and (~quick.free).sum() > 30
    touch = exact.free & (exact.distance <= 0)
    np.testing.assert_allclose(quick.distance[touch], exact.distance[touch], atol=1e-9)


def test_free_only_decides_alike_with_a_clearance():
    _, _, _, limits, check = checker(
        REPO / "tests/data/vendor_cells/iiwa14/cell.yaml", clearance=0.01
    )
    q = np.random.default_rng(6).uniform(limits[:, 0], limits[:, 1], (24, len(limits)))
    full, quick = check.check(q), check.check(q, nearest=False)
    np.testing.assert_array_equal(full.free, quick.free)
    assert (~full.free).any() and full.free.any()
    within = full.distance <= 0.01
    # exact where nothing collides; a collision's depth only as deep as the decision needs
    # (at least the tolerance, never deeper than the deepest pair)
    shallow = within & (full.distance >= -check.tolerance)
    np.testing.assert_allclose(quick.distance[shallow], full.distance[shallow], atol=1e-9)
    deep = full.distance < -check.tolerance
    assert deep.any()
    assert (quick.distance[deep] < -check.tolerance).all()
    assert (quick.distance[deep] >= full.distance[deep] - 1e-9).all()
    assert (quick.distance[~within] > 0.01).all()


def test_a_segment_is_free_exactly_when_dense_samples_find_no_contact():
    """Random straight joint-space segments of the Puma in its cell: the segment check (a few
    hundred exact queries, with the guarantee between them) against 2 001 states along each
    segment.  Where the dense states find a contact, the segment check finds one no later;
    where it says free, no dense state collides."""
    _, _, _, limits, check = checker(REPO / "workcells/puma560/cell.yaml")
    rng = np.random.default_rng(1)
    s = np.linspace(0.0, 1.0, 2001)
    colliding = 0
    for _ in range(60):
        q0, q1 = rng.uniform(limits[:, 0], limits[:, 1], (2, len(limits)))
        segment = check.check_segment(q0, q1)
        dense = check.check(q0 + s[:, None] * (q1 - q0), nearest=False)
        assert not segment.unresolved
        if dense.free.all():  # free, or a contact between the dense states: one there
            if not segment.free:
                at = q0 + segment.first * (q1 - q0)
                assert not check.check(at[None], nearest=False).free[0]
        else:
            colliding += 1
            assert not segment.free
            assert segment.first <= s[~dense.free].min() + 1e-12
    assert colliding >= 4


@pytest.mark.parametrize(
    "cell_file",
    [
        REPO / "workcells/puma560/cell.yaml",
        REPO / "tests/data/vendor_cells/gp7/cell.yaml",
        REPO / "tests/data/motion/panda_pair/cell.yaml",
    ],
)
def test_the_chains_poses_are_the_world_trees(cell_file):
    """The checker's poses by the device's chain (fixed products taken once) against the world
    tree's, every body frame in a pair, at random states: to 1e-12 m (the products' order
    differs in rounding only); the Panda pair's hand and fingers hang off its last link."""
    world, _, device, limits, check = checker(cell_file)
    assert check._chain is not None
    q = np.random.default_rng(4).uniform(limits[:, 0], limits[:, 1], (16, len(limits)))
    ours = check.poses(q)
    frames = sorted({check.model.bodies[k].frame for k in check.pairs.ravel()})
    theirs = world.T_world_frames(frames, {device: q})
    assert len(frames) > len(check._frames) > 3
    for frame in frames:
        assert np.abs(ours[frame] - theirs[frame]).max() < 1e-12, frame


@pytest.mark.parametrize(
    "cell_file",
    [
        REPO / "workcells/puma560/cell.yaml",
        REPO / "tests/data/vendor_cells/gp7/cell.yaml",
        REPO / "tests/data/motion/panda_pair/cell.yaml",
    ],
)
def test_the_generated_chain_places_the_kernels_bodies_as_the_world_tree(cell_file):
    """The planner's poses of the fused table's bodies (one generated program of the chain,
    its fixed offsets embedded) against the world tree's at random states: rotations and
    origins to 1e-12 (DH and joint-frame chains; the Panda's hand off its last link)."""
    world, _, device, limits, check = checker(cell_file)
    q = np.random.default_rng(7).uniform(limits[:, 0], limits[:, 1], (16, len(limits)))
    ours = check._packed_by_chain(q)
    frames = check._fused["frames"]
    theirs = world.T_world_frames(frames, {device: q})
    assert ours is not None and len(check._chain_plan[1]) > 3  # moving bodies among them
    for u, frame in enumerate(frames):
        T = np.broadcast_to(theirs[frame], (len(q), 4, 4))
        rows = np.concatenate([T[:, :3, :3].reshape(-1, 9), T[:, :3, 3]], axis=1)
        assert np.abs(ours[:, u] - rows).max() < 1e-12, frame


@pytest.mark.parametrize(
    "cell_file, clearance",
    [
        (REPO / "tests/data/vendor_cells/iiwa14/cell.yaml", 0.0),
        (REPO / "tests/data/vendor_cells/iiwa14/cell.yaml", 0.01),
        (REPO / "tests/data/vendor_cells/gp7/cell.yaml", 0.0),
        (REPO / "tests/data/motion/panda_pair/cell.yaml", 0.006),
    ],
)
def test_free_decides_every_state_as_the_check(cell_file, clearance):
    """``free`` (the planner's question: the kernel's statuses read directly, the states an
    overlap leaves open sent on) against ``check``'s exact nearest distances, at random
    states and at the ends of 12 bisections towards the first contact (or the clearance) on
    lines from free states to states that are not: the same answer at every state."""
    _, _, _, limits, check = checker(cell_file, clearance=clearance)
    assert not len(check._fused["rest"])  # every pair in the kernel: its statuses decide
    rng = np.random.default_rng(12)
    q = rng.uniform(limits[:, 0], limits[:, 1], (120, len(limits)))
    first = check.check(q, nearest=False).free
    free, hit = q[first][:25], q[~first][:25]
    count = min(len(free), len(hit))
    free, hit = free[:count], hit[:count]
    lo, hi = np.zeros(count), np.ones(count)
    for _ in range(12):  # the boundary found by the free-only check; judged below exactly
        mid = 0.5 * (lo + hi)
        bad = ~check.check(free + mid[:, None] * (hit - free), nearest=False).free
        hi, lo = np.where(bad, mid, hi), np.where(bad, lo, mid)
    states = np.concatenate([q[:40], *[free + s[:, None] * (hit - free) for s in (lo, hi)]])
    exact = check.check(states).free
    np.testing.assert_array_equal(check.free(states), exact)
    assert exact.sum() > 20 and (~exact).sum() > 20


def test_a_blend_is_free_exactly_when_dense_samples_on_its_curve_find_no_contact():
    """Random corners of the Puma in its cell blended by quadratic Bezier curves (a planned
    path's blends): the blend check against 2 001 states along each curve, as the segment
    check is tested.  And a blend whose corner lies on its chord is that straight segment:
    the two checks decide alike."""
    _, _, _, limits, check = checker(REPO / "workcells/puma560/cell.yaml")
    rng = np.random.default_rng(2)
    s = np.linspace(0.0, 1.0, 2001)[:, None]
    colliding = free = 0
    for _ in range(60):
        p0, corner, p2 = rng.uniform(limits[:, 0], limits[:, 1], (3, len(limits)))
        corner = p0 + (corner - p0) * 0.6 + (p2 - p0) * 0.2  # a corner, not far off the chord
        blend = check.check_blend(p0, corner, p2)
        curve = (1 - s) ** 2 * p0 + 2 * s * (1 - s) * corner + s**2 * p2
        dense = check.check(curve, nearest=False)
        assert not blend.unresolved
        if dense.free.all():
            free += blend.free
            if not blend.free:  # a contact between the dense states: it is one
                u = blend.first
                at = (1 - u) ** 2 * p0 + 2 * u * (1 - u) * corner + u**2 * p2
                assert not check.check(at[None], nearest=False).free[0]
        else:
            colliding += 1
            assert not blend.free
            assert blend.first <= s[~dense.free, 0].min() + 1e-12
        mid = (p0 + p2) / 2  # on the chord: the segment itself
        assert check.check_blend(p0, mid, p2).free == check.check_segment(p0, p2).free
    assert colliding >= 4 and free >= 4


def test_a_segment_through_the_plate_stops_at_it():
    _, model, _, _, check = checker(REPO / "tests/data/vendor_cells/iiwa14/cell.yaml")
    down = np.radians([[0, 40, 0, -80, 0, 50, 0], [0, 40, 0, -90, 0, 50, 0]])
    assert check.check(down[:1], nearest=False).free.all()
    segment = check.check_segment(down[0], down[1])
    assert not segment.free and 0 < segment.first < 1
    assert {model.bodies[i].label for i in segment.pair} == {
        "plate",
        "kuka_lbr_iiwa_14_r820.link_7",
    }
    # the state found is a contact, and the segment before it is clear
    at = down[0] + segment.first * (down[1] - down[0])
    assert not check.check(at[None], nearest=False).free[0]
    assert check.check_segment(down[0], down[0] + 0.9 * segment.first * (down[1] - down[0])).free


def test_an_arm_inside_a_closed_solid_is_buried_for_the_compiled_check(tmp_path):
    """An enclosure modelled as a closed solid (a 3 m box with a dent in its top, so not
    convex: checked by its triangles) around the whole iiwa: its links touch none of the
    triangles, yet each lies inside the solid.  The compiled free-only check finds them
    buried and not free (its witness points in the box, then the winding number), as the
    exact check does (where it gets to the enclosure's pairs)."""
    import shutil

    import trimesh

    cell = tmp_path / "iiwa14"
    shutil.copytree(REPO / "tests/data/vendor_cells/iiwa14", cell)
    hood = trimesh.creation.box(extents=[3.0, 3.0, 3.0]).subdivide().subdivide()
    top = np.flatnonzero(np.isclose(hood.vertices[:, 2], 1.5))
    centre = top[np.argmin(np.linalg.norm(hood.vertices[top, :2], axis=1))]
    hood.vertices[centre, 2] -= 0.3  # a dent: not convex
    assert hood.is_watertight
    hood.export(cell / "meshes" / "hood.stl")
    text = (
        (cell / "cell.yaml")
        .read_text()
        .replace(
            "objects:\n",
            "objects:\n  - name: hood\n    geometry: {mesh: {file: meshes/hood.stl, units: m}}\n",
        )
    )
    (cell / "cell.yaml").write_text(text)
    poses = cell / "poses.yaml"
    poses.write_text(poses.read_text() + "  hood: {xyz: [0, 0, 0.5]}\n")
    _, model, _, limits, check = checker(cell / "cell.yaml")
    assert check._fused is not None
    assert next(b for b in model.bodies if b.label == "hood").is_mesh
    q = np.random.default_rng(4).uniform(limits[:, 0], limits[:, 1], (16, len(limits)))
    exact, quick = check.check(q), check.check(q, nearest=False)
    np.testing.assert_array_equal(quick.free, exact.free)
    assert exact.buried.all() and not quick.free.any()
    # the free-only check stops at a state's first collision: a link deep in the table may
    # come before the enclosure, and then the state is not said to be buried too
    assert quick.buried.sum() >= 12 and not (quick.buried & ~exact.buried).any()


@pytest.mark.parametrize("cell", ["iiwa14", "gp7"])
def test_rows_in_one_compiled_call_give_what_pair_by_pair_walks_give(cell, monkeypatch):
    """A segment check's measurements (each pair at its own state, exact up to its own limit)
    in one compiled call (``compiled_bvh.pair_rows``) equal the pair by pair walks they
    replace, to the last bit: at 60 random states of each vendor robot and near contacts,
    every pair, limits from 0 to 0.3 m, signed distances and buried flags alike."""
    from rworld_cli.collision import compiled_bvh

    _, _, _, limits, check = checker(REPO / "tests/data/vendor_cells" / cell / "cell.yaml")
    rng = np.random.default_rng(3)
    q = rng.uniform(limits[:, 0], limits[:, 1], (60, len(limits)))
    P = len(check.pairs)
    at = np.repeat(np.arange(len(q)), P)
    pair = np.tile(np.arange(P), len(q))
    within = rng.uniform(0.0, 0.3, len(at))
    fast = check._signed(q, pair, at, within)
    monkeypatch.setattr(compiled_bvh, "pair_rows", lambda *args: None)
    slow = check._signed(q, pair, at, within)
    np.testing.assert_array_equal(fast[0], slow[0])
    np.testing.assert_array_equal(fast[1], slow[1])
    assert (fast[0] < 0).any() and (fast[0] < within).any() and (fast[0] == within).any()

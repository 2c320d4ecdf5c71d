"""Programs on features (issue 36): targets from the features' geometry, resolved when the
program runs, moving with every calibration of their owner; bad steps located."""

from __future__ import annotations

import hashlib
import shutil

import numpy as np
import pytest

from rworld_cli import spatial
from rworld_cli.api import simulate_run
from rworld_cli.model.cell import Feature
from rworld_cli.world.feature_targets import (
    SPINS,
    along,
    feature_frame,
    in_plane_axes,
    outward_frame,
    plane_coordinates,
    spun,
)
from tests.conftest import WORKCELLS

PROBING = WORKCELLS / "probing"


def _rotation(T):
    R = T[:3, :3]
    return np.allclose(R.T @ R, np.eye(3), atol=1e-12) and np.isclose(np.linalg.det(R), 1.0)


def test_feature_frames_follow_the_definitions():
    rng = np.random.default_rng(3)
    for _ in range(50):
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        p = rng.normal(size=3)
        plane = Feature("o.f", "o", "plane", p, n)
        at, standoff = rng.normal(size=2) * 0.1, float(rng.uniform(0, 0.1))
        T = feature_frame(plane, at, standoff)
        u, v = in_plane_axes(n)
        assert _rotation(T) and abs(u @ n) < 1e-12 and np.allclose(np.cross(n, u), v)
        assert np.allclose(T[:3, 2], -n)  # the tool points into the surface
        assert np.allclose(T[:3, 3], p + at[0] * u + at[1] * v + standoff * n)
        assert np.allclose(plane_coordinates(plane, p + at[0] * u + at[1] * v + 0.3 * n), at)
        turned = spun(T, "plane", SPINS)  # the free turn keeps the point and the axis
        assert np.allclose(turned[:, :3, 3], T[:3, 3]) and np.allclose(turned[:, :3, 2], -n)
        assert np.allclose(along(T, standoff)[:3, 3], p + at[0] * u + at[1] * v)
        line = Feature("o.e", "o", "line", p, n)
        com = rng.normal(size=3)
        L = feature_frame(line, 0.05, standoff, com)
        towards = com - (p + 0.05 * n)
        towards -= (towards @ n) * n
        assert _rotation(L) and np.allclose(L[:3, 0], n)  # x along the line
        assert np.allclose(L[:3, 2], towards / np.linalg.norm(towards))  # z at the material
        assert np.allclose(L[:3, 3], p + 0.05 * n - standoff * L[:3, 2])
        line_turned = spun(L, "line", SPINS)  # about the line: x stays
        assert np.allclose(line_turned[:, :3, 0], n) and np.allclose(
            line_turned[:, :3, 3], L[:3, 3]
        )
        O = outward_frame(Feature("o.t", "o", "circle", p, n, 0.01))
        assert _rotation(O) and np.allclose(O[:3, 2], n) and np.allclose(O[:3, 3], p)


def test_peg_in_hole_on_features_puts_the_tip_at_the_depth_on_the_axis():
    loaded, result = simulate_run(str(PROBING), "peg_in_hole")
    assert result.ok
    cell = loaded.cell
    release = next(e for e in result.events if e.kind == "release")
    T_world_peg = np.array(release.tree["T_world_child"])
    tip, hole = cell.features["peg.tip"], cell.features["plate.hole1"]
    from rworld_cli.world.tree import World

    T_world_plate = World(cell).T_world("plate")
    rim = T_world_plate[:3, :3] @ hole.point + T_world_plate[:3, 3]
    axis = T_world_plate[:3, :3] @ hole.direction
    assert np.allclose(T_world_peg[:3, :3] @ tip.point + T_world_peg[:3, 3], rim - 0.010 * axis)
    assert np.allclose(T_world_peg[:3, :3] @ tip.direction, -axis)  # the tip points in
    # every move of the insert step is recorded for the exporters, on the hole
    inserted = [r for r in result.resolved["puma"] if r.step.kind == "insert"]
    assert [r.move.motion for r in inserted] == ["joint", "linear"]
    assert {r.move.target for r in inserted} == {"plate.hole1"}
    grasp = next(e for e in result.events if e.kind == "grasp")
    T_tcp_peg = np.linalg.solve(grasp.tree["T_world_parent"], grasp.tree["T_world_child"])
    T_world_base = World(cell).T_world("puma")
    T_peg_there = T_world_base @ inserted[0].move.T_base_tcp @ T_tcp_peg
    above = T_peg_there[:3, :3] @ tip.point + T_peg_there[:3, 3]
    assert np.allclose(above, rim + 0.050 * axis, atol=1e-6)  # the approach: 50 mm above the rim


def _digest(folder):
    return {
        p.name: hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted((folder / "programs").glob("*.yaml"))
    }


def test_calibration_moves_every_feature_target_by_exactly_its_correction(tmp_path, cli):
    """Probe the plate on features against a true cell, calibrate, and every target on the
    plate moves by the calibration's correction (1e-6 m, 1e-6 rad); the programs are
    unchanged and the run still passes its check."""
    truth, cell = tmp_path / "truth", tmp_path / "cell"
    shutil.copytree(PROBING, truth)
    shutil.copytree(PROBING, cell)
    poses = (truth / "poses.yaml").read_text()
    (truth / "poses.yaml").write_text(
        poses.replace(
            "plate: {xyz: [-0.25, 0.1, 0]}",
            "plate: {xyz: [-0.2488, 0.1007, 0.0002], rpy: [0.05, -0.03, 0.3]}",
        )
    )
    before = _digest(cell)
    measured = tmp_path / "m.yaml"
    run = [
        "measure", "--simulate", str(cell), "--truth", str(truth),
        "--program", str(cell / "programs" / "probe_features.yaml"),
        "--sigma", "0.0001mm", "-o", str(measured),
    ]  # fmt: skip
    assert cli(run).exit_code == 0
    assert cli(["calibrate", str(cell), str(measured), "--frames", "plate"]).exit_code == 0
    _, nominal = simulate_run(str(cell), "peg_in_hole")
    text = (cell / "cell.yaml").read_text()
    (cell / "cell.yaml").write_text(
        text.replace("pose_files: [poses.yaml]", "pose_files: [poses.yaml, calibrated.yaml]")
    )
    loaded, calibrated = simulate_run(str(cell), "peg_in_hole")
    assert calibrated.ok and _digest(cell) == before
    from rworld_cli.schema.loader import load_cell
    from rworld_cli.world.tree import World

    T_nominal = World(load_cell(str(PROBING)).cell).T_world("plate")
    T_true = World(load_cell(str(truth)).cell).T_world("plate")
    T_calibrated = World(loaded.cell).T_world("plate")
    correction = T_calibrated @ np.linalg.inv(T_nominal)  # in world
    assert np.linalg.norm(T_calibrated[:3, 3] - T_true[:3, 3]) < 2e-6  # it found the plate
    T_world_base = World(loaded.cell).T_world("puma")
    on_plate = 0
    for now, then in zip(calibrated.resolved["puma"], nominal.resolved["puma"]):
        assert now.step.where == then.step.where
        if now.move is None:
            continue
        a = T_world_base @ now.move.T_base_tcp
        b = T_world_base @ then.move.T_base_tcp
        if now.move.target.startswith("plate."):
            on_plate += 1
            expected = correction @ b
            assert np.linalg.norm(a[:3, 3] - expected[:3, 3]) < 1e-6
            turn = spatial.rotation_vector(expected[:3, :3].T @ a[:3, :3])
            assert np.linalg.norm(turn) < 1e-6
        else:  # the peg and the named positions did not move
            assert np.allclose(a, b, atol=1e-6)
    assert on_plate == 3  # the insertion's approach and push, the way out
    out = cli(["export", "program", str(cell), "peg_in_hole", "--format", "rapid", "-o",
               str(tmp_path / "out"),
               "--against", str(cell / "poses.yaml"), "--json"])  # fmt: skip
    assert out.exit_code == 0, out.output
    import json

    changes = json.loads(out.stdout)["changes"]
    assert len(changes) == 3 and {c["frames"][0] for c in changes} == {"plate"}
    angle = np.linalg.norm(spatial.rotation_vector(correction[:3, :3]))
    assert all(abs(c["rotation_arcsec"] - np.degrees(angle) * 3600) < 0.01 for c in changes)


def _program(tmp_path, steps: str, units: bool = True) -> tuple:
    cell = tmp_path / "probing"
    shutil.copytree(PROBING, cell)
    program = cell / "programs" / "f.yaml"
    head = "device: puma\n" + ("units: {length: mm, angle: deg}\n" if units else "")
    program.write_text(head + "steps:\n  - move: {to: ready}\n" + steps)
    return cell, program


@pytest.mark.parametrize(
    "step, units, code, where, message",
    [
        (
            "  - insert: {object: peg.tip, into: bracket.top_edge, depth: 5}\n",
            True, 2, "f.yaml:5:37",
            "'bracket.top_edge' is a line: 'into' (a hole: a circle) needs a circle feature",
        ),
        (
            "  - move: {to: {feature: plate.hoel1, standoff: 20}}\n",
            True, 2, "f.yaml:5:26",
            "unknown feature 'plate.hoel1' (did you mean 'plate.hole1'?)",
        ),
        (
            "  - move: {to: {feature: plate.top, standoff: 20}}\n",
            False, 2, "f.yaml:4:47",
            "a bare standoff (20.0) needs the file's units.length",
        ),
        (
            "  - follow: {edge: plate.top, speed: 20mm/s}\n",
            True, 2, "f.yaml:5:20",
            "'plate.top' is a plane: 'edge' (a line) needs a line feature",
        ),
        (
            "  - move: {to: {feature: plate.top, at: [10]}}\n",
            True, 2, "f.yaml:5:41",
            "on a plane, 'at' is [u, v]",
        ),
        (
            "  - move: {to: {feature: plate.top, standoff: 2000}}\n",
            True, 2, "f.yaml:5:16",
            "beyond its reach",
        ),
        (
            "  - move: {to: {feature: plate.top, standoff: 900}}\n",
            True, 1, "f.yaml:5",
            "puma step 2 (move to plate.top (900 mm out)): 'plate.top' is unreachable",
        ),
        (
            "  - insert: {object: peg.tip, into: plate.hole1, depth: 10}\n",
            True, 2, "f.yaml:5",
            "puma does not hold 'peg'",
        ),
    ],
)  # fmt: skip
def test_bad_feature_steps_are_located(tmp_path, cli, step, units, code, where, message):
    cell, program = _program(tmp_path, step, units)
    out = cli(["check", str(cell), str(program)])
    assert out.exit_code == code, out.output
    assert where in out.output and message in out.output, out.output
    assert "Traceback" not in out.output


def test_probing_on_features_records_every_point_on_its_feature():
    _, result = simulate_run(str(PROBING), "probe_features")
    assert result.ok
    probes = [e.reading["feature"] for e in result.events if e.kind == "probe"]
    assert (
        probes
        == ["plate.top"] * 3 + ["plate.front"] * 3 + ["plate.hole1"] * 3 + ["plate.hole2"] * 3
    )
    guarded = [r for r in result.resolved["puma"] if r.move is not None and r.move.guard]
    assert len(guarded) == 12 and {r.move.guard for r in guarded} == {"probe_ball"}


def test_follow_holds_its_speed_along_the_edge(tmp_path):
    cell, program = _program(
        tmp_path,
        "  - follow: {edge: bracket.top_edge, speed: 20mm/s, approach: 30, tcp: gripper}\n",
    )
    from rworld_cli.api import simulate_run as run

    loaded, result = run(str(cell), str(program))
    assert result.ok
    moves = [r.move for r in result.resolved["puma"] if r.step.kind == "follow"]
    assert [m.motion for m in moves] == ["joint", "linear", "linear", "linear"]
    edge = moves[2]
    length = np.linalg.norm(edge.T_base_tcp[:3, 3] - moves[1].T_base_tcp[:3, 3])
    assert length == pytest.approx(0.080, abs=1e-6)  # the bracket is 80 mm deep
    # 80 mm at 20 mm/s with 1 m/s^2 ramps: 4.02 s (+ the clock's rounding)
    assert edge.t1 - edge.t0 == pytest.approx(0.08 / 0.02 + 0.02 / 1.0, abs=0.011)


def test_place_sets_the_face_down_on_the_plane_where_asked(tmp_path):
    """The peg's foot set down on the plate's top at [u, v] = [-20, 30] mm (in the plane's
    axes from its point): it stands there, upright, and rests on the plate (the gripper lets
    go: a placement is the release)."""
    cell, program = _program(
        tmp_path,
        "  - move: {to: {feature: peg.head, standoff: 40}, tcp: gripper}\n"
        "  - move: {to: {feature: peg.head}, tcp: gripper, motion: linear, speed: 0.2}\n"
        "  - grasp: {object: peg, tcp: gripper}\n"
        "  - place: {object: peg.foot, on: plate.top, at: [-20, 30]}\n"
        "  - move: {to: ready}\n",
    )
    loaded, result = simulate_run(str(cell), str(program))
    assert result.ok, [c.describe() for c in result.collisions.contacts]
    placed = next(e for e in result.events if e.kind == "place")
    assert placed.tree["parent"] == "plate" and placed.tree["kind"] == "rests_on"
    T_peg = np.array(placed.tree["T_world_child"])
    from rworld_cli.world.tree import World

    T_plate = World(loaded.cell).T_world("plate")
    top = loaded.cell.features["plate.top"]
    expected = T_plate[:3, :3] @ (top.point + [-0.020, 0.030, 0.0]) + T_plate[:3, 3]
    assert np.allclose(T_peg[:3, 3], expected, atol=1e-6)  # the foot's centre, on the top
    assert np.allclose(T_peg[:3, 2], T_plate[:3, 2], atol=1e-6)  # upright
    placing = [r.kind for r in result.resolved["puma"] if r.step.kind == "place"]
    # the moves, then the release: what the exporters write (issue 44)
    assert placing == ["move", "move", "place"]
    moves = [r.move.motion for r in result.resolved["puma"] if r.step.kind == "place" and r.move]
    assert moves == ["joint", "linear"]

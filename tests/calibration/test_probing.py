"""Probing a robot can do: targets on material, probe geometry, the probe program, the loop closed
in simulation (workcells/probing: a Puma 560 with a 3 mm ball probe, an L-bracket and a plate)."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from rworld_cli import spatial
from rworld_cli.api import plan_cell_measurements, simulate_probe_measurements
from rworld_cli.calibration.pipeline import calibrate
from rworld_cli.calibration.plan import ProbeGeometry, plan_measurements
from rworld_cli.calibration.probe_run import measurement_features, probe_run
from rworld_cli.calibration.probing import tour
from rworld_cli.calibration.solve import _jacobian
from rworld_cli.calibration.targets import d_optimal, feature_candidates
from rworld_cli.collision.bodies import point_triangle_distance
from rworld_cli.errors import UserError
from rworld_cli.geometry import shape_mesh, winding_number
from rworld_cli.model.measurements import Measurement, MeasurementSet
from rworld_cli.schema.loader import load_cell
from rworld_cli.schema.measurements import load_measurements
from rworld_cli.schema.programs import load_run
from rworld_cli.simulate.engine import simulate
from rworld_cli.world.tree import World
from tests.conftest import WORKCELLS

CELL = WORKCELLS / "probing"
SIGMA = 2e-5
MOVES = {  # the true parts: moved from nominal by (mm, deg) in their parent's frame
    "bracket": ([-0.08, -0.3, 0.0], [0, 0, 180], [0.5e-3, -0.6e-3, 0.2e-3], [0.1, -0.08, 0.25]),
    "plate": ([-0.25, 0.1, 0.0], [0, 0, 0], [-0.6e-3, 0.4e-3, -0.2e-3], [-0.07, 0.1, -0.2]),
}


def make_truth(folder):
    shutil.copytree(CELL, folder)
    text = (folder / "poses.yaml").read_text()
    for name, (xyz, rpy, dxyz, drpy) in MOVES.items():
        R = spatial.rpy_to_matrix(np.radians(rpy)) @ spatial.rpy_to_matrix(np.radians(drpy))
        new = np.add(xyz, dxyz)
        line = next(s for s in text.splitlines() if s.strip().startswith(f"{name}:"))
        text = text.replace(
            line,
            f"  {name}: {{xyz: [{', '.join(repr(float(v)) for v in new)}], rpy: "
            f"[{', '.join(repr(float(v)) for v in np.degrees(spatial.matrix_to_rpy(R)))}]}}",
        )
    (folder / "poses.yaml").write_text(text)
    return folder


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    """The probe program planned once for the module (IK, collisions, 2-opt, checked)."""
    folder = tmp_path_factory.mktemp("plan")
    shutil.copytree(CELL, folder / "cell")
    cell = folder / "cell"
    program = cell / "programs" / "planned.yaml"
    result = plan_cell_measurements(str(cell), None, 5e-5, 1e-4, program=str(program))
    return cell, program, result


@pytest.fixture(scope="module")
def probed(planned, tmp_path_factory):
    """The planned program run on the nominal cell, its contacts found on a true cell."""
    cell, program, _ = planned
    truth_dir = make_truth(tmp_path_factory.mktemp("truth") / "truth")
    run = load_run(str(cell), str(program))
    truth = load_cell(str(truth_dir)).cell
    result = simulate(run, collisions=False)
    return run.cell, truth, truth_dir, probe_run(result, run, truth), result


SHORT = """device: puma
units: {length: mm, angle: deg}
steps:
  - move: {to: ready}
  - move: {to: plate, tcp: probe, offset: {xyz: [80, 60, 130], rpy: [180, 0, -90]}}
  - move: {to: plate, tcp: probe, offset: {xyz: [80, 60, 38], rpy: [180, 0, -90]}, motion: linear}
  - move: {to: plate, tcp: probe, offset: {xyz: [80, 60, 14], rpy: [180, 0, -90]}, motion: linear,
      speed: 0.04, until: probe_ball}
  - probe: plate.top
  - move: {to: plate, tcp: probe, offset: {xyz: [80, 60, 38], rpy: [180, 0, -90]}, motion: linear}
"""


def short_program(folder):
    path = folder / "short.yaml"
    path.write_text(SHORT)
    return path


# ---------------------------------------------------------------- targets on material


def test_every_target_lies_on_material_with_the_ball_clear_of_the_part(planned):
    cell_dir, _, result = planned
    cell = load_cell(str(cell_dir)).cell
    world = World(cell)
    radius = 0.003
    for plan in result.plans:
        for d in plan.directives:
            f = cell.features[d.feature]
            tri = shape_mesh(cell.objects[f.owner].shape).triangles()
            T = np.linalg.inv(world.T_world(f.owner))
            contacts = d.contacts @ T[:3, :3].T + T[:3, 3]
            centres = d.points @ T[:3, :3].T + T[:3, 3]
            # on the part's surface (the holes are 360-gons: their facets are 0.4 um in)
            surface = point_triangle_distance(contacts[:, None], tri[None]).min(axis=1)
            assert surface.max() < 1e-6, d.feature
            clear = point_triangle_distance(centres[:, None], tri[None]).min(axis=1)
            assert clear.min() > radius - 1e-6
            assert not (winding_number(centres, tri) > 0.5).any()  # the ball is outside
            if d.feature == "bracket.side":  # the L's side face: nothing in the empty corner
                assert not np.any((contacts[:, 0] > 0.012) & (contacts[:, 2] > 0.012))
            if d.feature == "plate.top":  # off the holes by the ball radius + 1 mm
                for x in (0.04, 0.12):
                    gap = np.linalg.norm(contacts[:, :2] - [x, 0.06], axis=1) - 0.01
                    assert gap.min() >= 0.004 - 1e-9


def test_planes_get_targets_in_two_directions_and_the_program_is_written(planned):
    cell_dir, program, result = planned
    assert result.program == program and program.is_file()
    assert all(p.determined for p in result.plans) and result.cycle_time > 0
    text = program.read_text()
    assert text.count("probe: ") == sum(len(d.points) for p in result.plans for d in p.directives)
    assert text.count("until: probe_ball") == text.count("probe: ")
    for p in result.plans:
        for d in p.directives:
            if d.kind == "plane":
                spread = np.linalg.svd(d.contacts - d.contacts.mean(axis=0), compute_uv=False)
                assert spread[1] > 1e-3  # not on one line: the plane's own fit is defined
    assert not list(program.parent.glob(".*check*"))  # the trial file is gone


def test_d_optimal_choice_predicts_no_worse_than_uniform_for_the_plate(planned):
    plate = next(p for p in planned[2].plans if p.frame == "plate")
    assert plate.sigma_translation < 0.8 * plate.uniform_sigma_translation


def test_line_targets_touch_the_edge_between_its_faces():
    cell = load_cell(str(CELL)).cell
    c = feature_candidates(cell, cell.features["bracket.top_edge"], 0.003, 0.004)
    bisector = np.array([1.0, 0.0, 1.0]) / np.sqrt(2)  # between the top (+z) and inner (+x) faces
    np.testing.assert_allclose(c.normals, np.tile(bisector, (len(c), 1)), atol=1e-12)
    np.testing.assert_allclose(c.offset, 0.003 * bisector, atol=1e-12)
    assert c.points[:, 1].min() >= 0.004 - 1e-12 and c.points[:, 1].max() <= 0.076 + 1e-12


def test_hole_targets_are_on_the_wall_at_the_stated_depth():
    cell = load_cell(str(CELL)).cell
    f = cell.features["plate.hole1"]
    c = feature_candidates(cell, f, 0.003, 0.004, depth=0.005)
    v = c.centres - f.point
    np.testing.assert_allclose(v @ f.direction, -0.005, atol=1e-12)
    radial = np.linalg.norm(v - np.outer(v @ f.direction, f.direction), axis=1)
    np.testing.assert_allclose(radial, 0.007, atol=1e-12)  # R - r
    assert not c.boss and c.depth == 0.005 and c.wall_depth == pytest.approx(0.015, abs=2e-4)


@pytest.mark.parametrize(
    "feature, radius, depth, message",
    [
        ("plate.hole1", 0.0099, None, "does not fit the hole"),
        ("plate.hole1", 0.003, 0.014, "outside the part's wall"),
        ("plate.hole1", 0.003, 0.001, "outside the part's wall"),
    ],
)
def test_a_probe_that_does_not_fit_is_refused_with_the_figure(feature, radius, depth, message):
    cell = load_cell(str(CELL)).cell
    with pytest.raises(UserError, match=message):
        feature_candidates(cell, cell.features[feature], radius, radius + 1e-3, depth)


def test_bad_probing_input_exits_2_and_writes_nothing(cli, tmp_path):
    out = tmp_path / "probe.yaml"
    for args, message in (
        (["--depth", "plate.hole9=3mm"], "not a circle feature"),
        (["--depth", "plate.hole1=14mm"], "outside the part's wall"),
        (["--margin", "1mm"], "less than the ball radius"),
        (["--start", "nowhere"], "not a named position"),
        (["--sensor", "nothing"], "not a ball-tip touch probe"),
    ):
        result = cli(["plan-measurements", str(CELL), "--program", str(out), *args])
        assert result.exit_code == 2, result.output
        assert message in result.output
    assert not out.exists()


def test_a_feature_the_robot_cannot_reach_exits_1_and_writes_nothing(cli, tmp_path):
    cell = tmp_path / "cell"
    shutil.copytree(CELL, cell)
    poses = cell / "poses.yaml"
    poses.write_text(
        poses.read_text().replace("plate: {xyz: [-0.25, 0.1, 0]}", "plate: {xyz: [1.5, 0.1, 0]}")
    )
    text = (cell / "cell.yaml").read_text().replace("box: [0.8, 1.2, 0.4]", "box: [5, 1.2, 0.4]")
    (cell / "cell.yaml").write_text(text)
    out = cell / "programs" / "far.yaml"
    result = cli(["plan-measurements", str(cell), "--frames", "plate", "--program", str(out)])
    assert result.exit_code == 1, result.output
    assert "too few reachable targets" in result.output and "beyond its reach" in result.output
    assert not out.exists()


def test_a_face_against_the_table_is_refused_without_searching_poses(cli, tmp_path):
    """The plate's underside lies on the table: every target's approach would start with
    the ball inside the table, which is said at once (the IK was tried at every target,
    stylus tilt and spin before: 36 s on the GP7 cell of docs/performance.md)."""
    cell = tmp_path / "cell"
    shutil.copytree(CELL, cell)
    text = (cell / "cell.yaml").read_text()
    text = text.replace(
        "      - name: front\n",
        "      - name: bottom\n        plane: {point: [0.08, 0.06, 0], normal: [0, 0, -1]}\n"
        "      - name: front\n",
        1,
    )
    (cell / "cell.yaml").write_text(text)
    (cell / "programs" / "under.yaml").write_text(
        "device: puma\nsteps:\n  - move: {to: ready}\n"
        "  - probe: {feature: plate.bottom, points: 3}\n"
    )
    result = cli(["check", str(cell), "under"])
    assert result.exit_code == 1, result.output
    said = " ".join(result.output.split())
    assert "0 of 3 points on plate.bottom can be probed" in said
    assert "its approach would start inside table" in said


# ---------------------------------------------------------------- the loop closed


def _measured(nominal, probed, sigma, seed):
    features = measurement_features(nominal, probed, sigma, seed)
    return MeasurementSet(
        {
            n: Measurement(n, f.points, f.above, f.ordered, 0.003, "sim", f.offset, f.boss, f.depth)
            for n, f in features.items()
        },
        [],
        sigma if sigma else None,
    )


def test_noiseless_probing_recovers_the_true_parts(probed):
    nominal, truth, _, points, _ = probed
    assert not any(p.off_edge for p in points) and all(p.true is not None for p in points)
    result = calibrate(nominal, _measured(nominal, points, 0.0, 0))
    world = World(truth)
    # the bracket exactly; the plate to the 0.4 um its holes' facets leave
    np.testing.assert_allclose(
        result.solutions["bracket"].T_world, world.T_world("bracket"), atol=1e-9
    )
    np.testing.assert_allclose(result.solutions["plate"].T_world, world.T_world("plate"), atol=1e-6)
    # the closed form starts both: the plate's from its oriented faces and hole axes (its
    # intersection points are collinear); the bracket's edge fits lean toward the nominal
    # approach (docs/calibration.md): its start is 0.2 mm and 0.13 deg off
    for frame, within in (("bracket", 5e-3), ("plate", 1e-5)):
        closed = result.solutions[frame].closed_form
        assert closed is not None
        np.testing.assert_allclose(closed, world.T_world(frame), atol=within)


def test_round_trip_errors_are_at_the_cramer_rao_bound(probed):
    """Median rotation and translation errors over 100 noise seeds within 1.2 of the bound for
    the points actually probed (bench/probing.py prints the same figures)."""
    nominal, truth, _, points, _ = probed
    world = World(truth)
    exact = _measured(nominal, points, 0.0, 0)
    errors = {"bracket": [], "plate": []}
    for seed in range(100):
        result = calibrate(nominal, _measured(nominal, points, SIGMA, seed))
        for frame in errors:
            T, T_true = result.solutions[frame].T_world, world.T_world(frame)
            dR = T[:3, :3] @ T_true[:3, :3].T
            angle = np.arccos(np.clip((np.trace(dR) - 1) / 2, -1, 1))
            errors[frame].append((angle, np.linalg.norm(T[:3, 3] - T_true[:3, 3])))
    rng = np.random.default_rng(0)
    for frame, errs in errors.items():
        cond = next(c for c in nominal.conditions if c.frame == frame)
        feats = [nominal.features[f] for f in cond.features]
        fits = {f.name: type("F", (), {"points": exact.measurements[f.name].points}) for f in feats}
        probing = {f.name: exact.measurements[f.name].probing for f in feats}
        J = _jacobian(feats, fits, probing, world.T_world(frame))
        draws = rng.multivariate_normal(np.zeros(6), SIGMA**2 * np.linalg.inv(J.T @ J), 100000)
        bound = (
            np.median(np.linalg.norm(draws[:, :3], axis=1)),
            np.median(np.linalg.norm(draws[:, 3:], axis=1)),
        )
        observed = np.median(np.array(errs), axis=0)
        assert np.all(observed / bound <= 1.2), (frame, observed / bound)
        assert np.all(observed / bound >= 0.8), (frame, observed / bound)


def test_measure_calibrate_then_the_production_program_goes_where_the_plate_is(
    cli, planned, probed, tmp_path
):
    cell_dir, program, _ = planned
    _, truth, truth_dir, _, _ = probed
    m = tmp_path / "m.yaml"
    info = simulate_probe_measurements(
        str(cell_dir), str(truth_dir), str(program), str(m), SIGMA, 3
    )
    assert info["warnings"] == [] and sum(info["points"].values()) == len(
        [line for line in program.read_text().splitlines() if "probe: " in line]
    )
    measured = load_measurements([str(m)], load_cell(str(cell_dir)).cell)
    assert measured.measurements["bracket.top_edge"].offset is not None
    assert measured.measurements["plate.hole1"].depth == pytest.approx(0.0075, abs=1e-8)
    out = cell_dir / "calibrated.yaml"
    result = cli(["calibrate", str(cell_dir), str(m), "-o", str(out)])
    assert result.exit_code == 0, result.output
    text = (cell_dir / "cell.yaml").read_text()
    (cell_dir / "cell.yaml").write_text(
        text.replace("pose_files: [poses.yaml]", "pose_files: [poses.yaml, calibrated.yaml]")
    )
    try:
        run = load_run(str(cell_dir), str(cell_dir / "runs" / "insert.yaml"))
        result = simulate(run)
        assert result.ok
        tip = World(run.cell)
        item = next(i for i in result.resolved["puma"] if i.move and i.move.motion == "linear")
        tip.set_joints("puma", item.move.q_goal)
        reached = tip.T_world("puma.probe")[:3, 3]
        goal = World(truth).T_world("plate.pin1") @ np.r_[0, 0, -0.005, 1.0]
        assert np.linalg.norm(reached - goal[:3]) < 5 * SIGMA  # nominal: 0.7 mm off
        nominal_goal = (
            World(load_cell(str(CELL)).cell).T_world("plate.pin1") @ np.r_[0, 0, -0.005, 1]
        )
        assert np.linalg.norm(nominal_goal[:3] - goal[:3]) > 5e-4
    finally:
        (cell_dir / "cell.yaml").write_text(text)


def test_a_guarded_move_that_touches_nothing_on_the_truth_exits_1(cli, tmp_path):
    cell_dir, program = CELL, short_program(tmp_path)
    truth = tmp_path / "truth"
    shutil.copytree(CELL, truth)
    poses = truth / "poses.yaml"
    poses.write_text(
        poses.read_text().replace(
            "plate: {xyz: [-0.25, 0.1, 0]}", "plate: {xyz: [-0.25, 0.1, -0.02]}"
        )
    )
    out = tmp_path / "m.yaml"
    result = cli(
        [
            "measure",
            "--simulate",
            str(cell_dir),
            "--truth",
            str(truth),
            "--program",
            str(program),
            "-o",
            str(out),
        ]
    )
    assert result.exit_code == 1, result.output
    assert "touch nothing on the truth cell" in result.output and "short.yaml:7" in result.output
    assert not out.exists()


def test_measure_refuses_a_probe_program_that_collides(cli, tmp_path):
    """``measure --simulate --program`` checks the program as ``check`` does: a move through
    the bracket is refused with the collision's place, nothing written; --allow-collisions
    writes the measurements with the problem said first (issue 60)."""
    program = tmp_path / "through.yaml"
    program.write_text(
        SHORT.replace(
            "  - move: {to: ready}\n",
            "  - move: {to: ready}\n"
            "  - move: {to: bracket, tcp: probe, offset: {xyz: [6, 40, -30], rpy: [180, 0, -90]}}\n"
            "  - move: {to: ready}\n",
        )
    )
    truth = tmp_path / "truth"
    shutil.copytree(CELL, truth)
    out = tmp_path / "m.yaml"
    args = ["measure", "--simulate", str(CELL), "--truth", str(truth), "--program", str(program)]
    refused = cli([*args, "-o", str(out)])
    assert refused.exit_code == 1, refused.output
    assert "does not pass the check" in refused.output and "bracket" in refused.output
    assert "through.yaml:5" in refused.output and "nothing written" in refused.output
    assert not out.exists()
    allowed = cli([*args, "-o", str(out), "--allow-collisions"])
    assert allowed.exit_code == 0, allowed.output
    assert allowed.output.index("warning:") < allowed.output.index("wrote")
    assert out.exists()


# ---------------------------------------------------------------- pieces


def test_two_opt_never_lengthens_the_nearest_neighbour_tour():
    rng = np.random.default_rng(5)
    for _ in range(30):
        pts = rng.uniform(size=(12, 2))
        costs = np.linalg.norm(pts[:, None] - pts[None], axis=2)
        start = np.linalg.norm(pts - [0.5, -0.5], axis=1)

        def length(order):
            return start[order[0]] + costs[order[:-1], order[1:]].sum() + start[order[-1]]

        order = tour(costs, start)
        assert sorted(order) == list(range(12))
        assert length(order) <= length(list(range(12))) + 1e-12
        # no 2-opt move improves it
        path = [None, *order, None]
        full = lambda a, b: start[b] if a is None else (start[a] if b is None else costs[a, b])  # noqa: E731
        for i in range(1, len(path) - 2):
            for j in range(i + 1, len(path) - 1):
                a, b, c, d = path[i - 1], path[i], path[j], path[j + 1]
                assert full(a, c) + full(b, d) >= full(a, b) + full(c, d) - 1e-12


def test_d_optimal_skips_infeasible_candidates_and_keeps_spacing():
    rng = np.random.default_rng(2)
    positions = [rng.uniform(size=(50, 3))]
    rows = [rng.normal(size=(50, 1, 6))]
    refused = {int(k) for k in rng.choice(50, 20, replace=False)}
    chosen = d_optimal(rows, [10], [0.1], positions, lambda f, k: k not in refused)[0]
    assert len(chosen) == 10 and not set(chosen) & refused
    gaps = np.linalg.norm(positions[0][chosen][:, None] - positions[0][chosen][None], axis=2)
    assert gaps[np.triu_indices(10, 1)].min() >= 0.1


def test_plan_without_a_robot_uses_a_point_probe_on_material():
    cell = load_cell(str(CELL)).cell
    plans = plan_measurements(cell, ["plate"], probe=ProbeGeometry(radius=0.0))
    hole = next(d for d in plans[0].directives if d.feature == "plate.hole1")
    np.testing.assert_allclose(hole.points, hole.contacts, atol=1e-15)  # radius 0: on the wall


def test_probing_offsets_round_trip_through_yaml_and_csv(tmp_path):
    cell = load_cell(str(CELL)).cell
    text = (
        "units: {length: mm}\nprobe_radius: 3\nfeatures:\n"
        "  bracket.top_edge:\n    points: [[1, 2, 3], [1, 5, 3]]\n    ordered: true\n"
        "    offset: [2.1, 0, 2.1]\n"
        "  plate.hole1:\n    points: [[1, 0, 0], [0, 1, 0], [-1, 0, 0]]\n    depth: 7.5\n"
    )
    (tmp_path / "m.yaml").write_text(text)
    m = load_measurements([str(tmp_path / "m.yaml")], cell).measurements
    np.testing.assert_allclose(m["bracket.top_edge"].offset, [0.0021, 0, 0.0021])
    assert m["plate.hole1"].depth == pytest.approx(0.0075) and not m["plate.hole1"].boss
    (tmp_path / "m.csv").write_text(
        "feature,x_mm,y_mm,z_mm,role\nplate.hole1,1,0,0,\nplate.hole1,0,1,0,\nplate.hole1,-1,0,0,\n"
        "plate.hole1,7.5,0,0,depth\nplate.hole1,0,0,0,boss\n"
    )
    c = load_measurements([str(tmp_path / "m.csv")], cell).measurements["plate.hole1"]
    assert c.depth == pytest.approx(0.0075) and c.boss
    (tmp_path / "bad.yaml").write_text(
        "units: {length: mm}\nfeatures:\n  plate.top:\n    points: [[0, 0, 0], [1, 0, 0], [0, 1, "
        "0]]\n    depth: 3\n"
    )
    with pytest.raises(UserError) as err:
        load_measurements([str(tmp_path / "bad.yaml")], cell)
    assert "'depth' applies to circles" in str(err.value.issues[0])


def test_a_boss_is_compensated_outward():
    from rworld_cli.calibration.fit import fit_circle

    ang = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    centres = np.stack([0.013 * np.cos(ang), 0.013 * np.sin(ang), np.zeros(8)], axis=1)
    assert fit_circle("c", centres, probe_radius=0.003, boss=True).radius == pytest.approx(0.010)
    assert fit_circle("c", centres, probe_radius=0.003).radius == pytest.approx(0.016)


def test_the_ball_probe_latches_its_contact_exactly(probed):
    nominal, _, _, _, result = probed
    world = World(nominal)
    events = [e for e in result.events if e.kind == "probe"]
    assert len(events) == len([e for e in result.events if e.kind == "guard"])
    for event in events:
        f = nominal.features[event.reading["feature"]]
        if f.kind != "plane":
            continue
        T = world.T_world(f.owner)
        local = (np.array(event.reading["point"]) - T[:3, 3]) @ T[:3, :3]
        assert (local - f.point) @ f.direction == pytest.approx(0.003, abs=1e-9)


def test_export_records_each_probe(tmp_path):
    from rworld_cli.api import export_program

    export_program(str(CELL), "probe", "rapid", str(tmp_path / "abb"))
    text = next((tmp_path / "abb").glob("*.mod")).read_text()
    assert text.count('Write rworld_log, "rworld contact ') == text.count("SearchL ") > 0


def test_a_boss_wall_is_found_and_probed_from_outside(tmp_path):
    cell_dir = tmp_path / "cell"
    shutil.copytree(CELL, cell_dir)
    text = (cell_dir / "cell.yaml").read_text()
    pin = """  - name: pin              # a boss: a 20 mm pin, 30 mm tall
    geometry: {cylinder: {radius: 0.01, length: 0.03}, origin: {xyz: [0, 0, 0.015]}}
    features:
      - name: rim
        circle: {center: [0, 0, 0.03], normal: [0, 0, 1], radius: 0.01}

sensors:"""
    (cell_dir / "cell.yaml").write_text(text.replace("\nsensors:", "\n" + pin, 1))
    poses = cell_dir / "poses.yaml"
    poses.write_text(poses.read_text() + "  pin: {xyz: [0.5, -0.1, 0.4]}\n")
    cell = load_cell(str(cell_dir)).cell
    f = cell.features["pin.rim"]
    c = feature_candidates(cell, f, 0.003, 0.004)
    assert c.boss and c.depth == pytest.approx(0.015, abs=2e-4)  # the middle of the wall
    v = c.centres - f.point
    radial = np.linalg.norm(v - np.outer(v @ f.direction, f.direction), axis=1)
    np.testing.assert_allclose(radial, 0.013, atol=1e-12)  # R + r: the ball outside
    np.testing.assert_allclose(np.einsum("ij,ij->i", c.normals, v), radial, atol=1e-12)


# ---------------------------------------------------------------- a robot that is not nominal


def test_a_robot_off_its_model_puts_its_error_into_the_probe_points(planned, tmp_path):
    """Issue 34: the truth cell's Puma has an upper arm (a2) 1 mm longer than its model; the
    parts are exactly where the nominal cell has them.  The controller drives the nominal joint
    values and records its nominal forward kinematics, so the recorded contacts are about 1 mm
    from the true ones, and calibrating from them moves the parts by about that much - the
    bias robot calibration exists for.  With the nominal robot as truth, recorded and true
    contacts are the same points and the parts stay within 1 um."""
    cell_dir, program, _ = planned
    run = load_run(str(cell_dir), str(program))
    result = simulate(run, collisions=False)
    corrections = {}
    for label, a2 in (("nominal", "0.4318"), ("a2 + 1 mm", "0.4328")):
        truth_dir = tmp_path / label.replace(" ", "_")
        shutil.copytree(CELL, truth_dir)
        text = (truth_dir / "cell.yaml").read_text()
        assert text.count("a: 0.4318") == 1
        (truth_dir / "cell.yaml").write_text(text.replace("a: 0.4318", f"a: {a2}"))
        truth = load_cell(str(truth_dir)).cell
        points = probe_run(result, run, truth)
        assert all(p.true is not None and p.reported is not None for p in points)
        gap = np.array([np.linalg.norm(p.reported - p.true) for p in points])
        calibrated = calibrate(run.cell, _measured(run.cell, points, 0.0, 0))
        world = World(truth)
        corrections[label] = {
            frame: np.linalg.norm(s.T_world[:3, 3] - world.T_world(frame)[:3, 3])
            for frame, s in calibrated.solutions.items()
        }
        if label == "nominal":
            assert gap.max() < 1e-12
        else:  # the arm's millimetre: the wrist, orientation kept, 1 mm along the upper arm
            print(f"recorded - true: {gap.min() * 1000:.4f}-{gap.max() * 1000:.4f} mm")
            np.testing.assert_allclose(gap, 1e-3, atol=1e-5)
    print({k: {f: f"{v * 1000:.4f} mm" for f, v in c.items()} for k, c in corrections.items()})
    assert max(corrections["nominal"].values()) < 1e-6, corrections
    assert all(0.9e-3 < c < 1.1e-3 for c in corrections["a2 + 1 mm"].values()), corrections


def robot_truth(folder, seed: int = 11, parts_moved: bool = True):
    """The probing cell's truth: the parts moved (MOVES, unless not ``parts_moved``) and the
    Puma off its DH table - a small pose before every row (0.3 mm, 0.03 deg) and its probe
    0.3 mm off - as a pose overlay."""
    if parts_moved:
        make_truth(folder)
    else:
        shutil.copytree(CELL, folder)
    rng = np.random.default_rng(seed)
    lines = ["units: {length: mm, angle: deg}", "corrections:"]
    for name in ("j1", "j2", "j3", "j4", "j5", "j6"):
        xyz = ", ".join(f"{v:.6f}" for v in rng.normal(0, 0.3, 3))
        rpy = ", ".join(f"{v:.6f}" for v in rng.normal(0, 0.03, 3))
        lines.append(f"  puma.{name}: {{xyz: [{xyz}], rpy: [{rpy}]}}")
    probe = np.r_[0, 0, 160.0] + rng.normal(0, 0.3, 3)
    lines += ["poses:", f"  puma.probe: {{xyz: [{', '.join(f'{v:.6f}' for v in probe)}]}}"]
    (folder / "robot_truth.yaml").write_text("\n".join(lines) + "\n")
    text = (folder / "cell.yaml").read_text()
    assert "pose_files: [poses.yaml]" in text
    (folder / "cell.yaml").write_text(
        text.replace("pose_files: [poses.yaml]", "pose_files: [poses.yaml, robot_truth.yaml]")
    )
    return folder


def _tracker_file(truth, path, count: int, seed: int, sigma_mm: float) -> None:
    """A laser tracker's file: the truth Puma's probe centre at random joint states (mm, deg)."""
    dev = truth.devices["puma"]
    rng = np.random.default_rng(seed)
    Q = rng.uniform(dev.limit_array("lower"), dev.limit_array("upper"), (count, dev.dof))
    world = World(truth)
    lines = [
        "units: {length: mm, angle: deg}",
        "device: puma",
        f"sigma: {sigma_mm}",
        "target: puma.probe",
        "observations:",
    ]
    for q in Q:
        world.set_joints("puma", q)
        p = world.T_world("puma.probe")[:3, 3] * 1000 + rng.normal(0, sigma_mm, 3)
        joints = ", ".join(f"{v:.9f}" for v in np.degrees(q))
        lines.append(f"  - {{joints: [{joints}], point: [{', '.join(f'{v:.6f}' for v in p)}]}}")
    path.write_text("\n".join(lines) + "\n")


def test_the_loop_closed_with_the_robot_calibrated_first(planned, tmp_path, cli):
    """Issue 34: a truth cell whose Puma is off its DH table (and whose parts moved). Tracker
    data -> calibrate-robot -> the probe program run with the calibrated robot -> calibrate: the
    parts within 3 predicted sigma of the truth.  Probing with the nominal robot instead leaves
    them off by the robot's error, many sigma."""
    from rworld_cli.api import calibrate_robot

    cell_dir, program, _ = planned
    truth_dir = robot_truth(tmp_path / "truth")
    truth = load_cell(str(truth_dir)).cell
    tracker = tmp_path / "tracker.yaml"
    _tracker_file(truth, tracker, 60, 1, 0.01)
    calibrated_dir = tmp_path / "calibrated"
    shutil.copytree(cell_dir, calibrated_dir)
    robot = calibrate_robot(
        str(calibrated_dir), [str(tracker)], output=str(calibrated_dir / "robot.yaml")
    )
    # the probe's ball centre lies on joint 6's axis: j6's tilts and zero stay nominal (issue
    # 46), 25 of the 27 a point elsewhere would identify
    assert robot.written and robot.identified == 25, robot.identified
    assert any("lies on j6's axis" in n for n in robot.notes), robot.notes
    text = (calibrated_dir / "cell.yaml").read_text()
    (calibrated_dir / "cell.yaml").write_text(
        text.replace("pose_files: [poses.yaml]", "pose_files: [poses.yaml, robot.yaml]")
    )
    world = World(truth)
    off = {}
    for label, cell in (("nominal robot", cell_dir), ("calibrated robot", calibrated_dir)):
        m = tmp_path / f"{label.replace(' ', '_')}.yaml"
        simulate_probe_measurements(str(cell), str(truth_dir), str(program), str(m), SIGMA, 5)
        result = calibrate(
            load_cell(str(cell)).cell, load_measurements([str(m)], load_cell(str(cell)).cell)
        )
        off[label] = {
            frame: (
                float(np.linalg.norm(s.T_world[:3, 3] - world.T_world(frame)[:3, 3])),
                float(np.linalg.norm(s.sigma_translation)),
            )
            for frame, s in result.solutions.items()
        }
    print(
        {
            k: {f: f"{e * 1000:.4f} mm ({e / s:.2f} sigma)" for f, (e, s) in v.items()}
            for k, v in off.items()
        }
    )
    for frame, (error, sigma) in off["calibrated robot"].items():
        assert error < 3 * sigma, (frame, error, sigma)
    assert max(e / s for e, s in off["nominal robot"].values()) > 10, off


STYLUS = """  - name: stylus   # the probe's shaft, on the flange up to 7 mm short of the ball
    mass: 0.1
    geometry: {cylinder: {radius: 0.006, length: 0.15}, origin: {xyz: [0, 0, 0.075]}}
"""


def test_a_stylus_carried_by_the_robot_is_not_what_its_ball_touches(tmp_path):
    """Issue 50's walkthrough: a probe's shaft modelled as an object on the flange is carried by
    the robot, and was taken for part of the cell - where it stood at the guarded move's end,
    so the ball 'touched' its own shaft mm before the part.  With the nominal cell as truth the
    recorded contacts are the simulated ones (to 1e-8 m: mm before the fix)."""
    cell = tmp_path / "cell"
    shutil.copytree(CELL, cell)
    text = (cell / "cell.yaml").read_text()
    text = text.replace("objects:\n", "objects:\n" + STYLUS, 1)
    text = text.replace(
        "affixments:\n", "affixments:\n  - {parent: puma.tool, child: stylus, type: rigid}\n", 1
    )
    (cell / "cell.yaml").write_text(text)
    with (cell / "poses.yaml").open("a") as poses:
        poses.write("  stylus: {xyz: [0, 0, 0]}\n")
    run = load_run(str(cell), str(short_program(tmp_path)))
    result = simulate(run, collisions=False)
    [point] = probe_run(result, run, load_cell(str(cell)).cell)
    assert point.objects == ["plate"]
    # the engine latches its contact by bisection in time; the line search is exact
    assert np.abs(point.true - point.nominal).max() < 1e-8
    assert np.abs(point.reported - point.true).max() < 1e-12

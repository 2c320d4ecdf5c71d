"""Calibration: fits, natural and auxiliary frames, degenerate sets, the overlay, the commands."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from rworld_cli.calibration.fit import FitError, fit_circle, fit_line, fit_plane
from rworld_cli.calibration.pipeline import calibrate, simulate_measurements
from rworld_cli.schema.loader import load_cell
from rworld_cli.schema.measurements import load_measurements, measurement_text
from rworld_cli.world.tree import World
from tests.conftest import REPO, WORKCELLS

TRUE_BLOCK = "block: {xyz: [-98.7, -76.2, 0.4], rpy: [0.3, -0.2, 15.8]}"
NOMINAL_BLOCK = "block: {xyz: [-100, -75, 0], rpy: [0, 0, 15]}"


def make_truth(tmp_path: Path, replace: dict[str, str] | None = None) -> Path:
    truth = tmp_path / "truth"
    shutil.copytree(WORKCELLS / "calibration_example", truth)
    text = (truth / "poses.yaml").read_text().replace(NOMINAL_BLOCK, TRUE_BLOCK)
    for a, b in (replace or {}).items():
        text = text.replace(a, b)
    (truth / "poses.yaml").write_text(text)
    return truth


def measure(nominal, truth_cell, sigma, seed, n=10, features=None):
    feats = features or sorted({f for c in nominal.conditions for f in c.features})
    return simulate_measurements(nominal, truth_cell, feats, {f: n for f in feats}, sigma, seed)


def run(tmp_path, nominal, doc, sigma=0.0, name="m.yaml"):
    path = tmp_path / name
    path.write_text(measurement_text(doc, nominal.name, [], sigma=sigma or 1e-12))
    return calibrate(nominal, load_measurements([str(path)], nominal))


# ---------------------------------------------------------------- fits


def test_plane_fit_is_the_reports_least_root():
    rng = np.random.default_rng(0)
    n = np.array([0.2, -0.3, 0.93])
    n /= np.linalg.norm(n)
    u = np.cross(n, [1, 0, 0])
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    pts = 0.5 * n + rng.uniform(-0.1, 0.1, (40, 1)) * u + rng.uniform(-0.1, 0.1, (40, 1)) * v
    fit = fit_plane("p", pts, above=n)
    np.testing.assert_allclose(fit.direction, n, atol=1e-12)
    assert fit.oriented and fit.rms < 1e-12
    with pytest.raises(FitError, match="collinear"):
        fit_plane("p", np.outer(np.linspace(0, 1, 5), [1, 2, 3]))


def test_line_and_circle_fits():
    d = np.array([1.0, 2.0, 2.0]) / 3
    pts = np.outer(np.linspace(-1, 1, 7), d) + [0.1, 0.2, 0.3]
    line = fit_line("l", pts[::-1].copy(), ordered=True)
    np.testing.assert_allclose(line.direction, -d, atol=1e-12)
    ang = np.linspace(0, 2 * np.pi, 9, endpoint=False)
    circle = fit_circle(
        "c",
        np.stack([0.02 * np.cos(ang) + 0.1, 0.02 * np.sin(ang), np.full(9, 0.05)], axis=1),
        above=[0.1, 0, 1],
    )
    np.testing.assert_allclose(circle.point, [0.1, 0, 0.05], atol=1e-12)
    assert circle.radius == pytest.approx(0.02, abs=1e-12)
    arc = fit_circle(
        "c", np.stack([0.02 * np.cos(ang[:3]), 0.02 * np.sin(ang[:3]), np.zeros(3)], axis=1)
    )
    assert any("cover only" in w for w in arc.warnings)


def test_outliers_flagged():
    rng = np.random.default_rng(1)
    pts = np.column_stack([rng.uniform(-1, 1, 30), rng.uniform(-1, 1, 30), rng.normal(0, 1e-5, 30)])
    pts[7, 2] += 1e-3
    assert fit_plane("p", pts).outliers == [7]


# ---------------------------------------------------------------- frames


def test_noiseless_measurements_recover_the_truth_to_1e9(tmp_path):
    nominal = load_cell(WORKCELLS / "calibration_example").cell
    truth = load_cell(make_truth(tmp_path)).cell
    result = run(tmp_path, nominal, measure(nominal, truth, 0.0, 0))
    world = World(truth)
    sol = result.solutions["block"]
    assert sol.determined and sol.closed_form is not None
    np.testing.assert_allclose(sol.T_world, world.T_world("block"), atol=1e-9)
    np.testing.assert_allclose(
        sol.closed_form, world.T_world("block"), atol=1e-9
    )  # the report's closed form alone
    for aux in ("block.frame2", "block.frame3", "block.frame5"):
        np.testing.assert_allclose(result.solutions[aux].T_world, world.T_world(aux), atol=1e-9)


def test_noisy_error_within_the_predicted_sigma(tmp_path):
    """Over seeds, the pose errors scatter like the predicted standard errors say."""
    nominal = load_cell(WORKCELLS / "calibration_example").cell
    truth = load_cell(make_truth(tmp_path)).cell
    T_true = World(truth).T_world("block")
    z = []
    for seed in range(40):
        result = run(tmp_path, nominal, measure(nominal, truth, 5e-5, seed), 5e-5, f"m{seed}.yaml")
        sol = result.solutions["block"]
        err_t = sol.T_world[:3, 3] - T_true[:3, 3]
        z.append(err_t / sol.sigma_translation)
    z = np.array(z)
    spread = z.std(axis=0)
    assert np.all((0.75 < spread) & (spread < 1.25)), (
        spread
    )  # predicted sigma within +-25 % of the observed spread
    assert np.abs(z).max() < 5


def test_auxiliary_conditions_hold_after_calibration(tmp_path):
    """Nominal auxiliary frames that break their conditions are corrected by the smallest motion."""
    cell_dir = tmp_path / "cell"
    shutil.copytree(WORKCELLS / "calibration_example", cell_dir)
    poses = (cell_dir / "poses.yaml").read_text()
    poses = poses.replace(
        "block.frame2: {xyz: [200, 75, 50]}", "block.frame2: {xyz: [203, 75, 50], rpy: [2, 3, 4]}"
    )
    poses = poses.replace(
        "block.frame3: {xyz: [100, 0, 50], rpy: [90, 0, 0]}",
        "block.frame3: {xyz: [100, 0, 50], rpy: [93, 2, 1]}",
    )
    poses = poses.replace(
        "block.frame5: {xyz: [100, 75, 100]}", "block.frame5: {xyz: [104, 72, 103], rpy: [3, 0, 0]}"
    )
    (cell_dir / "poses.yaml").write_text(poses)
    nominal = load_cell(cell_dir).cell
    truth = load_cell(make_truth(tmp_path)).cell
    result = run(tmp_path, nominal, measure(nominal, truth, 0.0, 0))
    T_block = result.solutions["block"].T_world
    f2 = T_block[:3, :3] @ nominal.features["block.f2"].direction
    f3 = T_block[:3, :3] @ nominal.features["block.f3"].direction
    c6 = nominal.features["block.f6"]
    R2, R3, T5 = (
        result.solutions["block.frame2"].T_world[:3, :3],
        result.solutions["block.frame3"].T_world[:3, :3],
        result.solutions["block.frame5"].T_world,
    )
    assert (
        abs(abs(R2[:, 0] @ f2) - 1) < 1e-12
    )  # C12: the yz plane parallel to f2, i.e. x along its normal
    assert abs(abs(R3[:, 2] @ f3) - 1) < 1e-12  # C6: z normal to f3
    np.testing.assert_allclose(
        T5[:3, 3], T_block[:3, :3] @ c6.point + T_block[:3, 3], atol=1e-9
    )  # C13: origin at the centre
    assert abs(abs(T5[:3, 2] @ (T_block[:3, :3] @ c6.direction)) - 1) < 1e-12
    # frame 4 is chained to frame 3: it follows (its relative pose is unchanged)
    w = World(nominal)
    for name, T in result.overlay.items():
        w._T_parent[name] = T
    w._invalidate()
    np.testing.assert_allclose(
        w.T("block.frame3", "block.frame4"),
        World(nominal).T("block.frame3", "block.frame4"),
        atol=1e-12,
    )


def test_unobservable_frame_is_refused_with_the_motion(tmp_path):
    """Two parallel faces cannot locate a block: the motion they leave free is named."""
    cell_dir = tmp_path / "cell"
    shutil.copytree(WORKCELLS / "calibration_example", cell_dir)
    text = (
        (cell_dir / "cell.yaml")
        .read_text()
        .replace("features: [f1, f2, f3, f4, f5]", "features: [f2, f4]")
    )
    (cell_dir / "cell.yaml").write_text(text)
    nominal = load_cell(cell_dir).cell
    truth = load_cell(make_truth(tmp_path)).cell
    result = run(
        tmp_path, nominal, measure(nominal, truth, 0.0, 0, features=["block.f2", "block.f4"])
    )
    assert "block" in result.undetermined
    assert "undetermined (condition number" in result.undetermined["block"]


def test_weak_set_warns_with_the_figure(tmp_path):
    """Three faces of which two are nearly parallel: solved, with a warning that gives the
    condition number.
    """
    from rworld_cli.calibration.fit import fit_plane as fp
    from rworld_cli.calibration.solve import solve_natural
    from rworld_cli.model.cell import Feature

    rng = np.random.default_rng(2)
    normals = [np.array([0, 0, 1.0]), np.array([1.0, 0, 0]), np.array([0.999, 0.0447, 0])]
    normals = [n / np.linalg.norm(n) for n in normals]
    feats, fits = [], {}
    for k, n in enumerate(normals):
        p = 0.1 * n
        u = np.cross(n, [0.3, 0.5, 0.8])
        u /= np.linalg.norm(u)
        v = np.cross(n, u)
        pts = p + rng.uniform(-0.05, 0.05, (12, 1)) * u + rng.uniform(-0.05, 0.05, (12, 1)) * v
        f = Feature(f"o.p{k}", "o", "plane", p, n)
        feats.append(f)
        fits[f.name] = fp(f.name, pts, above=p + n)
    sol = solve_natural("o", "C2", feats, fits, {}, np.eye(4))
    assert sol.determined and any("weakly determined: condition number" in w for w in sol.warnings)


# ---------------------------------------------------------------- the commands and the overlay


def test_calibrate_command_writes_only_the_overlay(cli, tmp_path):
    cell_dir = tmp_path / "cell"
    shutil.copytree(WORKCELLS / "calibration_example", cell_dir)
    truth = make_truth(tmp_path)
    digests = {
        p.name: hashlib.sha256(p.read_bytes()).hexdigest()
        for p in cell_dir.iterdir()
        if p.is_file()
    }
    m = tmp_path / "m.yaml"
    assert (
        cli(
            [
                "measure",
                "--simulate",
                str(cell_dir),
                "--truth",
                str(truth),
                "--sigma",
                "0",
                "-o",
                str(m),
            ]
        ).exit_code
        == 0
    )
    result = cli(["calibrate", str(cell_dir), str(m)])
    assert result.exit_code == 0, result.output
    overlay = cell_dir / "calibrated.yaml"
    assert overlay.is_file() and "provenance:" in overlay.read_text()
    assert {
        p.name: hashlib.sha256(p.read_bytes()).hexdigest()
        for p in cell_dir.iterdir()
        if p.is_file() and p.name != "calibrated.yaml"
    } == digests
    # with the overlay listed, the cell's world is the truth
    text = (
        (cell_dir / "cell.yaml")
        .read_text()
        .replace("pose_files: [poses.yaml]", "pose_files: [poses.yaml, calibrated.yaml]")
    )
    (cell_dir / "cell.yaml").write_text(text)
    calibrated, true_world = World(load_cell(cell_dir).cell), World(load_cell(truth).cell)
    for frame in ("block", "block.frame2", "block.frame4", "block.frame5"):
        np.testing.assert_allclose(calibrated.T_world(frame), true_world.T_world(frame), atol=1e-9)
    data = json.loads(cli(["calibrate", str(cell_dir), str(m), "--dry-run", "--json"]).stdout)
    assert {f["frame"] for f in data["frames"]} == {
        "block",
        "block.frame2",
        "block.frame3",
        "block.frame5",
    }


def test_refuses_to_overwrite_nominal_or_structure(cli, tmp_path):
    cell_dir = tmp_path / "cell"
    shutil.copytree(WORKCELLS / "calibration_example", cell_dir)
    for target in ("poses.yaml", "cell.yaml"):
        before = (cell_dir / target).read_text()
        result = cli(["calibrate", str(cell_dir), "x.yaml", "-o", str(cell_dir / target)])
        assert result.exit_code == 2 and "refusing to write" in result.output
        assert (cell_dir / target).read_text() == before


def test_undetermined_frame_exits_1_and_writes_nothing(cli, tmp_path):
    cell_dir = tmp_path / "cell"
    shutil.copytree(WORKCELLS / "calibration_example", cell_dir)
    truth = make_truth(tmp_path)
    m = tmp_path / "m.yaml"
    cli(
        [
            "measure",
            "--simulate",
            str(cell_dir),
            "--truth",
            str(truth),
            "--frames",
            "block.frame2",
            "-o",
            str(m),
        ]
    )
    result = cli(["calibrate", str(cell_dir), str(m)])
    assert result.exit_code == 1
    assert "not determined" in result.output and "not measured" in result.output
    assert not (cell_dir / "calibrated.yaml").exists()


@pytest.mark.parametrize(
    "content, message",
    [
        (
            "units: {length: mm}\nfeatures:\n  block.f9:\n    points: [[0, 0, 0]]\n",
            "m.yaml:3:3: features.block.f9: unknown feature 'block.f9' (did you mean",
        ),
        (
            "units: {length: mm}\nfeatures:\n  block.f1:\n    points: [[0, 0, 0], [1, 0, 0]]\n",
            "a plane needs at least 3 point(s), got 2",
        ),
        (
            "units: {length: mm}\nfeatures:\n  block.f1:\n    points: [[0, 0]]\n",
            "m.yaml:4:14: features.block.f1.points[0]: expected exactly 3 values, got 2",
        ),
        (
            "units: {length: mm}\nfeatures:\n  block.f1:\n    points: [[0, 0, 0], [1, 1, 1], [2, "
            "2, 2]]\n",
            "the points are collinear",
        ),
    ],
)
def test_bad_measurements_exit_2(cli, tmp_path, content, message):
    (tmp_path / "m.yaml").write_text(content)
    result = cli(
        ["calibrate", "workcells/calibration_example", str(tmp_path / "m.yaml"), "--dry-run"]
    )
    assert result.exit_code == 2, result.output
    assert message in result.output


def test_csv_points_import(tmp_path):
    nominal = load_cell(WORKCELLS / "calibration_example").cell
    truth = load_cell(make_truth(tmp_path)).cell
    doc = measure(nominal, truth, 0.0, 0)
    rows = ["feature,x,y,z,role"]
    for name, entry in doc.items():
        rows += [
            f"{name},{float(p[0]) * 1000!r},{float(p[1]) * 1000!r},{float(p[2]) * 1000!r},"
            for p in entry.points
        ]
        if entry.offset is not None:  # a line probed beside its edge, a hole below its rim
            rows.append(
                f"{name}," + ",".join(repr(float(x) * 1000) for x in entry.offset) + ",offset"
            )
    (tmp_path / "m.csv").write_text("\n".join(rows) + "\n")
    result = calibrate(nominal, load_measurements([str(tmp_path / "m.csv")], nominal, "mm"))
    np.testing.assert_allclose(
        result.solutions["block"].T_world, World(truth).T_world("block"), atol=1e-9
    )


def test_mirrored_points_are_warned():
    """Four points measured as the mirror image of the nominal ones: no rotation maps them; said
    so.
    """
    from rworld_cli.calibration.fit import fit_point
    from rworld_cli.calibration.solve import MIRROR, solve_natural
    from rworld_cli.model.cell import Feature

    nominal = np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.08, 0], [0.02, 0.03, 0.05]])
    mirrored = nominal * [1, 1, -1] + [0.3, 0.1, 0.5]
    feats = [Feature(f"o.p{k}", "o", "point", p) for k, p in enumerate(nominal)]
    fits = {f.name: fit_point(f.name, m[None]) for f, m in zip(feats, mirrored)}
    sol = solve_natural("o", "C1", feats, fits, {}, np.eye(4))
    assert MIRROR in sol.warnings


def test_line_parallel_to_plane_is_refused():
    """A line parallel to the only plane leaves the translation along the line free."""
    from rworld_cli.calibration.fit import fit_line as fl
    from rworld_cli.calibration.fit import fit_plane as fp
    from rworld_cli.calibration.solve import solve_natural
    from rworld_cli.model.cell import Feature

    plane = Feature("o.top", "o", "plane", np.zeros(3), np.array([0, 0, 1.0]))
    line = Feature("o.edge", "o", "line", np.array([0, 0.05, 0.02]), np.array([1.0, 0, 0]))
    g = np.linspace(-0.05, 0.05, 4)
    plane_pts = np.array([[x, y, 0.0] for x in g for y in g])
    line_pts = np.column_stack([np.linspace(-0.05, 0.05, 6), np.full(6, 0.05), np.full(6, 0.02)])
    fits = {
        "o.top": fp("o.top", plane_pts, above=[0, 0, 1]),
        "o.edge": fl("o.edge", line_pts, ordered=True),
    }
    sol = solve_natural("o", "C2", [plane, line], fits, {}, np.eye(4))
    assert not sol.determined
    assert (
        "translation along (1.00, 0.00, 0.00)" in sol.reason
        or "translation along (-1.00, 0.00, 0.00)" in sol.reason
    )


def test_overlay_refusal_compares_real_paths(cli, tmp_path):
    """The refusal names what the file is, and a folder that merely is called 'runs' elsewhere is
    fine (it was refused by its name before)."""
    cell_dir = tmp_path / "puma560"
    shutil.copytree(WORKCELLS / "puma560", cell_dir)
    program = cell_dir / "programs" / "pick_place.yaml"
    before = program.read_bytes()
    result = cli(["calibrate", str(cell_dir), "x.yaml", "-o", str(program)])
    assert result.exit_code == 2 and "it is a program file of the cell" in result.output
    assert program.read_bytes() == before
    result = cli(["calibrate", str(cell_dir), "x.yaml", "-o", str(cell_dir / "poses.yaml")])
    assert "it is a nominal pose file of the cell" in result.output
    measurements = sorted((REPO / "measurements" / "calibration_example").glob("*.yaml"))
    elsewhere = tmp_path / "results" / "runs" / "calibrated.yaml"
    result = cli(
        [
            "calibrate",
            str(WORKCELLS / "calibration_example"),
            str(measurements[0]),
            "-o",
            str(elsewhere),
        ]
    )
    assert result.exit_code == 0, result.output
    assert elsewhere.is_file()


def test_c1_closed_form_from_circle_axes_and_a_plane():
    """C1 (no orientation): a circle's axis counts as a line, so two holes tilted against a face
    give the centres and where the axes pierce it, and two skew holes their axes' closest points;
    two parallel holes alone give two points, and the message says so."""
    import dataclasses

    from scipy.spatial.transform import Rotation

    from rworld_cli.calibration.fit import FeatureFit
    from rworld_cli.calibration.solve import closed_form
    from rworld_cli.model.cell import Feature

    def unit(v):
        return np.asarray(v, dtype=float) / np.linalg.norm(v)

    features = [
        Feature("part.face", "part", "plane", np.zeros(3), unit([0, 0, 1])),
        Feature(
            "part.hole1", "part", "circle", np.array([0.1, 0.0, 0.05]), unit([0.3, 0, 1]), 0.01
        ),
        Feature(
            "part.hole2", "part", "circle", np.array([0.0, 0.1, 0.05]), unit([0, -0.4, 1]), 0.01
        ),
    ]
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec([0.2, -0.5, 0.9]).as_matrix()
    T[:3, 3] = [0.4, -0.2, 0.7]
    fits = {
        f.name: FeatureFit(
            f.name,
            f.kind,
            T[:3, :3] @ f.point + T[:3, 3],
            T[:3, :3] @ f.direction,
            False,
            f.radius,
            np.zeros(3),
            0.0,
            [],
            1.0,
            3,
            np.zeros((3, 3)),
        )
        for f in features
    }
    pose, how = closed_form("C1", features, fits)
    assert pose is not None, how
    np.testing.assert_allclose(pose, T, atol=1e-9)
    np.testing.assert_allclose(closed_form("C1", features[1:], fits)[0], T, atol=1e-9)  # skew
    parallel = [  # two holes with parallel axes and no face: two centres, nothing more
        Feature(f.name, f.owner, f.kind, f.point, unit([0, 0, 1]), f.radius) for f in features[1:]
    ]
    for f in parallel:
        fits[f.name] = dataclasses.replace(fits[f.name], direction=T[:3, :3] @ f.direction)
    pose, how = closed_form("C1", parallel, fits)
    assert pose is None and "2 intersection point(s)" in how and "not 3 non-collinear" in how


def _csv_rows(doc, scale: float) -> list[list[str]]:
    rows = []
    for name, entry in doc.items():
        rows += [[name, *(repr(float(x) * scale) for x in p), ""] for p in entry.points]
        if entry.offset is not None:
            rows.append([name, *(repr(float(x) * scale) for x in entry.offset), "offset"])
    return rows


@pytest.mark.parametrize(
    "header, delimiter, bom, quoted, csv_units",
    [
        ("feature,x_mm,y_mm,z_mm,role", ",", False, False, None),  # the unit in the header
        ("feature;x [mm];y [mm];z [mm];role", ";", True, True, None),  # Excel: BOM, ;, quotes
        ("feature\tx\ty\tz\trole", "\t", False, False, "mm"),  # tabs, --csv-units
        ("# units: mm\nfeature,x,y,z,role", ",", False, True, None),  # a units line
    ],
)
def test_csv_dialects_and_stated_units(tmp_path, header, delimiter, bom, quoted, csv_units):
    nominal = load_cell(WORKCELLS / "calibration_example").cell
    truth = load_cell(make_truth(tmp_path)).cell
    lines = [header]
    for row in _csv_rows(measure(nominal, truth, 0.0, 0), 1000):
        lines.append(
            delimiter.join(f'"{f}"' if quoted and k == 0 else f for k, f in enumerate(row))
        )
    text = ("\ufeff" if bom else "") + "\n".join(lines) + "\n"
    (tmp_path / "m.csv").write_text(text, encoding="utf-8")
    result = calibrate(nominal, load_measurements([str(tmp_path / "m.csv")], nominal, csv_units))
    np.testing.assert_allclose(
        result.solutions["block"].T_world, World(truth).T_world("block"), atol=1e-9
    )


@pytest.mark.parametrize(
    "text, csv_units, where, message",
    [
        ("feature,x,y,z\nblock.f1,1,2,3\n", None, "m.csv:1:1:", "does not state its length unit"),
        ("feature,x_m,y_m,z_m\nblock.f1,1,2,3\n", "mm", "m.csv:1:1:", "but --csv-units says mm"),
        ("feature;x_mm;y_mm;z_mm\nblock.f1;1,5;2;3\n", None, "m.csv:2:10:", "a decimal comma?"),
        ("feature,x_mm,y_mm,z_mm\nblock.f1,1,2\n", None, "m.csv:2:1:", "3 field(s) separated"),
        ("feature x y z\nblock.f1 1 2 3\n", None, "m.csv:1:1:", "separated by ',', ';' or a tab"),
        ("# units: inch\nfeature,x,y,z\nb,1,2,3\n", None, "m.csv:1:1:", "unknown length unit"),
    ],
)
def test_csv_refusals_say_why(cli, tmp_path, text, csv_units, where, message):
    (tmp_path / "m.csv").write_text(text)
    args = ["calibrate", "workcells/calibration_example", str(tmp_path / "m.csv"), "--dry-run"]
    result = cli(args + (["--csv-units", csv_units] if csv_units else []))
    assert result.exit_code == 2, result.output
    assert where in result.output and message in result.output, result.output


def test_points_in_metres_given_as_millimetres_never_make_an_overlay(cli, tmp_path):
    """The issue's case: a 930.86 mm correction of block.frame5 was written with exit 0."""
    nominal = load_cell(WORKCELLS / "calibration_example").cell
    truth = load_cell(make_truth(tmp_path)).cell
    rows = _csv_rows(measure(nominal, truth, 0.0, 0), 1.0)  # metres
    (tmp_path / "m.csv").write_text(
        "feature,x_mm,y_mm,z_mm,role\n" + "\n".join(",".join(r) for r in rows) + "\n"
    )
    out = tmp_path / "out.yaml"
    for frames in (["--frames", "block.frame5"], []):
        args = ["calibrate", "workcells/calibration_example", str(tmp_path / "m.csv"), "-o"]
        result = cli(args + [str(out), *frames])
        assert result.exit_code == 2, result.output
        assert "implausible measurements, nothing written" in result.output
        assert "(m read as mm)" in result.output
        assert not out.exists()


def test_implausible_corrections_and_residuals_are_refused(cli, tmp_path):
    """A block 80 mm off its nominal pose, and points 50 times noisier than the stated sigma."""
    nominal = load_cell(WORKCELLS / "calibration_example").cell
    far = make_truth(tmp_path, {TRUE_BLOCK: "block: {xyz: [-100, -75, 80], rpy: [0, 0, 15]}"})
    doc = measure(nominal, load_cell(far).cell, 0.0, 0)
    (tmp_path / "m.yaml").write_text(measurement_text(doc, "calibration_example", [], sigma=1e-5))
    args = ["calibrate", "workcells/calibration_example", str(tmp_path / "m.yaml"), "--dry-run"]
    result = cli(args)
    assert result.exit_code == 2 and "more than --max-correction 50 mm" in result.output
    assert cli(args + ["--max-correction", "100mm"]).exit_code == 0
    assert cli(args + ["--max-correction", "100"]).exit_code == 2  # no unit
    noisy = measure(nominal, load_cell(make_truth(tmp_path / "n")).cell, 5e-4, 1)
    (tmp_path / "m.yaml").write_text(measurement_text(noisy, "calibration_example", [], sigma=1e-5))
    result = cli(args)
    assert result.exit_code == 2 and "times the instrument's sigma 0.01 mm" in result.output

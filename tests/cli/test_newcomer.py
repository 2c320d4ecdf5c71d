"""The newcomer's path (issue 50): the small stops a new user met, each checked - rename
messages, help text, an 80-column show with units, a CSV export that says what it holds, moves
that name their configuration, IK in a configuration, probe points spread for the fit, counts
that match the program, a note for massless links, and each file written once."""

from __future__ import annotations

import json
import re
import shutil

import numpy as np
import yaml

from rworld_cli.schema.loader import load_cell
from tests.conftest import REPO, WORKCELLS

GP7 = REPO / "tests" / "data" / "motoman" / "motoman_gp7_support" / "urdf" / "gp7.xacro"


def test_renames_say_what_shows_where(cli, tmp_path):
    """A URDF whose root is 'world' (UR's ROS 2 description) and names with spaces: only the
    names the cell shows are listed, each with where it shows."""
    urdf = tmp_path / "r.urdf"
    urdf.write_text(
        '<robot name="r"><link name="world"/><link name="base_link"/>'
        '<joint name="world_joint" type="fixed"><parent link="world"/><child link="base_link"/>'
        '</joint><link name="l 1"/><joint name="j 1" type="revolute"><parent link="base_link"/>'
        '<child link="l 1"/><origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" velocity="1" effort="1"/></joint></robot>'
    )
    result = cli(["import", "urdf", str(urdf), "-o", str(tmp_path / "cell"), "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.output)
    assert report["renamed"] == {"l 1": "l_1", "j 1": "j_1"}  # world_2 shows nowhere
    assert report["renamed_where"] == {"l 1": "link r.l_1", "j 1": "joint r.j_1"}
    assert "world_2" not in (tmp_path / "cell" / "cell.yaml").read_text()


def test_check_help_says_unreachable_targets_fail_the_check(cli):
    text = " ".join(cli(["check", "--help"]).output.split())
    assert "A target no joint solution reaches fails the check too (exit 1" in text
    assert "unreachable targets) exits 2" not in text


def test_show_fits_80_columns_and_states_its_units(cli, tmp_path, monkeypatch):
    monkeypatch.setenv("COLUMNS", "80")
    cell = tmp_path / "gp7"
    assert (
        cli(
            ["import", "urdf", str(GP7), "--package-path", str(GP7.parents[2])] + ["-o", str(cell)]
        ).exit_code
        == 0
    )
    for folder in (WORKCELLS / "ur5", WORKCELLS / "puma560", cell):
        out = cli(["show", str(folder)]).stdout
        lines = out.splitlines()
        assert max(len(line) for line in lines) <= 80, folder
        assert "x y z [mm]" in out and "r p y [deg]" in out
        # numbers are never cut: every row of the frame table ends in its three and three
        head = next(k for k, line in enumerate(lines) if "x y z [mm]" in line)
        rows = lines[head + 1 : next(k for k in range(head, len(lines)) if not lines[k].strip())]
        for line in rows:
            numbers = re.findall(r"-?\d+\.\d\b", line.split("…")[-1])
            assert len(numbers) == 6, line
    assert "6 DOF RRRRRR, joint frames" in cli(["show", str(cell), "--json"]).stdout


def test_csv_export_says_its_samples_and_units(cli, tmp_path):
    result = cli(
        ["export", "program", str(WORKCELLS / "puma560"), "pick_place", "--format", "csv"]
        + ["-o", str(tmp_path / "csv")]
    )
    assert result.exit_code == 0
    assert re.search(r"\(puma, (\d+) samples every 8 ms\)", result.output)
    samples = int(re.search(r"(\d+) samples", result.output).group(1))
    lines = (tmp_path / "csv" / "pick_place.csv").read_text().splitlines()
    assert lines[0] == f"# {samples} samples every 8 ms (rworld export program); t in s"
    assert lines[1] == "# units: m, rad" and lines[2].startswith("t,j1,")
    assert len(lines) == samples + 3
    from rworld_cli.schema.csvtext import read_csv_table

    table = read_csv_table(str(tmp_path / "csv" / "pick_place.csv"), "t,<joints>")
    assert len(table.rows) == samples  # the comment lines are the readers' own


def test_moves_name_their_configuration_and_ik_takes_one(cli):
    result = cli(["simulate", str(WORKCELLS / "puma560"), "pick_place", "--json"])
    moves = [e for e in json.loads(result.output)["events"] if e["kind"] == "move"]
    assert moves and all(e["reading"]["configuration"]["elbow"] in ("up", "down") for e in moves)
    assert all("shoulder front" in e["detail"] for e in moves if "already" not in e["detail"])
    ik = cli(
        ["kinematics", "ik", str(WORKCELLS / "ur5"), "--xyz", "0.4,0.2,0.4", "--rpy", "3.1,0,0"]
        + ["--config", "elbow=down", "--json"]
    )
    assert ik.exit_code == 0, ik.output
    assert json.loads(ik.output)["configuration"]["elbow"] == "down"
    up = cli(
        ["kinematics", "ik", str(WORKCELLS / "ur5"), "--xyz", "0.4,0.2,0.4", "--rpy", "3.1,0,0"]
        + ["--config", "elbow=up", "--json"]
    )
    assert json.loads(up.output)["configuration"]["elbow"] == "up"
    bad = cli(
        ["kinematics", "ik", str(WORKCELLS / "ur5"), "--xyz", "0.4,0.2,0.4", "--rpy", "3.1,0,0"]
        + ["--config", "knee=up"]
    )
    assert bad.exit_code == 2 and "give shoulder=front|back" in bad.output


def test_a_vendor_arm_names_its_controllers_configuration(cli, tmp_path):
    """A KUKA KR 16 from ROS-Industrial: each move says its Status and Turn."""
    from tests.conftest import urdf_without_meshes
    from tests.export.test_vendors import VENDORS

    urdf = urdf_without_meshes(VENDORS["kr16"][0], tmp_path / "kr16.urdf")
    cell = tmp_path / "kr16"
    assert cli(["import", "urdf", str(urdf), "-o", str(cell)]).exit_code == 0
    data = yaml.safe_load((cell / "cell.yaml").read_text())
    for joint in data["devices"][0]["joints"]:
        joint["limits"]["acceleration"] = 10.0
    (cell / "cell.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    device = data["devices"][0]["name"]
    program = cell / "p.yaml"
    program.write_text(
        f"device: {device}\nunits: {{length: mm, angle: deg}}\nsteps:\n"
        "  - move: {joints: [10, -80, 90, 20, 40, 30]}\n"
    )
    result = cli(["simulate", str(cell), str(program), "--json"])
    [move] = [e for e in json.loads(result.output)["events"] if e["kind"] == "move"]
    assert re.search(r"KUKA S \d+ T \d+", move["detail"]), move["detail"]
    assert move["reading"]["configuration"]["controller"].startswith("KUKA S ")


def test_probe_points_spread_for_the_fit_and_what_calibrate_would_say_is_said(cli):
    result = cli(["simulate", str(WORKCELLS / "probing"), "probe_features", "--json"])
    report = json.loads(result.output)
    probes = [e["reading"] for e in report["events"] if e["kind"] == "probe"]
    cell = load_cell(str(WORKCELLS / "probing")).cell
    from rworld_cli.world.tree import World

    world = World(cell)
    T = world.T_world("plate")
    for hole in ("plate.hole1", "plate.hole2"):
        f = cell.features[hole]
        points = np.array([p["point"] for p in probes if p["feature"] == hole])
        local = (points - T[:3, 3]) @ T[:3, :3] - f.point
        angles = np.sort(np.arctan2(local[:, 1], local[:, 0]))
        gaps = np.diff(np.r_[angles, angles[0] + 2 * np.pi])
        assert np.degrees(2 * np.pi - gaps.max()) >= 230, hole  # near 120 deg apart
    top = np.array([p["point"] for p in probes if p["feature"] == "plate.top"])
    spread = np.sqrt(np.sort(np.linalg.eigvalsh(np.cov((top - top.mean(0)).T)))[::-1])
    assert spread[1] / spread[0] > 0.3  # in two directions, not on a line
    warnings = [e["detail"] for e in report["events"] if e["kind"] == "warning"]
    assert any("plate.front lie almost on a line" in w for w in warnings), warnings


def test_plan_measurements_counts_touches_and_writes_no_move_twice(cli, tmp_path):
    cell = tmp_path / "probing"
    shutil.copytree(WORKCELLS / "probing", cell)
    program = cell / "programs" / "planned.yaml"
    result = cli(
        ["plan-measurements", str(cell), "--program", str(program), "--frames", "plate", "--json"]
    )
    assert result.exit_code == 0, result.output
    report = json.loads(result.output)
    text = program.read_text()
    assert report["touches"] == text.count("  - probe: ")
    moves = [line.split("#")[0].strip() for line in text.splitlines() if "- move:" in line]
    assert all(a != b for a, b in zip(moves, moves[1:])), "a move written twice in a row"


def test_massless_links_are_noted_and_files_are_listed_once(cli, tmp_path):
    cell = tmp_path / "gp7"
    limits = tmp_path / "limits.yaml"
    limits.write_text(
        "joint_limits:\n"
        + "".join(
            f"  {j}: {{has_acceleration_limits: true, max_acceleration: 10}}\n"
            for j in ("joint_1_s", "joint_2_l", "joint_3_u", "joint_4_r", "joint_5_b", "joint_6_t")
        )
    )
    args = ["import", "urdf", str(GP7), "--package-path", str(GP7.parents[2])]
    assert cli(args + ["-o", str(cell), "--joint-limits", str(limits)]).exit_code == 0
    (cell / "p.yaml").write_text(
        "device: motoman_gp7\nunits: {length: mm, angle: deg}\nsteps:\n"
        "  - move: {joints: [10, 20, -10, 0, 30, 0]}\n"
    )
    out = tmp_path / "run"
    result = cli(
        ["simulate", str(cell), str(cell / "p.yaml"), "-o", str(out), "--glb", str(out / "run.glb")]
        + ["--no-collisions"]
    )
    assert result.exit_code == 0, result.output
    assert "motoman_gp7: its links have no mass in the cell" in " ".join(result.output.split())
    assert result.output.count("run.glb") == 1, result.output


def test_a_program_checks_by_its_name_when_the_cell_has_no_run_of_that_name(cli, tmp_path):
    """A newcomer's cell has programs/ and no runs/ yet: `rworld check CELL PROGRAM` runs the
    program alone (as a run of one), and a name that is neither still exits 2."""
    cell = tmp_path / "cell"
    shutil.copytree(WORKCELLS / "probing", cell)
    (cell / "runs" / "insert.yaml").unlink()
    result = cli(["check", str(cell), "insert"])
    assert result.exit_code == 0, result.output
    assert f"ok: {cell}/programs/insert.yaml: 1 device(s)" in result.output
    missing = cli(["check", str(cell), "insrt"])
    assert missing.exit_code == 2 and "no run 'insrt'" in missing.output

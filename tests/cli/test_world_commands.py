"""The real commands on the example cells."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

from tests.conftest import EXAMPLE_CELLS, REPO


def test_validate_all_examples(cli):
    result = cli(
        ["validate"] + [f"workcells/{c}/cell.yaml" for c in EXAMPLE_CELLS],
    )
    assert result.exit_code == 0
    assert result.stdout.count("ok: ") == len(EXAMPLE_CELLS)


def test_validate_json_reports_errors_with_positions(cli, tmp_path):
    (tmp_path / "cell.yaml").write_text(
        "name: x\nobjects:\n  - name: b\n    mass: lots\nunits: {length: m, angle: rad}\n"
    )
    (tmp_path / "poses.yaml").write_text(
        "poses: {b: {xyz: [0, 0, 0]}}\nunits: {length: m, angle: rad}\n"
    )
    result = cli(["validate", "--json", str(tmp_path)])
    assert result.exit_code == 2
    payload = json.loads(result.stdout)
    assert payload["valid"] is False
    err = payload["files"][0]["errors"][0]
    assert (err["line"], err["column"], err["location"]) == (4, 11, "objects[0].mass")
    assert result.stderr == ""


def test_validate_pose_file_alone(cli):
    import yaml

    count = len(yaml.safe_load((REPO / "workcells/puma560/poses.yaml").read_text())["poses"])
    result = cli(["validate", "workcells/puma560/poses.yaml"])
    assert result.exit_code == 0 and f"{count} pose(s)" in result.stdout


def test_group_json_flag_applies_to_subcommand(cli):
    result = cli(["--json", "show", "workcells/calibration_example"])
    assert result.exit_code == 0
    data = json.loads(result.stdout)
    frames = {f["name"]: f for f in data["frames"]}
    assert frames["block"]["affixment"] == {"type": "non_rigid", "kind": "rests_on"}
    assert frames["block.frame4"]["parent"] == "block.frame3"
    assert [c["code"] for c in data["conditions"]] == ["C1", "C12", "C6", "C13"]


def test_show_lists_every_frame_with_world_pose(cli, example_cell):
    result = cli(["show", str(example_cell)])
    assert result.exit_code == 0, result.stderr
    data = json.loads(cli(["show", "--json", str(example_cell)]).stdout)
    for frame in data["frames"][1:]:
        assert frame["name"] in result.stdout


def test_show_with_joint_values(cli):
    q = "0,0,0,0,0,0"
    data = json.loads(cli(["show", "--json", "workcells/puma560", "--joints", f"puma={q}"]).stdout)
    tool = next(f for f in data["frames"] if f["name"] == "puma.tool")
    # reference 'qz' configuration: tool at (0.4521, -0.15005, 0.4318 + 0.67183)
    assert [round(v, 5) for v in tool["xyz"]] == [0.4521, -0.15005, 1.10363]


def test_bad_usage_exits_2_without_traceback(cli):
    for args in (
        ["show", "workcells/puma560", "--joints", "puma=1,2"],
        ["show", "workcells/puma560", "--joints", "nope"],
        ["show", "workcells/puma560", "--joints", "robo=1"],
        ["show", "no/such/cell"],
        ["valdate"],
    ):
        result = cli(args)
        assert result.exit_code == 2, (args, result.output)
        assert "Traceback" not in result.output


def test_schemas_are_up_to_date(cli):
    result = cli(["schema", "--check", "-o", str(REPO / "schemas")])
    assert result.exit_code == 0, "schemas/ is stale: run 'rworld schema'"


def test_schema_check_detects_stale(cli, tmp_path):
    assert cli(["schema", "-o", str(tmp_path)]).exit_code == 0
    (tmp_path / "cell.schema.json").write_text("{}")
    assert cli(["schema", "--check", "-o", str(tmp_path)]).exit_code == 1


def test_help_lists_commands_without_importing_heavy_modules():
    code = (
        "import sys; from rworld_cli.cli import main\n"
        "try:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
        "heavy = [m for m in ('numpy', 'pydantic', 'scipy', 'trimesh', 'rich', 'matplotlib') if m "
        "in sys.modules]\n"
        "print('HEAVY', heavy)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    assert "validate" in out and "show" in out and "schema" in out
    assert "HEAVY []" in out


def test_validate_reads_files_without_loading_the_physics_rooms():
    """``validate`` is what CI runs on every change: it reads and cross-checks files only, so
    kinematics, dynamics, calibration, collision and simulation stay unimported (a module-level
    import in the api package once loaded them all: +8 % on every command's start-up)."""
    code = (
        "import sys; from rworld_cli.cli import main\n"
        f"try:\n    main(['validate', {str(REPO / 'workcells' / 'puma560')!r}])\n"
        "except SystemExit:\n    pass\n"
        "rooms = ('kinematics', 'dynamics', 'calibration', 'collision', 'simulate', 'planning')\n"
        "names = {m.split('.')[1] for m in sys.modules if m.startswith('rworld_cli.')}\n"
        "print('LOADED', sorted(names & set(rooms)))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    assert "LOADED []" in out, out


def test_readme_commands_match_ci():
    readme = (REPO / "README.md").read_text()
    blocks = re.findall(r"```sh\n(.*?)\n```", readme, re.S)
    assert len(blocks) >= 2
    setup_demo, setup_tests = blocks[0].strip(), blocks[1].strip()
    assert "rworld" in setup_demo and "pytest" in setup_tests
    assert setup_tests in (REPO / ".ci" / "run").read_text()


def test_imported_cells_point_their_editor_at_this_rworlds_schemas(cli, tmp_path, monkeypatch):
    """Issue 62: an imported cell's schema line was '../../schemas/...', right only inside the
    repository.  It now names this rworld's own copy in the user's cache (what `rworld schema
    --where` prints), the same text as the models' schemas, from any folder."""
    import json

    from rworld_cli.api import schema_documents

    monkeypatch.setenv("RWORLD_CACHE_DIR", str(tmp_path / "cache"))
    where = cli(["schema", "--where"])
    assert where.exit_code == 0, where.output
    folder = Path(where.output.strip())
    assert folder.parent == tmp_path / "cache" / "schemas"
    for name, text in schema_documents().items():
        assert (folder / name).read_text() == text
        json.loads(text)
    urdf = tmp_path / "elsewhere" / "arm.urdf"
    urdf.parent.mkdir()
    urdf.write_text(
        '<robot name="ur_arm"><link name="base"/><link name="l1"/>'
        '<joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>'
        '<limit lower="-1" upper="1" velocity="1" effort="1"/></joint></robot>'
    )
    assert cli(["import", "urdf", str(urdf), "-o", str(urdf.parent / "cell")]).exit_code == 0
    for name in ("cell", "poses"):
        first = (urdf.parent / "cell" / f"{name}.yaml").read_text().splitlines()[0]
        assert first == f"# yaml-language-server: $schema={folder / f'{name}.schema.json'}"

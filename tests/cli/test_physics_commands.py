"""rworld kinematics / dynamics on the example cells, against the reference values."""

from __future__ import annotations

import json

import numpy as np
import pytest

from rworld_cli.kinematics.jacobian import tool_pose
from rworld_cli.schema.loader import load_cell
from tests.reference import load_reference, states

REF = load_reference("puma560.json")["model"]
N = 6
HEADER = ",".join(
    [f"q{i}" for i in range(1, 7)]
    + [f"qd{i}" for i in range(1, 7)]
    + [f"qdd{i}" for i in range(1, 7)]
)


@pytest.fixture
def states_csv(tmp_path):
    path = tmp_path / "states.csv"
    rows = [",".join(repr(v) for v in s["q"] + s["qd"] + s["qdd"]) for s in REF["states"]]
    path.write_text("# reference states\n" + HEADER + "\n" + "\n".join(rows) + "\n")
    return path


def test_inverse_dynamics_json_matches_reference(cli, states_csv):
    result = cli(
        [
            "dynamics",
            "inverse",
            "workcells/puma560",
            "--device",
            "puma",
            "--states",
            str(states_csv),
            "--no-armature",
            "--no-friction",
            "--json",
        ]
    )
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert data["device"] == "puma"
    np.testing.assert_allclose(data["tau"], states(REF, "tau_rnea"), atol=1e-9, rtol=0)


def test_inverse_dynamics_csv_file_with_payload_and_motor_terms(cli, states_csv, tmp_path):
    out = tmp_path / "tau.csv"
    bare = json.loads(
        cli(
            ["dynamics", "inverse", "workcells/puma560", "--states", str(states_csv), "--json"]
        ).stdout
    )
    result = cli(
        [
            "dynamics",
            "inverse",
            "workcells/puma560",
            "--states",
            str(states_csv),
            "--payload-mass",
            "2.0",
            "-o",
            str(out),
        ]
    )
    assert result.exit_code == 0, result.output
    lines = out.read_text().splitlines()
    assert (
        lines[0] == ",".join(f"tau{i}" for i in range(1, 7))
        and len(lines) == len(REF["states"]) + 1
    )
    loaded = np.array([[float(v) for v in line.split(",")] for line in lines[1:]])
    assert np.abs(loaded - np.array(bare["tau"])).max() > 1.0  # 2 kg at the flange shows
    rigid = np.array(
        json.loads(
            cli(
                [
                    "dynamics",
                    "inverse",
                    "workcells/puma560",
                    "--states",
                    str(states_csv),
                    "--json",
                    "--no-armature",
                    "--no-friction",
                ]
            ).stdout
        )["tau"]
    )
    assert (
        np.abs(np.array(bare["tau"]) - rigid).max() > 1.0
    )  # armature and friction are on by default


def test_forward_dynamics_round_trip(cli, tmp_path):
    path = tmp_path / "fd.csv"
    cols = (
        [f"q{i}" for i in range(1, 7)]
        + [f"qd{i}" for i in range(1, 7)]
        + [f"tau{i}" for i in range(1, 7)]
    )
    path.write_text(
        ",".join(cols)
        + "\n"
        + "\n".join(
            ",".join(repr(v) for v in s["q"] + s["qd"] + s["fd_tau"]) for s in REF["states"]
        )
        + "\n"
    )
    data = json.loads(
        cli(
            [
                "dynamics",
                "forward",
                "workcells/puma560",
                "--states",
                str(path),
                "--json",
                "--no-armature",
                "--no-friction",
            ]
        ).stdout
    )
    np.testing.assert_allclose(data["qdd"], states(REF, "fd_qdd"), atol=1e-9, rtol=0)


def test_fk_and_jacobian_match_reference(cli):
    s = REF["states"][0]
    q = ",".join(repr(v) for v in s["q"])
    fk = json.loads(cli(["kinematics", "fk", "workcells/puma560", "--q", q, "--json"]).stdout)
    np.testing.assert_allclose(fk["T_world_tool"][0], s["T_tool"], atol=1e-12)
    jac = json.loads(
        cli(["kinematics", "jacobian", "workcells/puma560", "--q", q, "--json"]).stdout
    )
    np.testing.assert_allclose(jac["jacobian"][0], s["J0_tool"], atol=1e-12)
    assert jac["manipulability"][0] > 0 and jac["condition_number"][0] > 1


def test_ik_reaches_a_cell_frame(cli):
    data = json.loads(
        cli(
            ["kinematics", "ik", "workcells/puma560", "--target", "workpiece.grasp", "--json"]
        ).stdout
    )
    assert data["success"] and data["position_error"] < 1e-6
    world_T = load_cell("workcells/puma560")
    from rworld_cli.world.tree import World

    world = World(world_T.cell)
    device = world_T.cell.devices["puma"]
    np.testing.assert_allclose(
        tool_pose(device, np.array(data["q"])), world.T_world("workpiece.grasp"), atol=1e-6
    )


def test_ik_on_an_aggregated_hand_tcp(cli):
    """The robot of the Fig. 9 cell reaches the drop zone with hand_a's TCP (carried via the tool
    plate)
    once the conveyor has brought it closer; from the conveyor's home it is out of reach."""
    args = [
        "kinematics",
        "ik",
        "workcells/paper_fig9",
        "-d",
        "robot",
        "--tcp",
        "hand_a.tcp",
        "--target",
        "drop_zone",
        "--position-only",
        "--json",
    ]
    far = cli(args)
    assert far.exit_code == 2 and "unreachable" in far.stdout
    result = cli(args + ["--joints", "conveyor=1.5"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["position_error"] < 1e-6


def test_unreachable_target_exits_2_with_the_distance(cli):
    result = cli(["kinematics", "ik", "workcells/puma560", "--xyz", "3,0,0", "--position-only"])
    assert result.exit_code == 2
    assert (
        "unreachable" in result.stderr
        and " mm" in result.stderr
        and "Traceback" not in result.output
    )


def test_static_hold_and_capacity(cli):
    data = json.loads(
        cli(
            [
                "dynamics",
                "static",
                "workcells/puma560",
                "--q",
                "0,0.5,-1,0,0.3,0",
                "--wrench",
                "0,0,-50,0,0,0",
                "--json",
            ]
        ).stdout
    )
    tau = np.array(data["tau"][0])
    np.testing.assert_allclose(
        tau, np.array(data["tau_gravity"][0]) + np.array(data["tau_wrench"][0])
    )
    effort = [97.6, 186.4, 89.4, 24.2, 20.1, 21.3]
    s = data["max_scale"][0]
    j = int(data["limiting_joint"][0][1:]) - 1
    at_limit = data["tau_gravity"][0][j] + s * data["tau_wrench"][0][j]
    assert abs(abs(at_limit) - effort[j]) < 1e-9  # the binding joint sits exactly on its limit


@pytest.mark.parametrize(
    "content, message",
    [
        ("q1,q2,q3\n1,2,3\n", "missing column(s) q4, q5, q6"),
        ("q1,q2,q3,q4,q5,q6\n1,2,3,4,5\n", "5 field(s) separated by ',' but the header has 6"),
        ("q1,q2,q3,q4,q5,q6\n1,2,x,4,5,6\n", ":2:5: column 'q3': expected a number, got 'x'"),
        ("q1,q2,q3,q4,q5,q6\n1,2,3,nan,5,6\n", "column 'q4': expected a finite number, got 'nan'"),
        ("q1,q2,q3,q4,q5,q6\n", "no data rows"),
        ("", "the file is empty"),
    ],
)
def test_bad_state_files_exit_2_with_positions(cli, tmp_path, content, message):
    path = tmp_path / "bad.csv"
    path.write_text(content)
    result = cli(["kinematics", "fk", "workcells/puma560", "--states", str(path)])
    assert result.exit_code == 2, result.output
    assert message in result.stderr and "Traceback" not in result.output


def test_out_of_limit_values_are_warned_not_refused(cli):
    result = cli(["kinematics", "fk", "workcells/puma560", "--q", "0,-2,0,0,0,0"])
    assert result.exit_code == 0
    assert "warning: row 1: q2 = -2 is outside its limits" in result.stderr


@pytest.mark.parametrize(
    "args, message",
    [
        (["kinematics", "fk", "workcells/paper_fig9", "--q", "0"], "choose one with --device"),
        (["kinematics", "fk", "workcells/puma560", "-d", "pума", "--q", "0"], "unknown device"),
        (["kinematics", "fk", "workcells/puma560", "--q", "1,2"], "expected 6 values"),
        (
            [
                "kinematics",
                "fk",
                "workcells/puma560",
                "--tcp",
                "table.top_center",
                "--q",
                "0,0,0,0,0,0",
            ],
            "not carried by device",
        ),
        (["dynamics", "inverse", "workcells/puma560", "--states", "no/such.csv"], "no such file"),
        (
            ["dynamics", "inverse", "workcells/puma560", "--states", "x.csv", "--payload", "tabel"],
            "did you mean 'table'",
        ),
        (
            ["dynamics", "static", "workcells/puma560", "--q", "0,0,0,0,0,0", "--wrench", "1,2"],
            "expected 6 values",
        ),
    ],
)
def test_bad_arguments_exit_2(cli, tmp_path, args, message):
    (tmp_path / "x.csv").write_text(HEADER + "\n" + ",".join(["0"] * 18) + "\n")
    result = cli([str(tmp_path / a) if a == "x.csv" else a for a in args])
    assert result.exit_code == 2, result.output
    assert message in result.output and "Traceback" not in result.output


def test_a_one_column_state_file_reads(tmp_path):
    """A one-joint device's q column alone: no delimiter on the line, still CSV."""
    from rworld_cli.schema.tables import read_states

    (tmp_path / "q.csv").write_text("\ufeffq1\n0.5\n-0.25\n")
    assert read_states(str(tmp_path / "q.csv"), 1, ["q"])["q"].ravel().tolist() == [0.5, -0.25]

"""Loads are counted once and said: a payload given twice is refused, every result that
includes carried loads names them, joints without a limit show n/a (never 0 or inf), and a
massless model is bad input, not a bug."""

from __future__ import annotations

import json
import shutil

import pytest

from tests.conftest import WORKCELLS

STATE = (
    "q1,q2,q3,q4,q5,q6,qd1,qd2,qd3,qd4,qd5,qd6,qdd1,qdd2,qdd3,qdd4,qdd5,qdd6\n"
    "0,0.5,-1,0,0.3,0,0,0,0,0,0,0,0,0,0,0,0,0\n"
)
TORQUES = "q1,q2,q3,q4,q5,q6,qd1,qd2,qd3,qd4,qd5,qd6,tau1,tau2,tau3,tau4,tau5,tau6\n" + (
    "0,0.5,-1,0,0.3,0,0,0,0,0,0,0,1,1,1,1,1,1\n"
)


def _puma(tmp_path, grasped=False, efforts=True, massless=False):
    cell = tmp_path / "puma560"
    shutil.copytree(WORKCELLS / "puma560", cell)
    text = (cell / "cell.yaml").read_text()
    if grasped:
        text = text.replace(
            "{parent: table.top_center, child: workpiece, type: non_rigid, kind: rests_on}",
            "{parent: puma.probe, child: workpiece, type: rigid, kind: grasp}",
        )
    if not efforts:
        text = "\n".join(x for x in text.splitlines() if not x.strip().startswith("effort:"))
    if massless:
        import yaml

        doc = yaml.safe_load(text)
        for link in doc["devices"][0]["links"]:
            link["mass"] = 0.0
            link.pop("inertia", None)
            link.pop("com", None)
        for joint in doc["devices"][0]["joints"]:
            joint.pop("motor", None)
            joint.pop("friction", None)
        text = yaml.safe_dump(doc, sort_keys=False)
    (cell / "cell.yaml").write_text(text + "\n")
    (tmp_path / "states.csv").write_text(STATE)
    (tmp_path / "torques.csv").write_text(TORQUES)
    return cell


def test_a_point_mass_beside_a_grasped_part_is_a_load_given_twice(cli, tmp_path):
    cell = _puma(tmp_path, grasped=True)
    states = str(tmp_path / "states.csv")
    out = cli(["dynamics", "inverse", str(cell), "--states", states, "--payload-mass", "1"])
    assert out.exit_code == 2
    assert "a load given twice: --payload-mass 1 kg at puma.tool, and 'workpiece'" in out.output
    path = str(WORKCELLS / "puma560" / "paths" / "reference.yaml")
    out = cli(["plan", "time-optimal", str(cell), "--path", path, "--payload-mass", "1"])
    assert out.exit_code == 2 and "a load given twice" in out.output
    # the part as the payload counts it once: the same torques as carried
    carried = json.loads(
        cli(["dynamics", "inverse", str(cell), "--states", states, "--json"]).stdout
    )
    as_payload = json.loads(
        cli(
            ["dynamics", "inverse", str(cell), "--states", states, "--tcp", "probe"]
            + ["--payload", "workpiece", "--json"]
        ).stdout
    )
    assert carried["tau"][0] == pytest.approx(as_payload["tau"][0], abs=1e-9)
    assert carried["notes"] == [
        "includes what puma carries in the cell's state: workpiece, 1.2 kg on link 6"
    ]
    assert as_payload["notes"] == ["includes the payload: 'workpiece', 1.2 kg at puma.probe"]


def test_every_result_says_what_loads_it_includes(cli, tmp_path):
    cell = _puma(tmp_path, grasped=True)
    out = cli(["dynamics", "inverse", str(cell), "--states", str(tmp_path / "states.csv")])
    assert out.exit_code == 0
    assert "note: includes what puma carries in the cell's state: workpiece, 1.2 kg" in out.stderr
    path = str(WORKCELLS / "puma560" / "paths" / "reference.yaml")
    plan = json.loads(cli(["plan", "time-optimal", str(cell), "--path", path, "--json"]).stdout)
    assert plan["carried"] == [{"name": "workpiece", "link": 6, "mass": 1.2}]
    assert plan["loads_counted"] is True and plan["notes"]
    free = json.loads(
        cli(["plan", "time-optimal", str(cell), "--path", path, "--no-torque", "--json"]).stdout
    )
    assert free["carried"] == plan["carried"] and free["loads_counted"] is False


@pytest.mark.filterwarnings("error")
def test_joints_without_a_torque_limit_show_n_a_and_refuse_a_capacity(cli, tmp_path):
    cell = _puma(tmp_path, efforts=False)
    out = cli(["simulate", str(cell), "pick_place", "-o", str(tmp_path / "out"), "--plot"])
    assert out.exit_code == 0, out.output
    assert "n/a (no limits)" in out.stdout and "warning" not in out.stderr.lower()
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["devices"]["puma"]["peak_ratio"]["torque"] == [None] * 6
    path = str(WORKCELLS / "puma560" / "paths" / "reference.yaml")
    out = cli(["plan", "payload", str(cell), "--path", path, "--tcp", "probe", "--json"])
    assert out.exit_code == 2
    assert "has a torque (effort) limit, so nothing bounds its payload" in out.stdout
    assert "Infinity" not in out.stdout


def test_a_massless_robot_is_bad_input_and_said(cli, tmp_path):
    cell = _puma(tmp_path, massless=True)
    out = cli(["dynamics", "forward", str(cell), "--states", str(tmp_path / "torques.csv")])
    assert out.exit_code == 2, out.output
    assert "mass matrix of 'puma' is singular" in out.output and "<inertial>" in out.output
    out = cli(["dynamics", "inverse", str(cell), "--states", str(tmp_path / "states.csv")])
    assert out.exit_code == 0
    assert "every link of 'puma' is massless" in out.stderr

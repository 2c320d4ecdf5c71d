"""URDF import and export, against Pinocchio loading the same files.

The robots are real URDFs nobody here wrote: the ``example-robot-data`` package (UR5, the Panda's
arm, the Kinova Jaco 2).  For each, rworld's imported device must give Pinocchio's tool pose,
Jacobian, inverse dynamics, mass matrix and forward dynamics to 1e-9 on 20 random states; an
exported cell must load in Pinocchio and yourdfpy and give the same numbers; import, export and
import again must give the same model.
"""

from __future__ import annotations

from importlib.metadata import distribution
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import yourdfpy

from rworld_cli.api import (
    device_context,
    device_dynamics,
    export_urdf,
    forward_kinematics,
    import_urdf,
    jacobians,
)
from rworld_cli.schema.loader import load_cell
from tests.conftest import WORKCELLS, run_cli

SHARE = Path(str(distribution("example-robot-data").locate_file("cmeel.prefix/share")))
ROBOTS = SHARE / "example-robot-data" / "robots"
TOL = 1e-9

# name, URDF, import options, Pinocchio frame of the TCP, joints Pinocchio locks at 0
CASES = {
    "ur5": ("ur_description/urdf/ur5_robot.urdf", {}, "tool0", ()),
    "panda": (
        "panda_description/urdf/panda.urdf",
        {"tip": "panda_hand"},
        "panda_hand",
        ("panda_finger_joint1", "panda_finger_joint2"),
    ),
    "kinova": ("kinova_description/robots/kinova.urdf", {}, "j2s6s200_link_6", ()),
}


@pytest.fixture(scope="module")
def imported(tmp_path_factory) -> dict:
    root = tmp_path_factory.mktemp("urdf")
    out = {}
    for name, (urdf, options, _, _) in CASES.items():
        out[name] = import_urdf(
            str(ROBOTS / urdf), str(root / name), package_paths=[str(SHARE)], **options
        )
    return out


def _pinocchio(urdf: Path, locked=()):
    model = pin.buildModelFromUrdf(str(urdf))
    if locked:
        ids = [model.getJointId(n) for n in locked]
        model = pin.buildReducedModel(model, ids, pin.neutral(model))
    return model, model.createData()


def _configuration(model, angles: np.ndarray) -> np.ndarray:
    """Pinocchio's q for joint angles: continuous joints are (cos, sin)."""
    out: list[float] = []
    for joint, a in zip(list(model.joints)[1:], angles):
        out += [np.cos(a), np.sin(a)] if joint.nq == 2 else [a]
    return np.array(out)


def _worst_differences(cell: str, device: str, model, data, frame: str, seed: int = 7) -> dict:
    ctx = device_context(cell, device)
    dyn = device_dynamics(ctx, friction=False)  # Pinocchio's RNEA leaves URDF damping out
    rng = np.random.default_rng(seed)
    fid = model.getFrameId(frame)
    assert fid < len(model.frames), frame
    worst: dict[str, float] = {}
    for _ in range(20):
        angles = rng.uniform(-np.pi, np.pi, model.nv)
        qd, qdd = rng.uniform(-2, 2, model.nv), rng.uniform(-5, 5, model.nv)
        tau = rng.uniform(-20, 20, model.nv)
        q = _configuration(model, angles)
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacements(model, data)
        M = pin.crba(model, data, q)
        pairs = {
            "tool pose": (forward_kinematics(ctx, angles), data.oMf[fid].homogeneous),
            "jacobian": (
                jacobians(ctx, angles).jacobian[0],
                pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED),
            ),
            "inverse dynamics": (dyn.inverse(angles, qd, qdd), pin.rnea(model, data, q, qd, qdd)),
            "mass matrix": (dyn.mass_matrix(angles), np.triu(M) + np.triu(M, 1).T),
            "forward dynamics": (dyn.forward(angles, qd, tau), pin.aba(model, data, q, qd, tau)),
        }
        for what, (ours, theirs) in pairs.items():
            worst[what] = max(worst.get(what, 0.0), float(np.abs(ours - theirs).max()))
    return worst


@pytest.mark.parametrize("name", list(CASES))
def test_imported_robot_matches_pinocchio(name, imported):
    urdf, _, frame, locked = CASES[name]
    model, data = _pinocchio(ROBOTS / urdf, locked)
    result = imported[name]
    assert result.dof == model.nv
    worst = _worst_differences(result.cell, result.device, model, data, frame)
    print(f"{name}: " + ", ".join(f"{k} {v:.1e}" for k, v in worst.items()))  # pytest -s shows
    assert max(worst.values()) <= TOL, worst


def test_import_keeps_the_urdf_structure(imported):
    ur5 = load_cell(imported["ur5"].cell).cell.devices["ur5"]
    assert ur5.convention == "frames"
    assert [j.name for j in ur5.joints][:2] == ["shoulder_pan_joint", "shoulder_lift_joint"]
    assert ur5.tcps == ("ur5.tool0",)  # the ROS-Industrial flange frame is the default TCP
    np.testing.assert_allclose(ur5.joints[0].limits.velocity, 3.15)
    np.testing.assert_allclose(ur5.joints[0].limits.effort, 150.0)
    np.testing.assert_allclose(ur5.joints[0].limits.upper, 6.28318530718)
    panda = imported["panda"]
    assert panda.merged["panda_link7"][:3] == ["panda_link7", "panda_link8", "panda_hand"]
    locked = [w for w in panda.warnings if "locked at 0" in w.message]
    assert {w.location for w in locked} == {
        "joint[panda_finger_joint1]",
        "joint[panda_finger_joint2]",
    }
    kinova = load_cell(imported["kinova"].cell).cell.devices["kinova"]
    assert not np.isfinite(kinova.joints[0].limits.upper)  # continuous
    # several collision shapes of one link joined into one mesh file
    assert (Path(imported["kinova"].cell) / "meshes" / "j2s6s200_link_1.stl").is_file()


def test_tree_without_tip_names_the_branches(tmp_path, cli):
    result = cli(
        [
            "import",
            "urdf",
            str(ROBOTS / "panda_description/urdf/panda.urdf"),
            "-o",
            str(tmp_path / "panda"),
            "--package-path",
            str(SHARE),
        ]
    )
    assert result.exit_code == 2
    assert "branches at link 'panda_hand'" in result.stderr
    assert "--tip" in result.stderr
    assert not (tmp_path / "panda").exists()


def _same_device(a, b, tol=1e-12):
    assert [j.name for j in a.joints] == [j.name for j in b.joints]
    for ja, jb in zip(a.joints, b.joints):
        assert ja.kind == jb.kind
        np.testing.assert_allclose(ja.origin, jb.origin, atol=tol)
        np.testing.assert_allclose(ja.axis, jb.axis, atol=tol)
        for limit in ("lower", "upper", "velocity", "effort"):
            assert getattr(ja.limits, limit) == pytest.approx(getattr(jb.limits, limit), abs=tol)
        assert ja.viscous == pytest.approx(jb.viscous, abs=tol)
    for la, lb in zip(a.links, b.links):
        assert la.name == lb.name
        assert la.inertial.mass == pytest.approx(lb.inertial.mass, abs=tol)
        np.testing.assert_allclose(la.inertial.com, lb.inertial.com, atol=tol)
        np.testing.assert_allclose(la.inertial.inertia, lb.inertial.inertia, atol=tol)
        assert (la.shape is None) == (lb.shape is None)
        if la.shape is not None:
            np.testing.assert_allclose(la.shape.T_owner_shape, lb.shape.T_owner_shape, atol=tol)


@pytest.mark.parametrize("name", ["ur5", "panda"])
def test_import_export_import_gives_the_same_model(name, imported, tmp_path):
    first = load_cell(imported[name].cell).cell
    urdf = tmp_path / f"{name}.urdf"
    export_urdf(imported[name].cell, str(urdf))
    again = import_urdf(str(urdf), str(tmp_path / "again"), **CASES[name][1])  # same options
    second = load_cell(again.cell).cell
    device = imported[name].device
    _same_device(first.devices[device], second.devices[device])
    frames = {n for n, d in first.frames.items() if d.owner == device}
    assert frames == {n for n, d in second.frames.items() if d.owner == device}
    for frame in frames:
        if frame in first.poses:
            np.testing.assert_allclose(first.poses[frame], second.poses[frame], atol=1e-12)
    assert first.devices[device].tcps == second.devices[device].tcps


def test_exported_dh_robot_loads_in_pinocchio_and_yourdfpy(tmp_path):
    """The Puma (standard DH) out to URDF: Pinocchio gives rworld's numbers (no armature: URDF
    has none), and yourdfpy reads the file with its meshes."""
    urdf = tmp_path / "puma.urdf"
    result = export_urdf(str(WORKCELLS / "puma560"), str(urdf))
    assert "acceleration limit" in result.note and "armature" in result.note
    model, data = _pinocchio(urdf)
    ctx = device_context(str(WORKCELLS / "puma560"), "puma")
    dyn = device_dynamics(ctx, armature=False, friction=False)
    rng = np.random.default_rng(3)
    for _ in range(20):
        q, qd, qdd = rng.uniform(-2, 2, (3, 6))
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacements(model, data)
        np.testing.assert_allclose(
            data.oMf[model.getFrameId("tool")].homogeneous, forward_kinematics(ctx, q), atol=TOL
        )
        np.testing.assert_allclose(
            pin.rnea(model, data, q, qd, qdd), dyn.inverse(q, qd, qdd), atol=TOL
        )
    robot = yourdfpy.URDF.load(str(urdf))
    assert "link6" in robot.link_map and "probe" in robot.link_map


def test_calibrated_overlay_moves_the_exported_tcp(tmp_path):
    """Pose files are applied in order: an overlay after poses.yaml moves the TCP in the URDF."""
    import shutil

    cell = tmp_path / "ur5"
    shutil.copytree(WORKCELLS / "ur5", cell)
    tcp = next(n for n, d in load_cell(cell).cell.frames.items() if d.kind == "tcp")
    text = (cell / "cell.yaml").read_text()
    (cell / "cell.yaml").write_text(
        text.replace("pose_files: [poses.yaml]", "pose_files: [poses.yaml, calibrated.yaml]")
    )
    (cell / "calibrated.yaml").write_text(
        f"units: {{length: mm, angle: deg}}\nposes:\n  {tcp}: {{xyz: [1.5, -2, 30]}}\n"
    )
    urdf = tmp_path / "ur5.urdf"
    export_urdf(str(cell), str(urdf))
    model, data = _pinocchio(urdf)
    frame = tcp.split(".", 1)[1]
    ctx = device_context(str(cell), tcp.split(".")[0])
    q = np.array([0.3, -1.0, 1.2, 0.4, -0.5, 0.6])
    pin.forwardKinematics(model, data, q)
    pin.updateFramePlacements(model, data)
    np.testing.assert_allclose(
        data.oMf[model.getFrameId(frame)].homogeneous, forward_kinematics(ctx, q), atol=TOL
    )


def test_cli_import_writes_a_cell_that_validates(tmp_path, cli):
    out = tmp_path / "ur5"
    args = ["import", "urdf", str(ROBOTS / CASES["ur5"][0]), "-o", str(out)]
    result = cli([*args, "--package-path", str(SHARE), "--json"])
    assert result.exit_code == 0, result.output
    assert cli(["validate", str(out / "cell.yaml")]).exit_code == 0
    again = cli([*args, "--package-path", str(SHARE)])
    assert again.exit_code == 2 and "--force" in again.stderr  # an existing cell is kept
    assert cli([*args, "--package-path", str(SHARE), "--force"]).exit_code == 0
    result = run_cli(["export", "urdf", str(out), "-o", str(tmp_path / "r.urdf")])
    assert result.exit_code == 0 and (tmp_path / "r.urdf").is_file()


def test_imported_panda_example_simulates_and_plans(cli):
    """workcells/panda (imported from the Panda's URDF): a program runs with collision checks,
    a path is timed under torque limits - the joint-frame device through the whole tool."""
    cell = str(WORKCELLS / "panda")
    result = cli(["check", cell, "pick_place", "--clearance", "5mm"])
    assert result.exit_code == 0, result.output
    assert "no collisions" in result.stdout
    path = str(WORKCELLS / "panda" / "paths" / "sweep.yaml")
    result = cli(["plan", "time-optimal", cell, "--path", path, "--json"])
    assert result.exit_code == 0, result.output


def test_rotated_inertial_origin_and_a_link_without_inertial(tmp_path):
    """An <inertial> whose <origin> turns the inertia's axes is taken in the link frame (R I R^T);
    a moving link without <inertial> is massless, with a warning naming it (here it carries a
    hand on a fixed joint, whose mass it takes)."""
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(
        """<?xml version="1.0"?>
<robot name="arm">
  <link name="base"/>
  <link name="upper">
    <inertial>
      <origin xyz="0.1 0.02 -0.03" rpy="0.4 -0.7 1.1"/>
      <mass value="2.5"/>
      <inertia ixx="0.02" ixy="0.001" ixz="0" iyy="0.05" iyz="0.002" izz="0.04"/>
    </inertial>
  </link>
  <link name="fore"/>
  <link name="hand">
    <inertial>
      <origin xyz="0 0 0.05" rpy="0 0.2 0"/>
      <mass value="0.8"/>
      <inertia ixx="0.002" ixy="0" ixz="0" iyy="0.003" iyz="0" izz="0.001"/>
    </inertial>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="upper"/>
    <origin xyz="0 0 0.3" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="50" velocity="2"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="upper"/><child link="fore"/>
    <origin xyz="0.4 0 0" rpy="0.3 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" effort="50" velocity="2"/>
  </joint>
  <joint name="wrist" type="fixed">
    <parent link="fore"/><child link="hand"/>
    <origin xyz="0.2 0 0" rpy="0 0.5 0"/>
  </joint>
</robot>
"""
    )
    result = import_urdf(str(urdf), str(tmp_path / "arm"), tcp="hand")
    massless = [w for w in result.warnings if "no <inertial>" in w.message]
    assert [(w.location, w.line) for w in massless] == [("link[fore]", 11)]
    model, data = _pinocchio(urdf)
    worst = _worst_differences(result.cell, "arm", model, data, "hand")
    assert max(worst.values()) <= TOL, worst


def test_meshes_scaled_copied_or_joined(tmp_path):
    """A mesh in mm (scale 0.001) is copied with 'units: mm'; a link with several shapes (and a
    fixed child with one) becomes one STL joining them, in the link frame."""
    import trimesh

    (tmp_path / "meshes").mkdir()
    trimesh.creation.box(extents=[100, 40, 20]).export(tmp_path / "meshes" / "arm_mm.stl")
    urdf = tmp_path / "robot.urdf"
    urdf.write_text(
        """<robot name="r">
  <link name="base"/>
  <link name="arm">
    <inertial><mass value="1"/>
      <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry>
      <mesh filename="meshes/arm_mm.stl" scale="0.001 0.001 0.001"/></geometry></collision>
  </link>
  <link name="fore">
    <inertial><mass value="1"/>
      <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0.1 0 0"/><geometry><box size="0.2 0.05 0.05"/></geometry></collision>
    <collision><origin xyz="0.2 0 0" rpy="0 1.5707963267948966 0"/>
      <geometry><cylinder radius="0.03" length="0.1"/></geometry></collision>
  </link>
  <link name="pad">
    <collision><geometry><sphere radius="0.02"/></geometry></collision>
  </link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="arm"/><child link="fore"/><origin xyz="0.1 0 0"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="pad_joint" type="fixed"><parent link="fore"/><child link="pad"/>
    <origin xyz="0.3 0 0"/></joint>
</robot>
"""
    )
    result = import_urdf(str(urdf), str(tmp_path / "cell"))
    cell = load_cell(result.cell).cell
    arm, fore = cell.devices["r"].links
    assert arm.shape.mesh_scale == 0.001  # copied as is, in mm
    np.testing.assert_allclose(arm.shape.size, [0.1, 0.04, 0.02], atol=1e-12)
    assert (Path(result.cell) / "meshes" / "arm.stl").read_bytes() == (
        tmp_path / "meshes" / "arm_mm.stl"
    ).read_bytes()
    joined = trimesh.load(Path(result.cell) / "meshes" / "fore.stl")
    assert joined.body_count == 3  # box, cylinder and the fixed pad's sphere
    lo, hi = joined.bounds
    np.testing.assert_allclose(lo, [0.0, -0.03, -0.03], atol=1e-6)
    np.testing.assert_allclose(hi, [0.32, 0.03, 0.03], atol=1e-6)
    assert cell.frames["r.pad"].parent == "r.fore"  # the fixed link, kept as a frame

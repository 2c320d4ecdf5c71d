"""Devices given by joint frames (origin, axis) in the cell format: fixed joints merged, continuous
and prismatic joints, tilted axes - against Pinocchio reading the same robot as URDF."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import yaml
from scipy.spatial.transform import Rotation

from rworld_cli.api import device_context, device_dynamics, forward_kinematics, jacobians
from rworld_cli.schema.loader import load_cell

CELL = """
name: frames_arm
units: {length: mm, angle: deg}
pose_files: [poses.yaml]
devices:
  - name: arm
    dof: 4
    joints:
      - {name: j1, type: continuous, origin: {xyz: [0, 0, 300]}, limits: {velocity: 90}}
      - {name: j2, type: revolute, origin: {xyz: [0, 50, 0], rpy: [90, 0, 0]}, axis: [0, 0, 2],
         limits: {position: [-120, 120]}}
      - {name: bracket, type: fixed, origin: {xyz: [250, 0, 0], rpy: [0, 0, 30]}}
      - {name: j3, type: prismatic, origin: {xyz: [0, 0, 40]}, axis: [1, 1, 0],
         limits: {position: [0, 200]}}
      - {name: j4, type: revolute, origin: {xyz: [100, 0, 0], rpy: [0, -90, 0]}, axis: [0, 1, 0]}
    links:
      - {name: l1, mass: 3.0, com: [0, 0, -100], inertia: {ixx: 0.02, iyy: 0.02, izz: 0.01}}
      - {name: l2, mass: 2.0, com: [120, 0, 0],
         inertia: {ixx: 0.004, iyy: 0.03, izz: 0.03, ixy: 0.001}}
      - {name: bracket_plate, mass: 0.5, com: [10, 5, 0],
         inertia: {ixx: 0.001, iyy: 0.002, izz: 0.002}, geometry: {box: [40, 40, 10]}}
      - {name: l3, mass: 1.0, com: [0, 20, 0],
         inertia: {ixx: 0.002, iyy: 0.001, izz: 0.002, iyz: 0.0002}}
      - {name: l4, mass: 0.4, com: [0, 0, 30], inertia: {ixx: 0.0005, iyy: 0.0005, izz: 0.0002}}
    tcps:
      - {name: tool}
"""
POSES = """
units: {length: mm, angle: deg}
poses:
  arm: {xyz: [0, 0, 0]}
  arm.tool: {xyz: [0, 0, 80]}
"""


def _urdf() -> str:
    """The same robot written as URDF by hand (SI units, radians)."""
    d = np.radians

    def origin(xyz, rpy=(0, 0, 0)):
        xyz = " ".join(str(v / 1000) for v in xyz)
        return f'<origin xyz="{xyz}" rpy="{" ".join(str(float(d(v))) for v in rpy)}"/>'

    def link(name, mass, com, ixx, iyy, izz, ixy=0.0, iyz=0.0):
        return (
            f'<link name="{name}"><inertial>{origin(com)}<mass value="{mass}"/>'
            f'<inertia ixx="{ixx}" iyy="{iyy}" izz="{izz}" ixy="{ixy}" ixz="0" iyz="{iyz}"/>'
            "</inertial></link>"
        )

    def joint(name, kind, parent, child, o, axis=(0, 0, 1), limit=""):
        return (
            f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'{o}<axis xyz="{" ".join(map(str, axis))}"/>{limit}</joint>'
        )

    limit = '<limit lower="-10" upper="10" effort="0" velocity="0"/>'
    return (
        '<robot name="arm"><link name="base"/>'
        + link("l1", 3.0, (0, 0, -100), 0.02, 0.02, 0.01)
        + link("l2", 2.0, (120, 0, 0), 0.004, 0.03, 0.03, ixy=0.001)
        + link("bracket_plate", 0.5, (10, 5, 0), 0.001, 0.002, 0.002)
        + link("l3", 1.0, (0, 20, 0), 0.002, 0.001, 0.002, iyz=0.0002)
        + link("l4", 0.4, (0, 0, 30), 0.0005, 0.0005, 0.0002)
        + '<link name="tool"/>'
        + joint("j1", "continuous", "base", "l1", origin((0, 0, 300)))
        + joint("j2", "revolute", "l1", "l2", origin((0, 50, 0), (90, 0, 0)), limit=limit)
        + joint("bracket", "fixed", "l2", "bracket_plate", origin((250, 0, 0), (0, 0, 30)))
        + joint(
            "j3",
            "prismatic",
            "bracket_plate",
            "l3",
            origin((0, 0, 40)),
            (0.7071067811865476, 0.7071067811865476, 0),
            limit,
        )
        + joint("j4", "revolute", "l3", "l4", origin((100, 0, 0), (0, -90, 0)), (0, 1, 0), limit)
        + joint("tool_joint", "fixed", "l4", "tool", origin((0, 0, 80)))
        + "</robot>"
    )


def test_joint_frame_device_matches_pinocchio(tmp_path):
    (tmp_path / "cell.yaml").write_text(CELL)
    (tmp_path / "poses.yaml").write_text(POSES)
    cell = load_cell(tmp_path).cell
    arm = cell.devices["arm"]
    assert arm.dof == 4 and [j.name for j in arm.joints] == ["j1", "j2", "j3", "j4"]
    assert not np.isfinite(arm.joints[0].limits.upper)  # continuous
    np.testing.assert_allclose(arm.joints[1].axis, [0, 0, 1])  # normalised
    assert cell.frames["arm.bracket_plate"].kind == "auxiliary"  # the fixed link, kept as a frame
    assert arm.links[1].inertial.mass == 2.5  # ... its mass merged into l2
    assert arm.links[1].shape is not None  # ... and its shape moved onto l2
    model = pin.buildModelFromXML(_urdf())
    data = model.createData()
    ctx = device_context(str(tmp_path), "arm")
    dyn = device_dynamics(ctx)
    fid = model.getFrameId("tool")
    rng = np.random.default_rng(11)
    for _ in range(20):
        angles = rng.uniform(-1.5, 1.5, 4)
        qd, qdd, tau = rng.uniform(-2, 2, (3, 4))
        q = np.concatenate([[np.cos(angles[0]), np.sin(angles[0])], angles[1:]])
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacements(model, data)
        np.testing.assert_allclose(
            forward_kinematics(ctx, angles), data.oMf[fid].homogeneous, atol=1e-12
        )
        J = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)
        np.testing.assert_allclose(jacobians(ctx, angles).jacobian[0], J, atol=1e-12)
        np.testing.assert_allclose(
            dyn.inverse(angles, qd, qdd), pin.rnea(model, data, q, qd, qdd), atol=1e-10
        )
        np.testing.assert_allclose(
            dyn.forward(angles, qd, tau), pin.aba(model, data, q, qd, tau), atol=1e-9
        )
    # the world's link frames (simulation, sensing, collision) agree with the generated kernels
    from rworld_cli.world.tree import World

    world = World(cell)
    world.set_joints("arm", angles)
    np.testing.assert_allclose(
        world.T_world("arm.tool"), forward_kinematics(ctx, angles), atol=1e-12
    )


def test_unit_axes_and_zero_offsets_cost_nothing(tmp_path):
    """The generated kernels fold constants: a joint-frame chain costs no more than its DH form."""
    from rworld_cli.dynamics.rnea import generate_rnea
    from rworld_cli.kinematics.jacobian import generated
    from rworld_cli.schema.cell_to_urdf import urdf_from_cell
    from rworld_cli.schema.urdf import read_urdf, urdf_text
    from rworld_cli.schema.urdf_cell import cell_from_urdf
    from tests.conftest import WORKCELLS

    puma = load_cell(WORKCELLS / "puma560").cell
    robot, _ = urdf_from_cell(puma, "puma", tmp_path / "puma.urdf")
    (tmp_path / "puma.urdf").write_text(urdf_text(robot))
    imported = cell_from_urdf(read_urdf(tmp_path / "puma.urdf")[0], "puma_frames")
    (tmp_path / "cell.yaml").write_text(imported.cell_text)
    (tmp_path / "poses.yaml").write_text(imported.poses_text)
    frames = load_cell(tmp_path).cell.devices["puma"]
    dh = puma.devices["puma"]
    assert frames.convention == "frames"
    assert generated(frames, None, True).operations <= generated(dh, None, True).operations
    inertials = [link.inertial for link in frames.links]
    assert (
        generate_rnea(frames, inertials, "full").operations
        <= 1.01 * generate_rnea(dh, [link.inertial for link in dh.links], "full").operations
    )


def _random_cell(rng) -> tuple[str, int]:
    """A random joint-frame arm: 3-6 moving joints on random axes (revolute, continuous,
    prismatic), random origins, fixed joints with mass between them; SI units."""
    joints, links = [], []
    n_moving = int(rng.integers(3, 7))
    k = 0
    while k < n_moving:
        fixed = k > 0 and rng.random() < 0.3
        kind = "fixed" if fixed else str(rng.choice(["revolute", "continuous", "prismatic"]))
        xyz = [float(v) for v in rng.uniform(-0.3, 0.3, 3)]
        rpy = [float(v) for v in rng.uniform(-np.pi, np.pi, 3)]
        entry = {"name": f"j{len(joints)}", "type": kind, "origin": {"xyz": xyz, "rpy": rpy}}
        if kind != "fixed":
            entry["axis"] = [float(v) for v in rng.normal(size=3)]
            if kind != "continuous":
                entry["limits"] = {"position": [-3.0, 3.0]}
            k += 1
        joints.append(entry)
        box = rng.uniform(0.05, 0.4, 3)
        mass = float(rng.uniform(0.2, 5.0))
        moments = (
            mass
            / 12
            * np.array(
                [box[1] ** 2 + box[2] ** 2, box[0] ** 2 + box[2] ** 2, box[0] ** 2 + box[1] ** 2]
            )
        )
        R = Rotation.random(random_state=int(rng.integers(1 << 30))).as_matrix()
        inertia = R @ np.diag(moments) @ R.T
        links.append(
            {
                "name": f"l{len(links)}",
                "mass": mass,
                "com": [float(v) for v in rng.uniform(-0.1, 0.1, 3)],
                "inertia": {
                    key: float(inertia[a, b])
                    for key, (a, b) in {
                        "ixx": (0, 0),
                        "iyy": (1, 1),
                        "izz": (2, 2),
                        "ixy": (0, 1),
                        "ixz": (0, 2),
                        "iyz": (1, 2),
                    }.items()
                },
            }
        )
    doc = {
        "name": "random",
        "units": {"length": "m", "angle": "rad"},
        "pose_files": ["poses.yaml"],
        "devices": [
            {
                "name": "arm",
                "dof": n_moving,
                "joints": joints,
                "links": links,
                "tcps": [{"name": "tool"}],
            }
        ],
    }
    return yaml.safe_dump(doc, sort_keys=False), n_moving


def test_random_joint_frame_arms_out_to_urdf_match_pinocchio(tmp_path):
    """Seeded loop: random joint-frame arms (tilted axes, prismatic and continuous joints, fixed
    joints with mass) written to URDF by 'export urdf' and read by Pinocchio give rworld's tool
    pose, inverse and forward dynamics."""
    from rworld_cli.api import export_urdf

    rng = np.random.default_rng(2026)
    for case in range(8):
        folder = tmp_path / f"arm{case}"
        folder.mkdir()
        text, n = _random_cell(rng)
        (folder / "cell.yaml").write_text(text)
        (folder / "poses.yaml").write_text(
            "units: {length: m, angle: rad}\n"
            "poses:\n  arm: {xyz: [0, 0, 0]}\n  arm.tool: {xyz: [0.05, 0, 0.1]}\n"
        )
        export_urdf(str(folder), str(folder / "arm.urdf"))
        model = pin.buildModelFromUrdf(str(folder / "arm.urdf"))
        data = model.createData()
        ctx = device_context(str(folder), "arm")
        dyn = device_dynamics(ctx)
        fid = model.getFrameId("tool")
        for _ in range(5):
            angles = rng.uniform(-1.5, 1.5, n)
            qd, qdd, tau = rng.uniform(-2, 2, (3, n))
            q = []
            for joint, a in zip(list(model.joints)[1:], angles):
                q += [np.cos(a), np.sin(a)] if joint.nq == 2 else [a]
            q = np.array(q)
            pin.forwardKinematics(model, data, q)
            pin.updateFramePlacements(model, data)
            np.testing.assert_allclose(
                forward_kinematics(ctx, angles), data.oMf[fid].homogeneous, atol=1e-12
            )
            np.testing.assert_allclose(
                dyn.inverse(angles, qd, qdd), pin.rnea(model, data, q, qd, qdd), atol=1e-9
            )
            np.testing.assert_allclose(
                dyn.forward(angles, qd, tau), pin.aba(model, data, q, qd, tau), atol=1e-8
            )

"""What the references do not cover: prismatic joints, modified DH, payloads, armature,
friction, energy - checked by identities that must hold for any model."""

from __future__ import annotations

import numpy as np
import pytest

from rworld_cli import spatial
from rworld_cli.dynamics import DeviceDynamics, Payload, integrate
from rworld_cli.kinematics.jacobian import ToolMount, jacobian, tool_pose, tool_pose_and_jacobian
from rworld_cli.model.cell import DeviceModel, Inertial, Joint, JointLimits, Link
from rworld_cli.schema.loader import load_cell


def random_device(seed: int, convention: str, kinds: str) -> DeviceModel:
    """A random serial chain with physical (triangle-inequality) inertias."""
    rng = np.random.default_rng(seed)
    joints, links = [], []
    for i, kind in enumerate(kinds):
        kind = "revolute" if kind == "R" else "prismatic"
        alpha = rng.choice([0.0, np.pi / 2, -np.pi / 2, rng.uniform(-np.pi, np.pi)])
        joints.append(
            Joint(
                f"j{i}",
                kind,
                rng.uniform(-0.4, 0.4),
                alpha,
                rng.uniform(-0.3, 0.3),
                rng.uniform(-1, 1),
                JointLimits(),
                motor_inertia=rng.uniform(0, 1e-4),
                gear_ratio=rng.uniform(20, 100),
                viscous=rng.uniform(0, 2),
                coulomb_positive=rng.uniform(0, 1),
                coulomb_negative=rng.uniform(0, 1),
            )
        )
        moments = rng.uniform(0.01, 0.1, 3)
        R = spatial.rpy_to_matrix(rng.uniform(-np.pi, np.pi, 3))
        links.append(
            Link(
                f"l{i}",
                Inertial(
                    rng.uniform(0.5, 5), rng.uniform(-0.2, 0.2, 3), R @ np.diag(moments) @ R.T
                ),
                None,
            )
        )
    return DeviceModel("rand", convention, tuple(joints), tuple(links), (), np.zeros(len(joints)))


CASES = [
    (s, c, k)
    for s, (c, k) in enumerate(
        [
            ("standard", "RRRRRR"),
            ("modified", "RRRRRR"),
            ("standard", "PRRPRR"),
            ("modified", "RPRRPR"),
            ("standard", "P"),
            ("modified", "RRP"),
        ]
    )
]


@pytest.fixture(params=CASES, ids=[f"{c}-{k}" for _, c, k in CASES])
def device(request):
    return random_device(*request.param)


def sample(device, rng, N=16):
    n = device.dof
    return rng.uniform(-2, 2, (N, n)), rng.uniform(-1.5, 1.5, (N, n)), rng.uniform(-3, 3, (N, n))


def test_rnea_equals_mass_matrix_plus_bias(device):
    rng = np.random.default_rng(1)
    q, qd, qdd = sample(device, rng)
    g = rng.normal(size=3)
    dyn = DeviceDynamics(device)  # armature and friction on
    tau = dyn.inverse(q, qd, qdd, g)
    expected = (
        np.einsum("nij,nj->ni", dyn.mass_matrix(q), qdd)
        + dyn.nonlinear_torques(q, qd, g)
        + dyn.friction_torque(qd)
    )
    np.testing.assert_allclose(tau, expected, atol=1e-10)
    M = dyn.mass_matrix(q)
    assert np.all(np.linalg.eigvalsh(M) > 0)
    np.testing.assert_allclose(dyn.forward(q, qd, tau, g), qdd, atol=1e-8)


def test_jacobian_equals_finite_differences(device):
    rng = np.random.default_rng(2)
    q = rng.uniform(-2, 2, device.dof)
    mount = ToolMount(
        device.dof,
        spatial.make_transform(spatial.rpy_to_matrix([0.3, -0.2, 0.5]), [0.05, 0.02, 0.1]),
    )
    T, J = tool_pose_and_jacobian(device, q, mount)
    h = 1e-6
    for i in range(device.dof):
        dq = np.zeros(device.dof)
        dq[i] = h
        Tp, Tm = tool_pose(device, q + dq, mount), tool_pose(device, q - dq, mount)
        v = (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)
        dR = (Tp[:3, :3] - Tm[:3, :3]) / (2 * h) @ T[:3, :3].T  # skew(w)
        w = np.array([dR[2, 1], dR[0, 2], dR[1, 0]])
        np.testing.assert_allclose(J[:3, i], v, atol=1e-7)
        np.testing.assert_allclose(J[3:, i], w, atol=1e-7)


def test_batched_equals_single(device):
    rng = np.random.default_rng(3)
    q, qd, qdd = sample(device, rng, N=5000)  # more than one chunk
    dyn = DeviceDynamics(device)
    tau = dyn.inverse(q, qd, qdd)
    T, J = tool_pose_and_jacobian(device, q)
    for k in (0, 2047, 2048, 4999):
        np.testing.assert_allclose(tau[k], dyn.inverse(q[k], qd[k], qdd[k]), atol=1e-12)
        np.testing.assert_allclose(J[k], tool_pose_and_jacobian(device, q[k])[1], atol=1e-14)


def test_payload_adds_jacobian_transpose_of_its_wrench(device):
    """tau(with payload) = tau(without) + J_c^T [m (a_c - g); I dw + w x I w] at the payload's
    COM.
    """
    rng = np.random.default_rng(4)
    q, qd, qdd = sample(device, rng, N=1)
    q, qd, qdd = q[0], qd[0], qdd[0]
    g = np.array([0.0, 0.0, -9.81])
    mount = ToolMount(
        device.dof,
        spatial.make_transform(spatial.rpy_to_matrix([0.1, 0.4, -0.3]), [0.0, 0.05, 0.12]),
    )
    payload = Payload(2.5, np.array([0.02, -0.01, 0.04]), np.diag([0.01, 0.02, 0.015]))
    bare = DeviceDynamics(device, None, mount, armature=False, friction=False)
    loaded = DeviceDynamics(device, payload, mount, armature=False, friction=False)
    # payload COM velocity/acceleration by finite differences along the motion q(t) = q + qd t + qdd
    # t^2 / 2
    T = tool_pose(device, q, mount)
    Jc = jacobian(device, q, mount, point_in_tool=payload.com)

    def com_state(t):
        qt = q + qd * t + 0.5 * qdd * t * t
        Tt, Jt = tool_pose_and_jacobian(device, qt, mount)
        Jct = jacobian(device, qt, mount, point_in_tool=payload.com)
        return Jct @ (qd + qdd * t), Tt

    h = 1e-5
    (vp, _), (vm, _) = com_state(h), com_state(-h)
    accel = (vp - vm) / (2 * h)  # [a_c; dw]
    twist = Jc @ qd
    w = twist[3:]
    I_world = T[:3, :3] @ payload.inertia @ T[:3, :3].T
    wrench = np.concatenate(
        [payload.mass * (accel[:3] - g), I_world @ accel[3:] + np.cross(w, I_world @ w)]
    )
    np.testing.assert_allclose(
        loaded.inverse(q, qd, qdd, g), bare.inverse(q, qd, qdd, g) + Jc.T @ wrench, atol=1e-6
    )


def test_point_mass_payload_is_a_rigid_body_with_zero_inertia(device):
    rng = np.random.default_rng(5)
    q, qd, qdd = sample(device, rng)
    a = DeviceDynamics(device, Payload.point_mass(3.0, [0, 0, 0.1]))
    b = DeviceDynamics(
        device,
        Payload.rigid_body(
            Inertial(3.0, np.zeros(3), np.zeros((3, 3))), spatial.make_transform(p=[0, 0, 0.1])
        ),
    )
    np.testing.assert_allclose(a.inverse(q, qd, qdd), b.inverse(q, qd, qdd), atol=1e-12)


def test_armature_and_friction_switches(device):
    rng = np.random.default_rng(6)
    q, qd, qdd = sample(device, rng)
    full = DeviceDynamics(device).inverse(q, qd, qdd)
    rigid = DeviceDynamics(device, armature=False, friction=False).inverse(q, qd, qdd)
    arm = np.array([j.armature for j in device.joints])
    visc = np.array([j.viscous for j in device.joints])
    cp = np.array([j.coulomb_positive for j in device.joints])
    cn = np.array([j.coulomb_negative for j in device.joints])
    np.testing.assert_allclose(
        full - rigid, arm * qdd + visc * qd + np.where(qd > 0, cp, -cn), atol=1e-10
    )


def test_energy_is_conserved_without_friction_or_torque():
    """A frictionless Puma falling freely from rest: kinetic + potential stays constant."""
    device = load_cell("workcells/puma560").cell.devices["puma"]
    dyn = DeviceDynamics(device, friction=False)
    times = np.linspace(0.0, 0.5, 501)
    q0 = np.array([0.3, 0.5, -1.2, 0.4, 0.8, -0.2])
    q, qd = integrate(
        dyn, q0, np.zeros(6), times, np.zeros((len(times), 6)), method="rk4", substeps=2
    )
    kinetic, potential = dyn.energy(q, qd)
    total = kinetic + potential
    assert kinetic.max() > 10.0  # it really moved
    assert np.ptp(total) < 1e-6 * kinetic.max()
    q2, qd2 = integrate(
        dyn,
        q0,
        np.zeros(6),
        times,
        np.zeros((len(times), 6)),
        method="DOP853",
        rtol=1e-11,
        atol=1e-11,
    )
    np.testing.assert_allclose(q2, q, atol=1e-7)


def test_integration_follows_a_computed_torque_profile():
    """Torques from inverse dynamics along q(t), integrated forward, reproduce q(t).

    Without friction: Coulomb friction jumps where a joint reverses, and a
    linearly interpolated torque profile cannot follow the jump.
    """
    device = load_cell("workcells/puma560").cell.devices["puma"]
    dyn = DeviceDynamics(device, friction=False)
    times = np.linspace(0, 1.0, 2001)
    a = np.array([0.5, -0.3, 0.4, 1.0, -0.8, 0.6])
    q = np.sin(np.outer(times, [1, 2, 1.5, 3, 2.5, 2])) * a
    qd = np.cos(np.outer(times, [1, 2, 1.5, 3, 2.5, 2])) * a * [1, 2, 1.5, 3, 2.5, 2]
    qdd = -q * np.square([1, 2, 1.5, 3, 2.5, 2])
    tau = dyn.inverse(q, qd, qdd)
    q_sim, _ = integrate(dyn, q[0], qd[0], times, tau, method="rk4")
    np.testing.assert_allclose(q_sim, q, atol=2e-5)

"""Every reference quantity (Pinocchio, cross-checked with Robotics Toolbox) to 1e-9."""

from __future__ import annotations

import numpy as np
import pytest

from rworld_cli.dynamics import DeviceDynamics
from rworld_cli.kinematics.jacobian import tool_pose_and_jacobian
from tests.reference import device_from_reference, load_reference, mount_and_payload, states

MODELS = ["puma560.json", "ur5.json", "puma560_tool_pointmass.json"]
G = np.array([0.0, 0.0, -9.81])
TOL = 1e-9


@pytest.fixture(params=MODELS, scope="module")
def ref(request):
    model = load_reference(request.param)["model"]
    device = device_from_reference(model)
    mount, payload = mount_and_payload(model)
    return (
        model,
        device,
        mount,
        DeviceDynamics(device, payload, mount, armature=False, friction=False),
    )


def test_tool_pose_and_jacobian(ref):
    model, device, mount, _ = ref
    T, J = tool_pose_and_jacobian(device, states(model, "q"), mount)
    np.testing.assert_allclose(T, states(model, "T_tool"), atol=TOL, rtol=0)
    np.testing.assert_allclose(J, states(model, "J0_tool"), atol=TOL, rtol=0)


@pytest.mark.parametrize("batched", [True, False])
def test_inverse_dynamics_gravity_and_bias(ref, batched):
    model, _, _, dyn = ref
    q, qd, qdd = states(model, "q"), states(model, "qd"), states(model, "qdd")
    if batched:
        tau, grav, nle = (
            dyn.inverse(q, qd, qdd, G),
            dyn.gravity_torques(q, G),
            dyn.nonlinear_torques(q, qd, G),
        )
    else:  # the single-state path runs on Python floats
        tau = np.array([dyn.inverse(*s, G) for s in zip(q, qd, qdd)])
        grav = np.array([dyn.gravity_torques(s, G) for s in q])
        nle = np.array([dyn.nonlinear_torques(a, b, G) for a, b in zip(q, qd)])
    np.testing.assert_allclose(tau, states(model, "tau_rnea"), atol=TOL, rtol=0)
    np.testing.assert_allclose(grav, states(model, "tau_gravity"), atol=TOL, rtol=0)
    np.testing.assert_allclose(nle, states(model, "tau_nle"), atol=TOL, rtol=0)


def test_mass_matrix(ref):
    model, _, _, dyn = ref
    np.testing.assert_allclose(
        dyn.mass_matrix(states(model, "q")), states(model, "M"), atol=TOL, rtol=0
    )


# ur5.json has zero link inertias, a singular M, and no forward-dynamics values
@pytest.mark.parametrize(
    "name", [m for m in MODELS if load_reference(m)["model"]["forward_dynamics_available"]]
)
def test_forward_dynamics(name):
    model = load_reference(name)["model"]
    device = device_from_reference(model)
    mount, payload = mount_and_payload(model)
    dyn = DeviceDynamics(device, payload, mount, armature=False, friction=False)
    q, qd, tau = states(model, "q"), states(model, "qd"), states(model, "fd_tau")
    np.testing.assert_allclose(
        dyn.forward(q, qd, tau, G), states(model, "fd_qdd"), atol=TOL, rtol=0
    )

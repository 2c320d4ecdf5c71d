"""The compiled kernels against the numpy code they are compiled from, and their disk cache.

Every generated program (Newton-Euler in its five modes, tool pose and Jacobian) runs both ways
on random chains of every kind; the results must agree to rounding (1e-12 relative).  The cache
is exercised in fresh processes: written once, read back, a corrupt file recompiled, an
unwritable directory tolerated.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from rworld_cli import kernels
from rworld_cli.dynamics import DeviceDynamics
from rworld_cli.kinematics.jacobian import ToolMount, generated
from rworld_cli.model.cell import DeviceModel, Inertial, Joint, JointLimits, Link
from rworld_cli.schema.loader import load_cell
from tests.conftest import REPO
from tests.dynamics.test_properties import CASES, random_device

pytestmark = pytest.mark.skipif(
    kernels.backend() != "llvm", reason="compiled kernels are off (RWORLD_KERNELS or no llvmlite)"
)


def close(a: np.ndarray, b: np.ndarray) -> float:
    """Largest difference relative to the largest magnitude (0 for identical arrays)."""
    return float(np.abs(a - b).max() / max(1.0, np.abs(b).max()))


def both_ways(gen, inputs) -> tuple[np.ndarray, np.ndarray]:
    assert gen.kernel() is not None
    return gen.evaluate(inputs), gen.evaluate(inputs, compiled=False)


def example_devices() -> list[DeviceModel]:
    devices = []
    for cell in ("puma560", "ur5", "panda", "paper_fig9"):
        devices += [d for d in load_cell(REPO / "workcells" / cell).cell.devices.values() if d.dof]
    devices.append(load_cell(REPO / "bench" / "cells" / "stanford").cell.devices["stanford"])
    return devices


@pytest.mark.parametrize("seed,convention,kinds", CASES)
def test_every_program_agrees_with_numpy_on_random_chains(seed, convention, kinds):
    device = random_device(seed, convention, kinds)
    dyn = DeviceDynamics(device)  # armature and friction on: the full program
    rng = np.random.default_rng(seed)
    n = device.dof
    q, qd, qdd = (rng.uniform(-2, 2, (257, n)) for _ in range(3))
    g = np.array([0.3, -0.2, -9.81])
    tau = dyn.inverse(q, qd, qdd, g)
    programs = {
        "full": [q, qd, qdd, g],
        "gravity": [q, g],
        "bias": [q, qd, g],
        "mass": [q],
        "forward": [q, qd, tau, g],
    }
    for mode, inputs in programs.items():
        fast, slow = both_ways(dyn._gen(mode), inputs)
        assert close(fast, slow) < 1e-12, mode
        one_fast = dyn._gen(mode).evaluate([x[3] if x.ndim == 2 else x for x in inputs])
        assert close(one_fast, slow[3]) < 1e-12, mode  # the single-state path
    mount = ToolMount(
        n, np.array([[0, -1, 0, 0.01], [1, 0, 0, 0.02], [0, 0, 1, 0.1], [0, 0, 0, 1]])
    )
    for with_jacobian in (False, True):
        fast, slow = both_ways(generated(device, mount, with_jacobian), [q])
        assert close(fast, slow) < 1e-12


def test_the_example_devices_agree_with_numpy():
    rng = np.random.default_rng(7)
    for device in example_devices():
        dyn = DeviceDynamics(device)
        q, qd, qdd = (rng.uniform(-1, 1, (64, device.dof)) for _ in range(3))
        fast, slow = both_ways(dyn._gen("full"), [q, qd, qdd, np.array([0.0, 0.0, -9.81])])
        assert close(fast, slow) < 1e-12, device.name
        fast, slow = both_ways(generated(device, None, True), [q])
        assert close(fast, slow) < 1e-12, device.name


def test_forward_dynamics_inverts_inverse_dynamics_with_armature_and_friction():
    device = random_device(11, "standard", "RRPRRR")
    dyn = DeviceDynamics(device)
    rng = np.random.default_rng(3)
    q, qd, qdd = (rng.uniform(-2, 2, (500, 6)) for _ in range(3))
    qd[::7, 2] = 0.0  # Coulomb friction at rest is zero on both sides
    tau = dyn.inverse(q, qd, qdd)
    assert np.abs(dyn.forward(q, qd, tau) - qdd).max() < 1e-9
    M = dyn.mass_matrix(q)
    assert np.abs(M - np.swapaxes(M, 1, 2)).max() == 0.0  # the mirror is exact
    assert np.all(np.linalg.eigvalsh(M) > 0)


def test_per_sample_gravity_equals_one_call_per_gravity():
    device = load_cell(REPO / "workcells" / "puma560").cell.devices["puma"]
    dyn = DeviceDynamics(device)
    rng = np.random.default_rng(5)
    q, qd, qdd = (rng.uniform(-1, 1, (40, 6)) for _ in range(3))
    g = rng.normal(0, 5, (40, 3))
    batch = dyn.inverse(q, qd, qdd, g)
    one_by_one = np.array([dyn.inverse(a, b, c, d) for a, b, c, d in zip(q, qd, qdd, g)])
    assert np.abs(batch - one_by_one).max() == 0.0


def test_a_batch_split_over_threads_equals_one_thread(monkeypatch):
    device = load_cell(REPO / "workcells" / "ur5").cell.devices["ur5"]
    dyn = DeviceDynamics(device)
    rng = np.random.default_rng(9)
    N = kernels.PARALLEL_MIN + 1001  # uneven halves
    q, qd, qdd = (rng.uniform(-3, 3, (N, 6)) for _ in range(3))
    monkeypatch.setenv("RWORLD_THREADS", "2")
    split = dyn.inverse(q, qd, qdd)
    monkeypatch.setenv("RWORLD_THREADS", "1")
    whole = dyn.inverse(q, qd, qdd)
    assert np.array_equal(split, whole)
    assert np.array_equal(
        whole, dyn._gen("full").evaluate([q, qd, qdd, np.array([0, 0, -9.81])], compiled=False)
    )


def test_a_singular_mass_matrix_is_reported_not_divided_by():
    joints = (
        Joint("j1", "revolute", 0.3, 0.0, 0.0, 0.0, JointLimits()),
        Joint("j2", "revolute", 0.3, 0.0, 0.0, 0.0, JointLimits()),
    )
    massless = Inertial(0.0, np.zeros(3), np.zeros((3, 3)))
    heavy = Inertial(1.0, np.zeros(3), np.eye(3) * 0.01)
    device = DeviceModel(
        "arm",
        "standard",
        joints,
        (Link("l1", heavy, None), Link("l2", massless, None)),
        (),
        np.zeros(2),
    )
    dyn = DeviceDynamics(device)
    with pytest.raises(ValueError, match="'arm' is singular .joint 2 moves no inertia"):
        dyn.forward(np.zeros((2, 2)), np.zeros((2, 2)), np.ones((2, 2)))
    both = DeviceDynamics(
        DeviceModel("arm", "standard", joints, (Link("l1", heavy, None),) * 2, (), np.zeros(2))
    )
    nan = both.forward(np.array([np.nan, 0.0]), np.zeros(2), np.zeros(2))  # bad input: NaN out
    assert np.all(np.isnan(nan))


def test_the_direct_entry_takes_only_what_it_can_read_and_leaks_nothing():
    device = load_cell(REPO / "workcells" / "puma560").cell.devices["puma"]
    dyn = DeviceDynamics(device)
    program = dyn._gen("full")
    kernel = program.kernel()
    assert kernel.direct is not None, "numpy's array layout was not recognised"
    rng = np.random.default_rng(3)
    q, qd, qdd = rng.uniform(-2, 2, (3, 6))
    g = np.array([0.0, 0.0, -9.81])
    reference = program.evaluate([q, qd, qdd, g], compiled=False)
    out = np.empty(6)
    assert kernel.direct(q, qd, qdd, g, out) is out
    assert close(out, reference) < 1e-12
    assert np.array_equal(kernel.single([q, qd, qdd, g]), out)  # the packing path: same bits
    wide = np.zeros((6, 2))
    readonly = np.empty(6)
    readonly.flags.writeable = False
    refused = {
        "int array": (q.astype(int), qd, qdd, g, out),
        "float32": (q.astype(np.float32), qd, qdd, g, out),
        "big-endian": (q.astype(">f8"), qd, qdd, g, out),
        "strided": (wide[:, 0], qd, qdd, g, out),
        "too short": (q[:5], qd, qdd, g, out),
        "2-D": (q[None], qd, qdd, g, out),
        "0-D": (np.float64(1.0), qd, qdd, g, out),
        "list": (q.tolist(), qd, qdd, g, out),
        "subclass": (q.view(np.ma.MaskedArray), qd, qdd, g, out),
        "misaligned": (np.frombuffer(bytes(49), offset=1), qd, qdd, g, out),
        "read-only output": (q, qd, qdd, g, readonly),
        "one argument short": (q, qd, qdd, out),
        "no arguments": (),
    }
    for label, arguments in refused.items():
        before = out.copy()
        assert kernel.direct(*arguments) is None, label
        assert np.array_equal(out, before), label  # nothing written
    # what the direct entry refuses still computes, through the general path
    assert close(dyn.inverse(q.tolist(), qd, qdd), reference) < 1e-12
    assert (
        close(
            dyn.inverse(wide[:, 0] + q, qd, qdd), program.evaluate([q, qd, qdd, g], compiled=False)
        )
        < 1e-12
    )
    for bad in (np.array([0.0, 0.0, np.nan]), np.array([np.inf, 0.0, 0.0])):  # checked still
        with pytest.raises(ValueError, match="gravity must be a finite 3-vector"):
            dyn.inverse(q, qd, qdd, bad)
        with pytest.raises(ValueError, match="gravity must be a finite 3-vector"):
            dyn.forward(q, qd, reference, bad)
    counts = [sys.getrefcount(x) for x in (q, out, None)]
    for _ in range(1000):
        kernel.direct(q, qd, qdd, g, out)
        kernel.direct(q, qd, qdd, g)
    assert [sys.getrefcount(x) for x in (q, out)] == counts[:2]
    assert abs(sys.getrefcount(None) - counts[2]) < 100  # None's count moves with the runtime


def test_the_direct_entry_fills_shaped_outputs_and_refuses_the_wrong_ones():
    """Tool pose and Jacobian come as (4, 4) and (6, n), the mass matrix as (n, n): the same bits
    as the batch path; outputs of another shape, order, layout or dtype are refused untouched."""
    device = load_cell(REPO / "workcells" / "ur5").cell.devices["ur5"]
    mount = ToolMount(
        device.dof, np.array([[0, -1, 0, 0.01], [1, 0, 0, 0.02], [0, 0, 1, 0.1], [0, 0, 0, 1.0]])
    )
    program = generated(device, mount, True)
    kernel = program.kernel()
    assert kernel.shapes == [(4, 4), (6, 6)]
    q = np.random.default_rng(5).uniform(-2, 2, 6)
    flat = program.evaluate([q[None]])[0]  # the batch path
    T, J = program.direct(q)
    assert T.shape == (4, 4) and J.shape == (6, 6) and T.flags.owndata and J.flags.owndata
    assert np.array_equal(T.ravel(), flat[:16]) and np.array_equal(J.ravel(), flat[16:])
    M = DeviceDynamics(device).mass_matrix(q)
    assert M.shape == (6, 6)
    assert np.array_equal(M, DeviceDynamics(device).mass_matrix(q[None])[0])

    a, b = np.full((4, 4), 7.0), np.full((6, 6), 7.0)
    assert kernel.direct(q, a, b) is a and np.array_equal(a, T) and np.array_equal(b, J)
    readonly = np.zeros((6, 6))
    readonly.flags.writeable = False
    refused = {
        "one flat output": (q, np.empty(52)),
        "outputs swapped": (q, np.empty((6, 6)), np.empty((4, 4))),
        "flat first output": (q, np.empty(16), np.empty((6, 6))),
        "transposed": (q, np.empty((4, 4)), np.empty((6, 6)).T),
        "Fortran order": (q, np.empty((4, 4)), np.asfortranarray(np.empty((6, 6)))),
        "strided": (q, np.empty((4, 8))[:, ::2], np.empty((6, 6))),
        "float32": (q, np.empty((4, 4), np.float32), np.empty((6, 6))),
        "read-only": (q, np.empty((4, 4)), readonly),
        "3-D": (q, np.empty((1, 4, 4)), np.empty((6, 6))),
        "one output short": (q, np.empty((4, 4))),
    }
    for label, arguments in refused.items():
        before = [x.copy() for x in arguments[1:]]
        assert kernel.direct(*arguments) is None, label
        assert all(np.array_equal(x, y, equal_nan=True) for x, y in zip(arguments[1:], before)), (
            label
        )
    # what the entry refuses (a list, ints) still computes, through the general path
    from rworld_cli.kinematics.jacobian import tool_pose, tool_pose_and_jacobian

    T2, J2 = tool_pose_and_jacobian(device, q.tolist(), mount)
    assert np.array_equal(T2, T) and np.array_equal(J2, J)
    assert np.array_equal(tool_pose(device, q, mount), T)
    assert np.array_equal(tool_pose(device, q.tolist(), mount), T)


def test_constants_are_written_bit_exact():
    for x in (0.1, -1e-300, 2.0 / 3.0, 6.123233995736766e-17, 1e308):
        bits = kernels._literal(x)
        assert np.frombuffer(int(bits, 16).to_bytes(8, "little"), dtype="<f8")[0] == x


COLD = """
import sys
sys.path.insert(0, {repo!r})
import numpy as np
from rworld_cli import kernels
from rworld_cli.dynamics import DeviceDynamics
from rworld_cli.schema.loader import load_cell
device = load_cell({cell!r}).cell.devices["puma"]
q = np.linspace(-1, 1, 18).reshape(3, 6)
print(kernels.backend(), repr(DeviceDynamics(device).inverse(q, q, q).tolist()))
"""


def run_cold(env: dict) -> tuple[str, list]:
    code = COLD.format(repo=str(REPO), cell=str(REPO / "workcells" / "puma560"))
    out = subprocess.run(
        [sys.executable, "-c", code],
        env={**os.environ, **env},
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split(" ", 1)
    return out[0], eval(out[1])


def test_the_disk_cache_is_written_read_and_survives_corruption(tmp_path):
    env = {"RWORLD_CACHE_DIR": str(tmp_path)}
    backend, first = run_cold(env)
    assert backend == "llvm"
    files = sorted((tmp_path / "kernels").glob("*.o"))
    assert len(files) == 1  # one kernel: inverse dynamics
    stamp = files[0].stat().st_mtime_ns
    assert run_cold(env)[1] == first
    assert files[0].stat().st_mtime_ns == stamp  # read, not rewritten
    files[0].write_bytes(files[0].read_bytes()[:-100] + b"\0" * 100)  # corrupt the code
    assert run_cold(env)[1] == first
    assert not files[0].read_bytes().endswith(b"\0" * 100)  # compiled again and replaced
    assert not list((tmp_path / "kernels").glob(".tmp-*"))
    _, numpy_result = run_cold({"RWORLD_KERNELS": "numpy"})
    assert np.abs(np.array(numpy_result) - np.array(first)).max() < 1e-12


def test_an_unwritable_cache_is_not_an_error(tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a directory")
    backend, result = run_cold({"RWORLD_CACHE_DIR": str(blocker / "sub")})
    assert backend == "llvm" and len(result) == 3


def test_the_switch_is_checked(monkeypatch):
    monkeypatch.setenv("RWORLD_KERNELS", "fortran")
    with pytest.raises(ValueError, match="RWORLD_KERNELS must be 'llvm' or 'numpy'"):
        kernels.backend()
    monkeypatch.setenv("RWORLD_KERNELS", "numpy")
    assert kernels.backend() == "numpy"
    monkeypatch.setenv("RWORLD_KERNELS", "llvm")
    monkeypatch.setenv("RWORLD_THREADS", "two")
    with pytest.raises(ValueError, match="RWORLD_THREADS must be a whole number"):
        kernels.thread_count()


def test_commands_without_physics_never_load_the_compiler():
    code = (
        "import sys; from rworld_cli.cli import main\n"
        f"try:\n    main(['validate', {str(REPO / 'workcells' / 'puma560')!r}])\n"
        "except SystemExit:\n    pass\n"
        "print('LLVM', 'llvmlite' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True).stdout
    assert "LLVM False" in out

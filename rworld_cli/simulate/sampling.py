"""The time-step controller: every device sampled on the run's clock - poses, loads, gravity,
batched Newton-Euler torques - and the limit checks (the report's section 5, phase 2)."""

from __future__ import annotations

import numpy as np

from ..dynamics import DeviceDynamics, Payload
from ..errors import UserError
from ..kinematics.jacobian import ToolMount
from ..model.program import Run
from ..motion.trajectory import sample_track
from ..units import MAX_SAMPLES
from .timeline import DeviceTimeline, SimulationResult, Violation


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) index ranges where ``mask`` is True."""
    padded = np.concatenate([[False], mask, [False]])
    edges = np.flatnonzero(padded[1:] != padded[:-1])
    return list(zip(edges[::2], edges[1::2]))


def _sample(run: Run, sched, progress, payload: bool = False) -> tuple[SimulationResult, dict]:
    """The run on its clock, and every device's (q, qd, qdd) at the clock's instants."""
    cell = run.cell
    end = max((tr.end for tr in sched.tracks.values()), default=0.0)
    if not end / run.dt <= MAX_SAMPLES:  # waits may make a run long: bounded before sampling
        raise UserError(
            f"{run.file}: the run lasts {end:.4g} s: {end / run.dt:.3g} clock samples at dt "
            f"{run.dt:g} s, above the bound of {MAX_SAMPLES:,} (docs/simulation.md): shorten "
            "its waits or raise the clock step (dt)"
        )
    times = np.arange(0.0, end, run.dt)
    if len(times) == 0 or end - times[-1] > 1e-9 * max(1.0, end):
        times = np.append(times, end)  # the last sample is the end of the last program
    K = len(times)
    world = sched.world
    devices = list(cell.devices)
    q, qd, qdd = {}, {}, {}
    for d in devices:
        if d in sched.tracks:
            tr = sched.tracks[d]
            q[d], qd[d], qdd[d] = sample_track(tr.segments, tr.q_init, times)
        else:  # devices without a program hold their home values
            n = cell.devices[d].dof
            q[d], qd[d], qdd[d] = (
                np.tile(cell.devices[d].home, (K, 1)),
                np.zeros((K, n)),
                np.zeros((K, n)),
            )
    snaps = sched.snapshots
    bounds = [np.searchsorted(times, t, side="left") for t, _ in snaps[1:]] + [K]
    starts = [0] + bounds[:-1]
    run_devices = sched.order
    T_base = {d: np.empty((K, 4, 4)) for d in run_devices}
    T_tcp = {d: np.empty((K, 4, 4)) for d in run_devices}
    tcp_names = {d: [] for d in run_devices}
    total = len(snaps) * len(run_devices) * 2
    done = 0
    for (t_snap, snap), a, b in zip(snaps, starts, bounds):
        if b <= a:
            continue
        world.restore(snap)
        joints = {d: q[d][a:b] for d in devices}
        for d in run_devices:
            T_base[d][a:b] = world.T_world_batch(d, joints)
            tcp = world.active_tcp(d)
            T_tcp[d][a:b] = world.T_world_batch(tcp, joints)
            tcp_names[d].append((float(times[a]), tcp))
            done += 1
            if progress:
                progress(done, total, "poses")
    gravity = cell.gravity
    # what rides on each device's links, and where its active TCP sits, per stretch between
    # snapshots: the state at the stretch's start fixes the loads' poses (one restore per
    # stretch, not one per device and stretch: a line of robots)
    stretch_loads: list[dict] = []
    for (_, snap), a, b in zip(snaps, starts, bounds):
        stretch_loads.append({})
        if b <= a:
            continue
        world.restore(snap)
        for other in devices:
            world.set_joints(other, q[other][a])
        for d in run_devices:
            mount = ToolMount(*world.mount_of(d, world.active_tcp(d))) if payload else None
            stretch_loads[-1][d] = (world.carried_loads(d), mount)
    timelines = {}
    violations: list[Violation] = []
    step_texts = {d: [st.describe() for st in sched.tracks[d].program.steps] for d in run_devices}
    for d in run_devices:
        dev = cell.devices[d]
        # the base's own acceleration (a conveyor carrying the device) acts like gravity
        p = T_base[d][:, :3, 3]
        a_base = (
            np.gradient(np.gradient(p, times, axis=0), times, axis=0) if K > 2 else np.zeros_like(p)
        )
        g_world = gravity - a_base
        g_base = np.einsum("kji,kj->ki", T_base[d][:, :3, :3], g_world)  # R^T (g - a)
        tau = np.empty_like(q[d])
        per_kg = np.zeros_like(q[d]) if payload else None
        for n, (a, b) in enumerate(zip(starts, bounds)):
            if b <= a:
                continue
            loads, mount = stretch_loads[n][d]
            dyn = DeviceDynamics(dev, link_loads=loads)
            tau[a:b] = dyn.inverse(q[d][a:b], qd[d][a:b], qdd[d][a:b], g_base[a:b])
            if per_kg is not None and mount.link > 0:  # a TCP on the base loads no joint
                one = DeviceDynamics(dev, Payload.point_mass(1.0), mount, link_loads=loads)
                per_kg[a:b] = (
                    one.inverse(q[d][a:b], qd[d][a:b], qdd[d][a:b], g_base[a:b]) - tau[a:b]
                )
            done += 1
            if progress:
                progress(done, total, "dynamics")
        step_index = np.full(K, -1)
        for t0, idx in sched.tracks[d].step_starts:
            step_index[times >= t0 - 1e-12] = idx
        ratios = {  # NaN for a joint without that limit: no ratio, not 0
            kind: np.where(np.isfinite(limit), np.abs(value) / limit, np.nan)
            for kind, value, limit in (
                ("velocity", qd[d], dev.limit_array("velocity")),
                ("acceleration", qdd[d], dev.limit_array("acceleration")),
                ("torque", tau, dev.limit_array("effort")),
            )
        }
        capacity = None
        if per_kg is not None and K:
            from ..planning.payload import affine_capacity

            cap = affine_capacity(tau, per_kg, dev.limit_array("effort"))
            if np.isfinite(cap.mass):
                capacity = {
                    "mass": cap.mass,
                    "joint": dev.joints[cap.joint].name,
                    "t": float(times[cap.sample]),
                    "side": cap.side,
                }
        timelines[d] = DeviceTimeline(
            d,
            q[d],
            qd[d],
            qdd[d],
            tau,
            T_tcp[d],
            step_index,
            ratios,
            float(sched.tracks[d].end),
            tcp_names[d],
            per_kg,
            capacity,
        )
        violations += _violations(
            d, dev, times, q[d], ratios, qd[d], qdd[d], tau, step_index, step_texts[d]
        )
    world.restore(snaps[-1][1])
    violations.sort(key=lambda v: (v.t_start, v.device, v.joint))
    events = sorted(sched.events, key=lambda e: e.t)  # stable: simultaneous events keep their order
    unlimited = {d: cell.devices[d].unlimited() for d in timelines if cell.devices[d].unlimited()}
    result = SimulationResult(
        cell.name,
        run.file,
        run.dt,
        times,
        timelines,
        events,
        violations,
        step_texts,
        unlimited,
        resolved=sched.resolved,
        step_where={d: [st.where for st in sched.tracks[d].program.steps] for d in run_devices},
        snapshots=list(snaps),
        massless=[d for d in timelines if d in run_devices and cell.devices[d].total_mass <= 0.0],
    )
    return result, {d: (q[d], qd[d], qdd[d]) for d in devices}


def _violations(device, dev, times, q, ratios, qd, qdd, tau, step_index, texts) -> list[Violation]:
    out = []
    lower, upper = dev.limit_array("lower"), dev.limit_array("upper")
    checks = {
        "position": (np.maximum(lower - q, q - upper) > 1e-9, q, None),
        "velocity": (ratios["velocity"] > 1 + 1e-6, qd, dev.limit_array("velocity")),
        "acceleration": (ratios["acceleration"] > 1 + 1e-6, qdd, dev.limit_array("acceleration")),
        "torque": (ratios["torque"] > 1 + 1e-9, tau, dev.limit_array("effort")),
    }
    for kind, (bad, values, limits) in checks.items():
        for j in range(dev.dof):
            for a, b in _runs(bad[:, j]):
                seg = values[a:b, j]
                k = a + int(np.argmax(np.abs(seg)))
                if kind == "position":
                    peak = float(values[k, j])
                    limit = float(upper[j] if peak > upper[j] else lower[j])
                else:
                    peak, limit = float(values[k, j]), float(limits[j])
                step = int(step_index[k]) if step_index[k] >= 0 else None
                out.append(
                    Violation(
                        device,
                        dev.joints[j].name,
                        kind,
                        float(times[a]),
                        float(times[b - 1]),
                        peak,
                        limit,
                        step,
                        texts[step] if step is not None else "",
                    )
                )
    return out

"""What a simulation gives: the summary, timelines and events as tables and documents, and plots
(PNG).

The files are written by ``schema/results.py``."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..fileio import save_figure
from ..spatial import matrix_to_quat
from .engine import SimulationResult


def summary_dict(result: SimulationResult) -> dict:
    """The stable JSON summary (docs/simulation.md)."""
    devices = {}
    for name, tl in result.devices.items():
        peaks = result.peak_ratios(name)
        devices[name] = {
            "cycle_time": tl.cycle_time,
            "peak_ratio": {k: [float(x) for x in v] for k, v in peaks.items()},
            "violations": sum(1 for v in result.violations if v.device == name),
            "steps": len(result.step_texts[name]),
        }
    return {
        "cell": result.cell,
        "run": result.run,
        "dt": result.dt,
        "cycle_time": result.cycle_time,
        "ok": result.ok,
        "devices": devices,
        "violations": [v.as_dict() for v in result.violations],
        "unlimited": result.unlimited,
        "collisions": _collision_summary(result),
        "events": [e.as_dict() for e in result.events],
    }


def _collision_summary(result: SimulationResult) -> dict | None:
    """Counts, and the contacts themselves (collisions.json has the per-step distances too)."""
    report = result.collisions
    if report is None:
        return None
    full = report.as_dict()
    return {
        k: full[k]
        for k in (
            "tolerance",
            "required_clearance",
            "collisions",
            "clearance_violations",
            "handling",
            "not_checked",
            "open_meshes",
            "static_overlaps",
        )
    }


def unlimited_lines(unlimited: dict[str, dict[str, list[str]]]) -> list[str]:
    """One line per device naming the joints the cell gives no limit of a kind (they run
    unlimited in it).
    """
    return [
        f"{device}: no limit in the cell, so unchecked: "
        + "; ".join(f"{kind} of {', '.join(joints)}" for kind, joints in kinds.items())
        for device, kinds in unlimited.items()
    ]


def timeline_columns(n: int, clearance: bool = False) -> list[str]:
    cols = ["t", "step"]
    for group in ("q", "qd", "qdd", "tau"):
        cols += [f"{group}{i}" for i in range(1, n + 1)]
    cols += ["tcp_x", "tcp_y", "tcp_z", "tcp_qw", "tcp_qx", "tcp_qy", "tcp_qz"]
    return cols + (["clearance"] if clearance else [])


def timeline_array(result: SimulationResult, device: str) -> np.ndarray:
    tl = result.devices[device]
    step = np.where(tl.step >= 0, tl.step + 1, 0)  # 1-based program step, 0 = none
    extra = []
    if result.collisions is not None:
        # the least distance to anything the device may not touch; NaN beyond the report range
        c = result.collisions.clearance[device]
        extra = [np.where(np.isfinite(c), c, np.nan)[:, None]]
    return np.hstack(
        [
            result.times[:, None],
            step[:, None],
            tl.q,
            tl.qd,
            tl.qdd,
            tl.tau,
            tl.tcp[:, :3, 3],
            matrix_to_quat(tl.tcp[:, :3, :3]),
            *extra,
        ]
    )


def timeline_dict(result: SimulationResult) -> dict:
    """All devices on the uniform clock, as JSON (docs/simulation.md)."""
    devices = {}
    for name, tl in result.devices.items():
        devices[name] = {
            "step": [int(x) + 1 if x >= 0 else 0 for x in tl.step],
            "q": tl.q.tolist(),
            "qd": tl.qd.tolist(),
            "qdd": tl.qdd.tolist(),
            "tau": tl.tau.tolist(),
            "tcp_xyz": tl.tcp[:, :3, 3].tolist(),
            "tcp_quat_wxyz": matrix_to_quat(tl.tcp[:, :3, :3]).tolist(),
            "active_tcp": [{"from": t, "tcp": name_} for t, name_ in tl.tcp_names],
        }
        if result.collisions is not None:
            c = result.collisions.clearance[name]
            devices[name]["clearance"] = [float(x) if np.isfinite(x) else None for x in c]
    return {"t": result.times.tolist(), "devices": devices}


def output_files(result: SimulationResult) -> tuple[dict, dict]:
    """What a run writes: ({file name: (columns, rows)} CSV tables, {file name: payload} JSON
    documents).
    """
    checked = result.collisions is not None
    tables = {
        f"timeline_{name}.csv": (
            timeline_columns(tl.q.shape[1], checked),
            timeline_array(result, name),
        )
        for name, tl in result.devices.items()
    }
    summary = summary_dict(result)
    documents = {
        "timeline.json": timeline_dict(result),
        "events.json": summary["events"],
        "summary.json": {k: v for k, v in summary.items() if k != "events"},
    }
    if checked:
        documents["collisions.json"] = result.collisions.as_dict()
    return tables, documents


def write_plots(result: SimulationResult, directory: Path) -> list[Path]:
    """Per device: joint positions, and torque / velocity ratios to their limits, against time."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    written = []
    events = [e for e in result.events if e.tree is not None]
    for name, tl in result.devices.items():
        fig, axes = plt.subplots(3, 1, figsize=(10, 8), sharex=True, constrained_layout=True)
        t = result.times
        for j in range(tl.q.shape[1]):
            axes[0].plot(t, tl.q[:, j], label=f"q{j + 1}")
            for ax, kind in ((axes[1], "torque"), (axes[2], "velocity")):
                if np.isfinite(tl.ratios[kind][:, j]).any():  # a joint without a limit: no line
                    ax.plot(t, tl.ratios[kind][:, j], label=f"joint {j + 1}")
        for ax, kind in ((axes[1], "torque"), (axes[2], "velocity")):
            if not np.isfinite(tl.ratios[kind]).any():
                ax.text(
                    0.5,
                    0.5,
                    f"no {kind} limits in the cell",
                    transform=ax.transAxes,
                    ha="center",
                    va="center",
                    color="grey",
                )
        axes[0].set_ylabel("joint value [rad, m]")
        axes[1].set_ylabel("|torque| / limit")
        axes[2].set_ylabel("|velocity| / limit")
        for ax in axes[1:]:
            ax.axhline(1.0, color="red", linewidth=1, linestyle="--")
            ax.set_ylim(bottom=0)
        for ax in axes:
            ax.grid(alpha=0.3)
            for e in events:
                ax.axvline(e.t, color="grey", linewidth=0.8, alpha=0.6)
        for e in events:
            _mark(axes[0], e.t, f"{e.kind} {e.tree['child']}", "grey", top=True)
        for v in result.violations:
            if v.device == name:
                axes[1 if v.kind == "torque" else 2].axvspan(
                    v.t_start, v.t_end, color="red", alpha=0.15
                )
        if result.collisions is not None:  # contacts of this device: red spans and names
            for rc in result.collisions.contacts:
                if name not in {s.device for s in rc.steps}:
                    continue
                c = rc.contact
                width = max(c.t_end - c.t_start, result.dt)
                axes[0].axvspan(c.t_start, c.t_start + width, color="red", alpha=0.25)
                kind = "collision" if c.collision else "clearance"
                _mark(axes[0], c.t_start, f"{kind} {c.a} / {c.b}", "red", top=False)
        axes[0].legend(loc="upper right", fontsize=8, ncol=3)
        if np.isfinite(tl.ratios["torque"]).any():  # joints with a torque limit have lines
            axes[1].legend(loc="upper right", fontsize=8, ncol=3)
        axes[2].set_xlabel("time [s]")
        fig.suptitle(f"{result.cell}: {name} (cycle time {tl.cycle_time:.2f} s)")
        written.append(save_figure(fig, directory / f"plot_{name}.png"))
    return written


def sweep_picture(result, path: str) -> Path:
    """A sweep's picture (``api.sweep.SweepResult``): cycle time, peak torque ratio and payload
    capacity against the swept mass (or the speed override when no mass is swept), one line per
    speed or pose file; a failed point is a red cross, the torque limit and zero payload dashed
    lines."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    points = [p for p in result.points if p.error is None]
    by_mass = any(p.mass is not None for p in points)
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2), constrained_layout=True)
    lines: dict[tuple, list] = {}
    for p in points:
        key = (p.speed, p.variant) if by_mass else (None, p.variant)
        lines.setdefault(key, []).append(p)
    for (speed, variant), members in lines.items():
        x = [p.mass if by_mass else 100 * p.speed for p in members]
        label = ", ".join(
            part
            for part in (
                f"{100 * speed:g} %" if speed is not None else "",
                Path(variant).name if variant else "",
            )
            if part
        )
        for ax, what in (
            (axes[0], "cycle_time"),
            (axes[1], "peak_torque_ratio"),
            (axes[2], "payload"),
        ):
            y = [np.nan if getattr(p, what) is None else getattr(p, what) for p in members]
            ax.plot(x, y, marker="o", label=label or None)
            bad = [(xi, yi) for xi, yi, p in zip(x, y, members) if not p.ok]
            if bad:
                ax.plot(*zip(*bad), "x", color="red", markersize=10, mew=2)
    axes[1].axhline(1.0, color="red", linewidth=1, linestyle="--")
    axes[2].axhline(0.0, color="red", linewidth=1, linestyle="--")
    for ax in axes:
        ax.set_xlabel(f"mass of {result.object} [kg]" if by_mass else "speed override [%]")
        ax.grid(alpha=0.3)
        if any(label for label in ax.get_legend_handles_labels()[1]):
            ax.legend(fontsize=8)
    axes[0].set_ylabel("cycle time [s]")
    axes[1].set_ylabel("peak |torque| / limit")
    axes[2].set_ylabel("payload capacity at the TCP [kg]")
    fig.suptitle(f"{result.cell}: {result.run} (red x: the check failed)")
    return save_figure(fig, path)


def _mark(ax, t: float, text: str, color: str, top: bool) -> None:
    """A vertical label at time ``t``, hanging from the top of the axes or standing on its
    bottom."""
    ax.annotate(
        text,
        (t, 1.0 if top else 0.02),
        xycoords=("data", "axes fraction"),
        rotation=90,
        fontsize=7,
        va="top" if top else "bottom",
        ha="right",
        color=color,
    )

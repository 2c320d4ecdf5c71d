"""``rworld calibrate-robot``: the robot's own kinematic errors from instrument observations,
written as a pose-file overlay (joint frames, the measured frame, the instrument's frame)."""

from __future__ import annotations

import dataclasses
import datetime as _dt
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import UserError

if TYPE_CHECKING:
    from ..calibration.robotplan import Touches

IMPLAUSIBLE = 100.0  # residual rms over this many sigma: the data do not fit this robot
MAX_CORRECTION = 0.05  # [m]: a joint frame, the target or the instrument frame moved further...
MAX_ROTATION = np.radians(10.0)  # ... or turned further is refused (--max-correction)
SPARE_EQUATIONS = 5  # equations at distinct poses beyond the identified parameters, at least
MIN_RANGE = np.radians(10.0)  # a joint moved over less is named (its parameters weakly seen)
MISFIT_WARNING = 2.0  # a-posteriori sigma over this many stated sigmas is named


@dataclass
class RobotCalibrationRun:
    """What ``calibrate-robot`` found and wrote."""

    device: str
    target: str
    frame: str
    observations: int
    parameters: int
    identified: int
    observability: float
    sigma: float  # the instrument's [m]
    before: dict  # position errors on the fit's observations [m]: rms, p95, max
    after: dict
    validation_before: dict | None
    validation_after: dict | None
    predicted_validation: float | None  # rms the covariance predicts (estimate only) [m]
    unidentifiable: list[str]
    parameter_rows: list[dict]  # name, correction, sigma (SI)
    flagged: list[str]  # file:line of observations with a residual over 4 sigma
    output: str
    written: bool
    listed: bool
    seconds: float = 0.0
    notes: list[str] = field(default_factory=list)
    cross_validation: dict | None = None  # --folds: pooled held-out errors [m]
    warnings: list[str] = field(default_factory=list)
    iterations: int = 0
    converged: bool = True
    variance_factor: float = 1.0  # a-posteriori sigma / the stated sigma
    predicted_parts: tuple[float, float] | None = None  # (estimate, kept nominal) [m]
    outliers: list[dict] = field(default_factory=list)  # ranked: where, residual [m]
    loss: str = "linear"
    model: str = "geometric"  # or "compliance": the joints' compliance under gravity fitted too

    def as_dict(self) -> dict:
        mm = lambda d: None if d is None else {k: v * 1000 for k, v in d.items()}  # noqa: E731
        return {
            "device": self.device,
            "target": self.target,
            "frame": self.frame,
            "observations": self.observations,
            "parameters": self.parameters,
            "identified": self.identified,
            "observability_index": self.observability,
            "sigma_mm": self.sigma * 1000,
            "fit_mm": {"before": mm(self.before), "after": mm(self.after)},
            "validation_mm": None
            if self.validation_before is None
            else {
                "before": mm(self.validation_before),
                "after": mm(self.validation_after),
                "predicted_rms_of_the_estimate": None
                if self.predicted_validation is None
                else self.predicted_validation * 1000,
            },
            "unidentifiable": self.unidentifiable,
            "parameters_identified": [
                {
                    "name": r["name"],
                    "correction": r["correction"],
                    "sigma": r["sigma"],
                    "unit": r["unit"],
                }
                for r in self.parameter_rows
            ],
            "flagged": self.flagged,
            "outliers": [
                {"where": o["where"], "residual_mm": o["residual"] * 1000} for o in self.outliers
            ],
            "iterations": self.iterations,
            "converged": self.converged,
            "a_posteriori_sigma_mm": self.sigma * self.variance_factor * 1000,
            "variance_factor": self.variance_factor,
            "loss": self.loss,
            "model": self.model,
            "predicted_parts_mm": None
            if self.predicted_parts is None
            else {
                "estimate": self.predicted_parts[0] * 1000,
                "kept_nominal": self.predicted_parts[1] * 1000,
            },
            "warnings": self.warnings,
            "cross_validation_mm": None
            if self.cross_validation is None
            else {
                "folds": self.cross_validation["folds"],
                "before": mm(self.cross_validation["before"]),
                "after": mm(self.cross_validation["after"]),
            },
            "output": self.output,
            "written": self.written,
            "listed": self.listed,
            "seconds": self.seconds,
            "notes": self.notes,
        }


def _merge(observations):
    from ..model.measurements import RobotObservations

    first = observations[0]
    for o in observations[1:]:
        if (o.device, o.target, o.frame) != (first.device, first.target, first.frame):
            raise UserError(
                "the observation files measure different things: "
                f"{first.device}/{first.target} in {first.frame} against "
                f"{o.device}/{o.target} in {o.frame}"
            )
    kinds = {
        ("contacts" if o.surfaces else "poses" if o.rotations is not None else "points")
        for o in observations
    }
    if len(kinds) > 1:
        raise UserError(
            f"the observation files mix {' and '.join(sorted(kinds))}: calibrate from one kind"
        )
    if first.surfaces is not None:
        from ..model.measurements import Surfaces

        if len({o.surfaces.ball for o in observations if o.surfaces}) > 1:
            raise UserError("the contact files give different probe radii")
        parts = [o.surfaces for o in observations if o.surfaces is not None]
        surfaces = Surfaces(
            [k for part in parts for k in part.kind],
            np.vstack([part.point for part in parts]),
            np.vstack([part.direction for part in parts]),
            np.concatenate([part.radius for part in parts]),
            parts[0].ball,
            [n for part in parts for n in part.names],
            [o for part in parts for o in part.owners],
        )
        return RobotObservations(
            first.device,
            first.target,
            first.frame,
            np.vstack([o.q for o in observations]),
            np.zeros((sum(len(o.q) for o in observations), 3)),
            float(np.sqrt(np.mean([o.sigma**2 for o in observations]))),
            [line for o in observations for line in o.lines],
            first.instrument,
            surfaces=surfaces,
        )
    sigma = float(np.sqrt(np.mean([o.sigma**2 for o in observations])))
    poses = first.rotations is not None
    return RobotObservations(
        first.device,
        first.target,
        first.frame,
        np.vstack([o.q for o in observations]),
        np.vstack([o.points for o in observations]),
        sigma,
        [line for o in observations for line in o.lines],
        first.instrument,
        np.concatenate([o.rotations for o in observations]) if poses else None,  # type: ignore[misc]
        float(np.sqrt(np.mean([o.sigma_angle**2 for o in observations]))) if poses else 0.0,
    )


def calibrate_robot(
    cell_path: str,
    observation_paths: list[str],
    device: str | None = None,
    output: str | None = None,
    dry_run: bool = False,
    validate: list[str] | None = None,
    folds: int = 0,
    loss: str = "linear",
    loss_scale: float | None = None,
    frame_only: bool = False,
    max_correction: float = MAX_CORRECTION,
    max_rotation: float = MAX_ROTATION,
    accept_misfit: bool = False,
    error_model: str = "geometric",
) -> RobotCalibrationRun:
    """Identify a device's kinematic errors (joint frames, or DH rows with a correction each)
    from instrument observations and write them as a pose-file overlay (unless ``dry_run``).

    ``loss``: linear, huber or soft_l1 (``loss_scale`` [m], default 3 sigma); ``frame_only``:
    the instrument frame (and the target's offset) alone, the robot nominal;
    ``max_correction`` [m] / ``max_rotation`` [rad]: a joint frame, the target or the
    instrument frame moved further is refused; ``accept_misfit``: write even when the
    residuals are over 100 stated sigmas; ``error_model``: "geometric" (the joint frames) or
    "compliance" (and each joint's compliance under the torque holding the arm against gravity,
    from the cell's link masses and what the arm carries).

    Raises
    ------
    UserError
        Bad or mismatched observation files (located), a target without a pose, the
        compliance model for an arm without link masses,
        data that do not fit the robot (residuals over 100 sigma: a unit read wrongly), an
        output that is one of the cell's own files.
    """
    import time

    from ..calibration.robot import RobotModel, identify, position_errors
    from ..schema.loader import load_cell
    from ..schema.robotobs import read_observations
    from ..world.tree import World
    from .calibration import overlay_output

    started = time.perf_counter()
    cell = load_cell(cell_path).cell
    out = overlay_output(cell_path, cell, output, "robot_calibrated.yaml", "the calibrated robot")
    if not observation_paths:
        raise UserError("give at least one observation file")
    read = [read_observations(p, cell) for p in observation_paths]
    obs = _merge([o for o, _ in read])
    if device is not None and device != obs.device:
        raise UserError(f"--device {device}, but the observations are of '{obs.device}'")
    dev = cell.devices[obs.device]
    world = World(cell)
    if obs.surfaces is not None:  # the touched features where the cell has them
        obs = dataclasses.replace(obs, surfaces=obs.surfaces.placed(world.T_world))
    link, T_link_target = world.mount_of(obs.device, obs.target)
    if obs.target not in cell.pose_sources:
        raise UserError(
            f"'{obs.target}' has no pose of its own (a link frame): measure a frame with a pose "
            "on the link (a TCP, a reflector's frame), whose offset can be calibrated"
        )
    T_world_base = world.T_world(obs.device)
    estimated = obs.frame != "world"
    T_world_frame = world.T_world(obs.frame) if estimated else np.eye(4)
    if error_model not in MODELS:
        raise UserError(f"--model {error_model}: give one of {', '.join(MODELS)}")
    gravity, compliant, torque_scale, compliance_notes = _holding_torques(
        cell, world, dev, error_model == "compliance"
    )
    model = RobotModel(
        dev,
        np.linalg.solve(T_world_frame, T_world_base),
        link,
        T_link_target[:3, 3].copy(),
        estimated,
        T_link_target[:3, :3].copy() if obs.rotations is not None else None,
        gravity,
        compliant,
        torque_scale,
    )
    if 3 * len(obs.q) < 12:
        raise UserError(f"{len(obs.q)} observation(s): too few to identify anything")
    if not np.all(np.isfinite(obs.points)) or np.abs(obs.points).max(initial=0.0) > 1e4:
        k = int(np.argmax(np.abs(np.nan_to_num(obs.points, nan=np.inf)).max(axis=1)))
        raise UserError(
            f"{obs.lines[k] if k < len(obs.lines) else observation_paths[0]}: a coordinate of "
            f"{np.abs(obs.points[k]).max():.4g} m: no instrument measures that; check the units"
        )
    from ..calibration.robot import LOSSES

    if loss not in LOSSES:
        raise UserError(f"--loss {loss}: give one of {', '.join(LOSSES)}")
    warnings = _design_warnings(obs, dev)
    result = identify(model, obs, loss=loss, loss_scale=loss_scale, frame_only=frame_only)
    result.notes[:0] = compliance_notes
    model = result.model  # with its instrument frame registered
    per_pose = result.residuals.shape[1]
    equations = len(np.unique(np.round(obs.q, 6), axis=0)) * per_pose  # repeated poses: once
    if equations < result.rank + SPARE_EQUATIONS:
        needed = int(np.ceil((result.rank + SPARE_EQUATIONS) / per_pose))
        raise UserError(
            f"{len(obs.q)} observation(s) give {equations} equations at distinct poses for "
            f"{result.rank} identifiable parameters: the fit needs {SPARE_EQUATIONS} more than "
            f"it identifies to show its error ({needed} observations at distinct poses), or "
            "fewer parameters (--frame-only); nothing written"
        )
    rms = float(np.sqrt(np.mean(result.residuals[:, :3] ** 2)))  # per coordinate (or gap)
    turned = np.sqrt(np.mean(result.residuals[:, 3:] ** 2)) if obs.rotations is not None else 0.0
    if (rms > IMPLAUSIBLE * obs.sigma or turned > IMPLAUSIBLE * obs.sigma) and not accept_misfit:
        raise UserError(
            f"the observations do not fit '{obs.device}': residuals of {rms * 1000:.4g} mm rms "
            f"per coordinate after the fit, {rms / obs.sigma:.0f} times the stated sigma "
            f"({obs.sigma * 1000:g} mm). The causes, most likely first: a unit read wrongly (a "
            "joint in rad read as deg, points in m read as mm; check what the files state), the "
            f"joint order, points that are not of '{obs.target}' in '{obs.frame}', a sigma far "
            "too small for the instrument, or error the geometric model does not have "
            "(compliance, backlash). --accept-misfit writes the calibration all the same"
        )
    if result.variance_factor > MISFIT_WARNING:
        warnings.append(
            f"the residuals are {result.variance_factor:.1f} times the stated sigma "
            f"({obs.sigma * 1000:g} mm): non-geometric error or an optimistic sigma; the "
            "uncertainties are scaled by that factor"
        )
    if not result.converged:
        warnings.append(f"the fit did not converge in {result.iterations} iterations")
    moved = _too_large(model, result, max_correction, max_rotation)
    if moved:
        raise UserError(
            "implausible calibration, nothing written: "
            + "; ".join(moved)
            + f" (more than --max-correction {max_correction * 1000:g} mm / "
            f"{np.degrees(max_rotation):g} deg). A unit read wrongly, points of another target "
            "or frame, or data that cannot separate these parameters are the usual causes"
        )
    warnings += _negative_compliance(model, result)
    zeros = np.zeros_like(result.p)
    before = position_errors(model, zeros, obs)
    after = position_errors(model, result.p, obs)
    validation_before = validation_after = predicted = None
    if validate:
        checks = _merge([read_observations(p, cell)[0] for p in validate])
        if checks.surfaces is not None:
            checks = dataclasses.replace(checks, surfaces=checks.surfaces.placed(world.T_world))
        if (checks.device, checks.target, checks.frame) != (obs.device, obs.target, obs.frame):
            raise UserError("the validation files measure another device, target or frame")
        validation_before = position_errors(model, zeros, checks)
        validation_after = position_errors(model, result.p, checks)
        parts = result.predicted(checks.q)
        predicted = float(np.hypot(*parts))
    else:
        parts = None
    cross = None
    if folds:
        cross = _cross_validation(model, obs, folds, loss, loss_scale, frame_only)
    rows = []
    for name, value, sigma in zip(model.names, result.p, result.sigma):
        factor, unit = _display_unit(name, dev)
        rows.append(
            {
                "name": name,
                "correction": float(value * factor),
                "sigma": float(sigma * factor),
                "unit": unit,
            }
        )
    written = False
    if not dry_run:
        _write_overlay(out, obs, model, result, [d for _, d in read], world, T_link_target)
        written = True
    listed = out.resolve() in {p.resolve() for p in cell.pose_files}
    return RobotCalibrationRun(
        obs.device,
        obs.target,
        obs.frame,
        len(obs.q),
        len(result.p),
        result.rank,
        result.observability,
        obs.sigma,
        before,
        after,
        validation_before,
        validation_after,
        predicted,
        [u.describe() for u in result.unidentifiable],
        rows,
        [obs.lines[k] for k in result.flagged if k < len(obs.lines)],
        str(out),
        written,
        listed,
        time.perf_counter() - started,
        notes=result.notes,
        cross_validation=cross,
        warnings=warnings,
        iterations=result.iterations,
        converged=result.converged,
        variance_factor=result.variance_factor,
        predicted_parts=parts,
        outliers=[
            {
                "where": obs.lines[k] if k < len(obs.lines) else f"observation {k + 1}",
                "residual": float(np.linalg.norm(result.residuals[k])),
            }
            for k in result.flagged
        ],
        loss=loss,
        model=error_model,
    )


MODELS = ("geometric", "compliance")


def _display_unit(name: str, dev) -> tuple[float, str]:
    """(SI -> shown factor, unit) of a calibration parameter: mm, deg, and a compliance in
    mrad/kNm (= urad/Nm) or mm/kN (= um/N)."""
    group, _, part = name.rpartition(".")
    if part == "compliance":
        prismatic = next(j.kind for j in dev.joints if j.name == group) == "prismatic"
        return (1e6, "mm/kN") if prismatic else (1e6, "mrad/kNm")
    if part in ("rx", "ry", "rz"):
        return float(np.degrees(1.0)), "deg"
    return 1000.0, "mm"


def _holding_torques(cell, world, dev, fitted: bool):
    """What the compliance model needs of the cell: (the holding torques at joint values (K, n)
    -> (K, n) [N m, N] or None for a stiff arm, the joints whose compliance is fitted, the
    largest holding torque of each joint over 256 states in its limits, notes on the joints
    left out).  The torques are the cell's own dynamics: its link masses and what the arm
    carries in the cell (a tool, a reflector), gravity in the arm's base axes."""
    if not fitted and not any(j.compliance for j in dev.joints):
        return None, (), None, []
    from ..dynamics.compliance import holding_torques

    g_base = world.T_world(dev.name)[:3, :3].T @ cell.gravity
    holding = holding_torques(dev, world.carried_loads(dev.name), g_base)
    low = np.maximum(dev.limit_array("lower"), -np.pi)
    high = np.minimum(dev.limit_array("upper"), np.pi)
    states = np.random.default_rng(0).uniform(low, high, size=(256, dev.dof))
    scale = np.abs(holding(states)).max(axis=0)
    if not fitted:
        return holding, (), scale, []
    if scale.max() <= 1e-9:
        raise UserError(
            f"--model compliance: '{dev.name}' holds no torque against gravity in this cell "
            "(its links give no mass: 'inertial:' in the cell, or the URDF's <inertial>); "
            "compliance is the joints' yield under that torque. Give the links' masses, or "
            "use --model geometric"
        )
    # a joint whose torque never reaches 1e-3 of the largest (a vertical first axis, a wrist
    # roll carrying nothing) shows no yield: its compliance is not a parameter
    compliant = tuple(int(i) for i in np.flatnonzero(scale > 1e-3 * scale.max()))
    notes = [
        f"{dev.joints[i].name} holds at most {scale[i]:.3g} "
        f"{'N' if dev.joints[i].kind == 'prismatic' else 'N m'} against gravity here: its "
        "compliance is not seen and stays as the cell gives it"
        for i in range(dev.dof)
        if i not in compliant
    ]
    return holding, compliant, scale, notes


def _negative_compliance(model, result) -> list[str]:
    """A compliance estimated below zero by more than 2 sigma, in words: not a physical yield."""
    out = []
    start = model.compliance_start
    for k, i in enumerate(model.compliant):
        value, sigma = result.p[start + k], result.sigma[start + k]
        if value < -2 * sigma and sigma > 0:
            c = value + model.device.joints[i].compliance
            out.append(
                f"{model.device.joints[i].name}'s compliance came out negative "
                f"({c * 1e6:.3g} mrad/kNm, {value / sigma:.1f} sigma): the joint would move "
                "against its load; error the model does not have is the likelier cause"
            )
    return out


def _design_warnings(obs, dev) -> list[str]:
    """What the observations' joint states cannot support well: repeated poses, joints moved
    over less than :data:`MIN_RANGE`."""
    out = []
    distinct = len(np.unique(np.round(obs.q, 6), axis=0))
    if distinct < len(obs.q):
        out.append(
            f"{len(obs.q) - distinct} of {len(obs.q)} observations repeat a joint state: "
            f"they add no information on the geometry ({distinct} distinct poses)"
        )
    spans = obs.q.max(axis=0) - obs.q.min(axis=0)
    for j, span in zip(dev.joints, spans):
        limit = MIN_RANGE if j.kind == "revolute" else 0.05
        if span < limit:
            unit = np.degrees(span) if j.kind == "revolute" else span * 1000
            out.append(
                f"{j.name} moved over {unit:.3g} {'deg' if j.kind == 'revolute' else 'mm'} only: "
                "its parameters are seen weakly or not at all"
            )
    return out


def _too_large(model, result, max_correction: float, max_rotation: float) -> list[str]:
    """Each joint frame, the target and the instrument frame whose correction is beyond the
    bounds, in words."""
    groups: dict[str, list[int]] = {}  # a joint frame, the target, the instrument frame
    for k, name in enumerate(model.names):
        group, _, part = name.rpartition(".")
        if part != "compliance":
            groups.setdefault(group, []).append(k)
    out = []
    for group, rows in groups.items():
        d = np.zeros(6)
        d[: len(rows)] = result.p[rows]  # x y z (rx ry rz)
        length, angle = float(np.linalg.norm(d[:3])), float(np.linalg.norm(d[3:]))
        if length > max_correction or angle > max_rotation:
            out.append(f"{group} moves by {length * 1000:.1f} mm and {np.degrees(angle):.2f} deg")
    start = model.compliance_start
    for k, i in enumerate(model.compliant):  # a yield at the joint's largest holding torque
        j = model.device.joints[i]
        bound = max_correction if j.kind == "prismatic" else max_rotation
        yielded = abs(result.p[start + k]) * float(model.torque_scale[i])
        if yielded > bound:
            shown = (
                f"{yielded * 1000:.1f} mm"
                if j.kind == "prismatic"
                else (f"{np.degrees(yielded):.2f} deg")
            )
            out.append(f"{j.name}'s compliance yields {shown} at its largest holding torque")
    return out


def _cross_validation(model, obs, folds: int, loss="linear", scale=None, frame_only=False) -> dict:
    """k-fold: each fold's observations predicted by a fit on the others; the errors pooled
    (rms, p95, max [m]) for the nominal and the fitted models.  Both are held-out figures:
    "before" is the nominal robot with what any fit refits (the instrument frame registered,
    the target's offset) fitted on the same training fold."""
    from ..calibration.robot import identify

    K = len(obs.q)
    if not 2 <= folds <= K // 4:
        raise UserError(f"--folds {folds}: give 2 to {K // 4} folds for {K} observations")
    order = np.random.default_rng(0).permutation(K)
    before: list[float] = []
    after: list[float] = []
    for k in range(folds):
        test = order[k::folds]
        train = np.setdiff1d(order, test)

        def part(rows):
            return dataclasses.replace(
                obs,
                q=obs.q[rows],
                points=obs.points[rows],
                rotations=None if obs.rotations is None else obs.rotations[rows],
                surfaces=None if obs.surfaces is None else _take(obs.surfaces, rows),
                lines=[obs.lines[r] for r in rows if r < len(obs.lines)],
            )

        train_obs, held = part(train), part(test)
        fit = identify(model, train_obs, loss=loss, loss_scale=scale, frame_only=frame_only)
        base = identify(model, train_obs, frame_only=True)
        for fitted, into in ((base, before), (fit, after)):
            residual = fitted.model.residuals(fitted.p, held)
            if held.surfaces is not None:
                into.extend(np.abs(residual[:, 0]))
            else:
                into.extend(np.linalg.norm(residual[:, :3], axis=1))

    def stats(d) -> dict:
        d = np.asarray(d)
        return {
            "rms": float(np.sqrt(np.mean(d**2))),
            "p95": float(np.percentile(d, 95)),
            "max": float(d.max()),
        }

    return {"folds": folds, "before": stats(before), "after": stats(after)}


def _take(surfaces, rows):
    from ..model.measurements import Surfaces

    return Surfaces(
        [surfaces.kind[r] for r in rows],
        surfaces.point[rows],
        surfaces.direction[rows],
        surfaces.radius[rows],
        surfaces.ball,
        [surfaces.names[r] for r in rows] if surfaces.names else [],
    )


def _write_overlay(out: Path, obs, model, result, digests, world, T_link_target) -> None:
    """The calibrated numbers as a pose file (mm, deg): every joint's frame (and compliance),
    the measured frame's pose, the instrument frame's pose; provenance with the files'
    hashes."""
    from .. import spatial
    from ..calibration.robot import small_pose
    from ..fileio import atomic_write_text
    from ..schema.yamlio import yaml_value

    def pose(T) -> str:
        xyz = ", ".join(repr(float(x) * 1000) for x in T[:3, 3])
        rpy = ", ".join(repr(float(x)) for x in np.degrees(spatial.matrix_to_rpy(T[:3, :3])))
        return f"{{xyz: [{xyz}], rpy: [{rpy}]}}"

    def T_world(frame: str | None) -> np.ndarray:
        return world.T_world(frame) if frame not in (None, "world") else np.eye(4)

    n = result.device.dof
    lines = [
        "# The robot's calibrated kinematics, written by 'rworld calibrate-robot'.  List this",
        "# file last in the cell's pose_files; the nominal values stay where they are.",
        "units: {length: mm, angle: deg}",
    ]
    if result.device.convention == "frames":  # each joint's frame
        lines.append("joints:")
        for j in result.device.joints:
            lines.append(f"  {yaml_value(f'{obs.device}.{j.name}')}: {pose(j.origin)}")
    else:  # a small pose before each DH row
        lines.append("corrections:")
        for j in result.device.joints:
            lines.append(f"  {yaml_value(f'{obs.device}.{j.name}')}: {pose(j.correction)}")
    if any(j.compliance for j in result.device.joints):  # per kN m (per kN): readable numbers
        lines.append("compliance:  # deg per kN m (mm per kN for a prismatic joint)")
        for j in result.device.joints:
            unit = 1000.0 if j.kind == "prismatic" else float(np.degrees(1.0))  # mm or deg
            value = repr(float(j.compliance * unit * 1000))
            lines.append(f"  {yaml_value(f'{obs.device}.{j.name}')}: {value}")
    # the measured frame: its point on the link moved by the estimate, relative to its parent
    # (on the same link, so any joint state gives the same relative pose)
    if model.R_link_target is None:
        T_link_new = T_link_target.copy()
        T_link_new[:3, 3] += result.p[6 * n : 6 * n + 3]
    else:
        T_link_new = T_link_target @ small_pose(result.p[6 * n : 6 * n + 6])
    T_world_link = world.T_world(obs.target) @ np.linalg.inv(T_link_target)
    poses = {
        obs.target: np.linalg.solve(T_world(world.parent(obs.target)), T_world_link @ T_link_new)
    }
    if model.frame_estimated:  # the instrument's frame F' = F R E (R: its registration)
        m = model.target_count
        E = small_pose(result.p[6 * n + m : 6 * n + m + 6])
        poses[obs.frame] = np.linalg.solve(
            T_world(world.parent(obs.frame)),
            world.T_world(obs.frame) @ result.T_frame_registered @ E,
        )
    lines.append("poses:")
    for name, T in poses.items():
        lines.append(f"  {yaml_value(name)}: {pose(T)}")
    lines.append("provenance:")
    lines.append(f"  date: {yaml_value(_dt.datetime.now().replace(microsecond=0).isoformat())}")
    lines.append("  tool: rworld calibrate-robot")
    lines.append(f"  device: {yaml_value(obs.device)}")
    lines.append("  observations:")
    for d in digests:
        lines.append(f"    - {{path: {yaml_value(str(d['path']))}, sha256: {d['sha256']}}}")
    lines.append(f"  points: {len(obs.q)}")
    lines.append(f"  identified: {yaml_value(f'{result.rank} of {len(result.p)} parameters')}")
    lines.append(f"  observability_index: {result.observability:.6g}")
    rms = float(np.sqrt(np.mean(np.sum(result.residuals**2, axis=1))))
    lines.append(f"  residual_rms_mm: {rms * 1000:.6g}")
    atomic_write_text(out, "\n".join(lines) + "\n")


@dataclass
class RobotPosePlanRun:
    """What ``plan-robot-calibration`` chose and wrote."""

    device: str
    target: str
    instrument: str  # "tracker" or "probe"
    poses: int
    candidates: int
    rejected: int  # unreachable, or colliding on the way
    identifiable: int
    predicted: float  # [m] rms error of the calibrated model, the estimate's own
    random_same: float
    random_double: float
    best_possible: float  # [m] no choice of as many candidates predicts less
    q: np.ndarray  # (N, n) SI, in visiting order (touches: at the contact)
    features: list[str]  # touches: the feature of each; a tracker: empty
    program: str | None
    template: str | None
    dropped: int = 0  # poses replaced because the program collided on the way to them
    seconds: float = 0.0
    constraints: dict = field(default_factory=dict)  # tracker: candidates lost, by reason

    def as_dict(self) -> dict:
        return {
            "constraints_lost": self.constraints,
            "device": self.device,
            "target": self.target,
            "instrument": self.instrument,
            "poses": self.poses,
            "candidates": self.candidates,
            "rejected": self.rejected,
            "identifiable": self.identifiable,
            "predicted_rms_mm": self.predicted * 1000,
            "random_same_count_rms_mm": self.random_same * 1000,
            "random_double_count_rms_mm": self.random_double * 1000,
            "best_possible_rms_mm": self.best_possible * 1000,
            "joints": self.q.tolist(),
            "features": self.features,
            "program": self.program,
            "template": self.template,
            "dropped_on_the_way": self.dropped,
            "seconds": self.seconds,
        }


def _collision_free(cell, device: str, Q: np.ndarray) -> np.ndarray:
    """Which joint states (K, n) of ``device`` touch nothing it may not touch (K,) bool: the
    collision room's configuration check, with no overlap tolerated."""
    from ..collision.bodies import collision_model
    from ..collision.configurations import ConfigurationChecker
    from ..world.tree import World

    checker = ConfigurationChecker(World(cell), collision_model(cell), device, tolerance=0.0)
    return checker.check(Q, nearest=False).free


SIGHT_CLEARANCE = 0.01  # [m]: the line of sight's radius: no robot body within it
SIGHT_START = 0.03  # [m]: from this far out from the target (its own mount is not in the way)


def _visible(cell, device, target, Q, floor, instrument_at, acceptance, world):
    """Which tracker candidates (M, n) the instrument can measure: the target above the floor
    (world z) or the robot's mounting plane, facing the instrument within the acceptance angle
    of its z axis, the line of sight clear of every robot body by :data:`SIGHT_CLEARANCE`.
    Returns (kept (M,) bool, {reason: count lost})."""
    from ..collision.bodies import ball_body, collision_model, distances

    link, T_link_target = world.mount_of(device, target)
    T_world_base = world.T_world(device)
    from ..kinematics.jacobian import ToolMount, tool_pose

    T = T_world_base @ tool_pose(cell.devices[device], Q, ToolMount(link, T_link_target))
    p = T[:, :3, 3]
    lost: dict[str, int] = {}
    if floor is not None:
        keep = p[:, 2] > floor
        lost["below the floor"] = int((~keep).sum())
    else:
        height = (p - T_world_base[:3, 3]) @ T_world_base[:3, 2]
        keep = height > 0
        lost["below the robot's mounting plane"] = int((~keep).sum())
    if instrument_at is None:
        return keep, lost
    to = instrument_at - p
    distance = np.linalg.norm(to, axis=1)
    if acceptance is not None:
        facing = np.einsum("ij,ij->i", to / distance[:, None], T[:, :3, 2])
        inside = facing >= np.cos(acceptance)
        lost["outside the reflector's acceptance angle"] = int((keep & ~inside).sum())
        keep &= inside
    # the line of sight: balls of the clearance's radius along it, against the robot's bodies
    model = collision_model(cell)
    bodies = list(model.bodies)
    robot = [i for i, b in enumerate(bodies) if b.owner == device]
    if not robot:
        return keep, lost
    ball = len(bodies)
    bodies.append(ball_body("line of sight", SIGHT_CLEARANCE))
    reach = max(float(np.linalg.norm(p - T_world_base[:3, 3], axis=1).max()), 0.1) + 0.3
    # every kept candidate's beam samples at once: SIGHT_START, + clearance, ... to its end
    kept = np.flatnonzero(keep)
    length = np.minimum(distance[kept], reach)  # beyond the reach nothing is in the way
    counts = np.maximum(np.ceil((length - SIGHT_START) / SIGHT_CLEARANCE).astype(int), 0)
    owner = np.repeat(kept, counts)
    if not len(owner):
        return keep, lost
    step = np.arange(len(owner)) - np.repeat(np.cumsum(counts) - counts, counts)
    along = SIGHT_START + step * SIGHT_CLEARANCE
    C = p[owner] + along[:, None] * (to[owner] / distance[owner][:, None])
    frames = sorted({bodies[i].frame for i in robot})
    T_bodies = world.T_world_frames(frames, {device: Q})  # per candidate, not per sample
    hidden = np.zeros(len(Q), dtype=bool)
    for i in robot:
        b = bodies[i]
        Tb = T_bodies[b.frame]
        centre = np.einsum("kij,j->ki", Tb[:, :3, :3], b.center) + Tb[:, :3, 3]
        near = np.flatnonzero(
            np.linalg.norm(centre[owner] - C, axis=1) <= b.radius + SIGHT_CLEARANCE
        )
        near = near[~hidden[owner[near]]]
        if not len(near):
            continue
        Tc = np.broadcast_to(np.eye(4), (len(near), 4, 4)).copy()
        Tc[:, :3, 3] = C[near]
        result = distances(
            bodies, np.full(len(near), i), np.full(len(near), ball), Tb[owner[near]], Tc
        )
        hidden[owner[near[result.overlap]]] = True
    lost["with the arm in the line of sight"] = int((keep & hidden).sum())
    return keep & ~hidden, lost


@dataclass
class _Pool:
    """Candidates of one instrument: the states to choose from and how a program visits them."""

    q: np.ndarray  # (M, n) where the instrument measures
    q_path: np.ndarray  # (M, n) reached from home by a joint move (touches: the approach)
    normals: np.ndarray | None = None  # touches: (M, 3) world
    touches: Touches | None = None


def _tracker_pool(dev, rng, candidates: int) -> _Pool:
    lower, upper = dev.limit_array("lower"), dev.limit_array("upper")
    lo = np.where(np.isfinite(lower), lower, -np.pi)
    hi = np.where(np.isfinite(upper), upper, np.pi)
    q = rng.uniform(lo, hi, (candidates, dev.dof))
    return _Pool(q, q)


def _visit_steps(pool: _Pool, k: int, label: int, cell, device: str, target: str, sensor):
    """The steps that visit candidate ``k`` from home and back (mm, deg)."""
    from ..calibration.probing import _offset
    from ..schema.robotobs import file_scale

    values = [float(f"{v:.6f}") for v in pool.q_path[k] * file_scale(cell.devices[device])]
    if pool.touches is None:
        return [
            ({"move": {"joints": values}}, f"pose {label}"),
            ({"wait": {"time": 1.0}}, "the instrument's reading"),
            ({"move": {"to": "home"}}, None),
        ]
    t = pool.touches
    feature = t.features[k]
    owner = cell.features[feature].owner
    tcp = target.split(".", 1)[1] if target.startswith(device + ".") else target
    guarded = {"to": owner, "tcp": tcp, "offset": _offset(t.T_owner_end[k])}
    guarded.update(motion="linear", speed=0.04, until=sensor)
    back = {"to": owner, "tcp": tcp, "offset": _offset(t.T_owner_approach[k]), "motion": "linear"}
    return [
        ({"move": {"joints": values}}, f"touch {label}: {feature}"),
        ({"move": guarded}, "record the joint values at the trigger"),
        ({"probe": feature}, None),
        ({"move": back}, None),
        ({"move": {"to": "home"}}, None),
    ]


def plan_robot_calibration(
    cell_path: str,
    device: str,
    count: int,
    target: str | None = None,
    sigma: float = 2e-5,
    candidates: int = 2000,
    seed: int = 0,
    program: str | None = None,
    template: str | None = None,
    instrument: str = "tracker",
    features: list[str] | None = None,
    floor: float | None = None,
    instrument_at: np.ndarray | None = None,
    acceptance: float | None = None,
) -> RobotPosePlanRun:
    """Choose ``count`` joint states to measure for ``calibrate-robot``, then the choice that
    predicts the smallest error of the calibrated model
    (:func:`rworld_cli.calibration.robotplan.select_poses`), visited in a short order.

    ``instrument``: ``"tracker"`` (an instrument measures ``target``'s point; candidates are
    random joint states within the limits) or ``"probe"`` (self-calibration: the robot's own
    ball-tip touch probe, centred on ``target``, touches ``features`` of known geometry -
    planes and edges; candidates are touches on material with the stylus within 40 deg of the
    normal, :func:`rworld_cli.calibration.robotplan.touch_candidates`).  A candidate is kept
    when the robot touches nothing there (touches: at the approach) and on the joint path from
    home.  ``program``: a program that visits them - a pause at each for the instrument, or a
    guarded move to each touch - checked in simulation (a pose the robot collides on the way to
    is replaced).  ``template``: an observation or contacts file of the poses, to fill in.

    A tracker's candidates must also keep the target above the floor - ``floor`` [m, world z],
    else the robot's mounting plane (its base frame's xy plane) - and, with the instrument at
    ``instrument_at`` (3,) [m, world], face it within ``acceptance`` [rad] of the target's z
    axis (a reflector's acceptance cone) with the line of sight clear of the robot
    (:func:`_visible`).

    Raises
    ------
    UserError
        Unknown device, target or feature, no touch probe, too few usable candidates, bad
        numbers.
    CheckFailed
        The program still collides after the replacements.
    """
    import time

    from ..calibration.robot import RobotModel
    from ..calibration.robotplan import select_poses, touch_candidates
    from ..errors import CheckFailed, did_you_mean
    from ..fileio import atomic_write_text, output_set
    from ..schema.loader import load_cell
    from ..schema.programs import load_run, program_text
    from ..simulate.engine import simulate
    from ..world.tree import World

    started = time.perf_counter()
    cell = load_cell(cell_path).cell
    if device not in cell.devices:
        raise UserError(f"unknown device '{device}'{did_you_mean(device, cell.devices)}")
    if not (count >= 1 and candidates >= count and sigma > 0 and np.isfinite(sigma)):
        raise UserError("give --poses >= 1, --candidates >= --poses and a sigma above 0")
    dev = cell.devices[device]
    if program is not None and not np.isfinite(dev.limit_array("acceleration")).any():
        # said once, before minutes of planning, not per move of the program checked at the end
        raise UserError(
            f"--program: no joint of '{device}' has an acceleration limit, so nothing times the "
            "program's moves: add 'acceleration' to its joints' limits in the cell (an imported "
            "robot: import it with --joint-limits joint_limits.yaml); nothing written"
        )
    sensor: str | None = None
    radius = 0.0
    if instrument == "probe":
        from ..calibration.probing import find_probe

        if features is None or not features:
            raise UserError(
                "--instrument probe touches features of known geometry: name them with "
                "--feature (planes and edges of a calibrated artefact or part)"
            )
        target, sensor = find_probe(cell, device, target, None)
        radius = float(cell.sensors[sensor].ball or 0.0)  # find_probe: a ball-tip probe
    elif instrument != "tracker":
        raise UserError(f"unknown instrument '{instrument}': tracker or probe")
    target = target or dev.tcps[0]
    if target not in cell.frames and f"{device}.{target}" in cell.frames:
        target = f"{device}.{target}"
    if target not in cell.frames:
        raise UserError(f"unknown frame '{target}'{did_you_mean(target, cell.frames)}")
    world = World(cell)
    link, T_link_target = world.mount_of(device, target)
    model = RobotModel(
        dev, np.linalg.inv(world.T_world(device)), link, T_link_target[:3, 3].copy(), False
    )
    rng = np.random.default_rng(seed)
    constraints: dict[str, int] = {}
    if features and instrument == "probe":
        touches, tried = touch_candidates(cell, device, target, radius, features, candidates, seed)
        pool = _Pool(touches.q, touches.q_approach, touches.normals, touches)
    else:
        pool, tried = _tracker_pool(dev, rng, candidates), candidates
        seen, lost = _visible(cell, device, target, pool.q, floor, instrument_at, acceptance, world)
        pool = _Pool(pool.q[seen], pool.q_path[seen])
        constraints = lost
    # each pose is visited from home and back: the pose and the joint path to it must be free
    fractions = np.linspace(0.125, 1.0, 8)
    path = dev.home + fractions[:, None, None] * (pool.q_path - dev.home)[None]  # (8, M, n)
    free = _collision_free(cell, device, path.reshape(-1, dev.dof)).reshape(8, -1).all(axis=0)
    usable_count = int(free.sum())
    if usable_count < count:
        lost_said = "".join(f"; {n} {why}" for why, n in constraints.items() if n)
        raise UserError(
            f"only {usable_count} of {tried} candidates are reachable and free of "
            f"collisions{lost_said}; ask for fewer poses or more candidates"
        )
    banned = np.logical_not(free)
    dropped = 0
    text = ""
    for _ in range(6):  # a pose the robot collides on the way to is replaced
        usable = np.nonzero(~banned)[0]
        chosen, figures = select_poses(
            model,
            pool.q[usable],
            count,
            sigma,
            seed,
            normals=None if pool.normals is None else pool.normals[usable],
        )
        picked = usable[chosen]
        picked = picked[np.argsort(np.abs(pool.q_path[picked] - dev.home).max(axis=1))]
        if program is None:
            break
        steps: list[tuple[dict, str | None]] = []
        per = 3 if pool.touches is None else 5
        for k, index in enumerate(picked):  # from home to each pose and back
            steps += _visit_steps(pool, int(index), k + 1, cell, device, target, sensor)
        what = f"measure {target} at each" if sensor is None else f"touch with {sensor}"
        text = program_text(
            {
                "header": [
                    f"Robot calibration poses for '{device}' (rworld plan-robot-calibration): "
                    f"{count} of {usable_count} usable candidates, {what}",
                ],
                "device": device,
                "units": {"length": "mm", "angle": "deg"},
                "steps": steps,
            }
        )
        trial = Path(program).with_name(f".{Path(program).name}.trial")
        trial.write_text(text)  # checked before it is written: the real file appears whole
        try:
            result = simulate(load_run(cell_path, str(trial)))
        finally:
            trial.unlink(missing_ok=True)
        bad = set()
        if result.collisions is not None:
            for contact in result.collisions.contacts:
                if contact.contact.collision:
                    bad |= {s.step // per for s in contact.steps if s.device == device}
        if result.ok and not bad:
            break
        if not bad:  # a limit broken, not a collision: the program says which
            raise CheckFailed(f"the calibration program breaks a limit: {result.violations[0]}")
        dropped += len(bad)
        banned[picked[[k for k in sorted(bad) if k < len(picked)]]] = True
        if int((~banned).sum()) < count:
            break
    else:
        raise CheckFailed(
            "the calibration program still collides on the way between poses after replacing "
            f"{dropped}: check {program}"
        )
    if program is not None and not (result.ok and not bad):
        raise CheckFailed(
            f"the calibration program collides on the way to {len(bad)} poses and too few "
            f"candidates are left to replace them: check {program}"
        )
    chosen_features = [] if pool.touches is None else [pool.touches.features[k] for k in picked]
    with output_set():  # the program and the template appear together or not at all
        if program is not None:
            atomic_write_text(program, text)
        if template is not None:
            from ..schema.robotobs import contacts_template, observation_template

            if pool.touches is None:
                nominal = model.points(np.zeros(len(model.names)), pool.q[picked])
                filled = observation_template(dev, target, pool.q[picked], nominal, sigma)
            else:
                filled = contacts_template(
                    dev, target, pool.q[picked], chosen_features, sigma, radius
                )
            atomic_write_text(template, filled)
    return RobotPosePlanRun(
        device,
        target,
        instrument,
        count,
        tried,
        tried - usable_count,
        int(figures["identifiable"]),
        float(figures["predicted"]),
        float(figures["random_same"]),
        float(figures["random_double"]),
        float(figures["best_possible"]),
        pool.q[picked],
        chosen_features,
        program,
        template,
        dropped,
        time.perf_counter() - started,
        constraints,
    )


# --------------------------------------------------------------------------- UR factory calibration

UR_JOINT_TOLERANCE = (0.02, np.radians(5.0))  # a calibrated UR joint frame within this of nominal


def import_ur_calibration(
    calibration: str, cell_path: str, output: str, device: str | None = None
) -> dict:
    """A UR robot's factory calibration (``ur_calibration``'s ``kinematics:`` file) as a
    pose-file overlay of the cell's joint frames (``rworld import ur-calibration``).

    The cell's UR is imported from ``ur_description`` (joint frames): each calibration group is
    its joint's ``origin`` in ``ur_macro.xacro``.  What ``rworld import urdf`` merged before a
    joint stays: before the shoulder, the fixed joints from the device's base to
    ``base_link_inertia`` (``base_link`` turned by pi about z), found from the cell's joint 1
    frame - a turn about z and a height, as the default kinematics' shoulder is on the base's
    axis; before the other joints nothing (their parents are the previous joints' links), which
    is checked: each frame within 20 mm and 5 deg of the calibration's.

    Returns
    -------
    dict
        ``written``, ``device``, ``hash`` and per joint how far the calibration moves its frame
        from the cell's (``moved_mm``, ``turned_deg``).

    Raises
    ------
    UserError
        A malformed file (located), no 6-joint joint-frame device, a cell whose frames are not
        ur_description's.
    """
    from .. import spatial
    from ..schema.loader import load_cell
    from ..schema.urcal import read_ur_calibration, write_joint_overlay
    from .calibration import overlay_output

    origins, label = read_ur_calibration(calibration)
    cell = load_cell(cell_path).cell
    candidates = [
        d
        for d in cell.devices.values()
        if d.convention == "frames" and d.dof == 6 and all(j.kind == "revolute" for j in d.joints)
    ]
    if device is not None:
        candidates = [d for d in candidates if d.name == device]
    if len(candidates) != 1:
        raise UserError(
            f"{cell_path}: "
            + (
                f"no 6-axis arm given by joint frames{f' named {device}' if device else ''} (a UR "
                "imported from ur_description)"
                if not candidates
                else "several 6-axis arms: choose one with --device"
            )
        )
    dev = candidates[0]
    out = overlay_output(cell_path, cell, output, "ur_calibration.yaml", "the UR calibration")
    nominal = [np.asarray(j.origin) for j in dev.joints]
    # before the shoulder: the merged fixed joints, a turn about z (and the shoulder's height)
    first = nominal[0]
    R = first[:3, :3]
    about_z = abs(R[2, 2] - 1.0) < 1e-9 and np.abs(R[:2, 2]).max() < 1e-9
    if not about_z or np.abs(first[:2, 3]).max() > 1e-9:
        raise UserError(
            f"{dev.name}.{dev.joints[0].name}'s frame is not ur_description's (a turn about z "
            "and a height above the base): import the robot from ur_description with its base "
            "at base_link or base"
        )
    before_shoulder = spatial.make_transform(R, np.zeros(3))
    calibrated = {dev.joints[0].name: before_shoulder @ origins[0]}
    report = []
    for i, (j, T_nom) in enumerate(zip(dev.joints, nominal)):
        T_cal = calibrated[j.name] if i == 0 else origins[i]
        if i > 0:
            calibrated[j.name] = T_cal
        moved = np.linalg.solve(T_nom, T_cal)
        shift = float(np.linalg.norm(moved[:3, 3]))
        turn = float(np.arccos(np.clip((np.trace(moved[:3, :3]) - 1) / 2, -1.0, 1.0)))
        if shift > UR_JOINT_TOLERANCE[0] or turn > UR_JOINT_TOLERANCE[1]:
            raise UserError(
                f"{calibration}: the '{j.name}' frame of the calibration is {shift * 1000:.1f} mm "
                f"and {np.degrees(turn):.2f} deg from {dev.name}'s: not this robot's calibration, "
                "or a cell not imported from ur_description (joints in its order: "
                "shoulder_pan, shoulder_lift, elbow, wrist_1, wrist_2, wrist_3)"
            )
        report.append(
            {"joint": j.name, "moved_mm": shift * 1000, "turned_deg": float(np.degrees(turn))}
        )
    write_joint_overlay(
        out,
        dev.name,
        calibrated,
        [
            f"UR factory calibration of '{dev.name}' (rworld import ur-calibration), from "
            f"{calibration}" + (f", hash {label}" if label else ""),
            "List it last in the cell's pose_files; the nominal joint frames stay where they are.",
        ],
    )
    return {"written": str(out), "device": dev.name, "hash": label, "joints": report}

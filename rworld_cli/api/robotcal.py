"""``rworld calibrate-robot``: the robot's own kinematic errors from instrument observations,
written as a pose-file overlay (joint frames, the measured frame, the instrument's frame)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import UserError

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
    bounds, in words: the joints' from the cell's, the target's and the frame's from their
    rigid fit with the robot nominal (the zero of ``result.p``: ``calibration.robot.identify``)."""
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
    """The calibrated numbers as a pose file (``schema.robotobs.robot_overlay_text``)."""
    from ..fileio import atomic_write_text
    from ..schema.robotobs import robot_overlay_text

    rms = float(np.sqrt(np.mean(np.sum(result.residuals**2, axis=1))))
    text = robot_overlay_text(
        result.device,
        obs.device,
        calibrated_frames(obs.target, obs.frame, model, result, world, T_link_target),
        "rworld calibrate-robot",
        digests,
        {
            "points": len(obs.q),
            "identified": f"{result.rank} of {len(result.p)} parameters",
            "observability_index": float(result.observability),
            "residual_rms_mm": rms * 1000,
        },
    )
    atomic_write_text(out, text)


def calibrated_frames(target: str, frame: str, model, result, world, T_link_target) -> dict:
    """The poses a robot calibration moves besides the joints, relative to each frame's parent
    (name -> (4, 4) [m]): the measured frame (its pose on the link moved by the estimate) and
    an estimated instrument frame (``F' = F R E``, R its registration)."""
    from ..calibration.robot import small_pose

    def T_world(name: str | None) -> np.ndarray:
        return world.T_world(name) if name not in (None, "world") else np.eye(4)

    _, moved, _ = model.apply(result.p)  # from the rigid fit's target, not the cell's
    if model.R_link_target is None:
        T_link_new = T_link_target.copy()
        T_link_new[:3, 3] = moved[:3, 3]
    else:
        T_link_new = moved
    T_world_link = world.T_world(target) @ np.linalg.inv(T_link_target)
    poses = {target: np.linalg.solve(T_world(world.parent(target)), T_world_link @ T_link_new)}
    if model.frame_estimated:
        n, m = result.device.dof, model.target_count
        E = small_pose(result.p[6 * n + m : 6 * n + m + 6])
        poses[frame] = np.linalg.solve(
            T_world(world.parent(frame)),
            world.T_world(frame) @ result.T_frame_registered @ E,
        )
    return poses

"""Calibrate a cell from measurement files; plan where to probe; simulate probing.

``calibrate``: fit every measured feature, solve the conditioned natural
frames (C1, C2), then the auxiliary frames (C3-C13) in their owners'
calibrated frames, parents before children; frames chained to a
calibrated frame follow it (their poses are relative).  The result is an
overlay of calibrated poses; nominal pose files are never rewritten.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import UserError
from ..model.cell import CellModel, Feature
from ..model.measurements import FeatureProbes, Measurement, MeasurementSet
from ..world.tree import World
from .fit import FeatureFit, FitError, fit_circle, fit_line, fit_plane, fit_point
from .solve import FrameSolution, apply_condition, solve_natural

# --------------------------------------------------------------------------- simulated probing


def simulate_measurements(
    nominal: CellModel,
    truth: CellModel,
    features: list[str],
    n_points: dict[str, int],
    sigma: float,
    seed: int,
) -> dict:
    """Probe points (SI, world) of ``features`` of the truth cell, with Gaussian noise ``sigma``
    [m]: a point probe at targets on material (``targets.py``), spread by farthest-point
    sampling, each the nominal target carried to the truth cell's pose of its owner.
    """
    from .targets import farthest_points, feature_candidates

    rng = np.random.default_rng(seed)
    world = World(truth)
    out = {}
    for name in features:
        f = nominal.features[name]
        cand = feature_candidates(nominal, f, 0.0, 1e-3)
        pick = farthest_points(cand.points, n_points.get(name, 8))
        if f.kind == "line":
            pick = pick[np.argsort(cand.points[pick] @ f.direction)]
        pts = cand.centres[pick]
        T = world.T_world(f.owner)
        pw = pts @ T[:3, :3].T + T[:3, 3] + rng.normal(0.0, sigma, pts.shape)
        above = None
        if f.kind in ("plane", "circle"):
            above = T[:3, :3] @ (pts.mean(axis=0) + 0.01 * f.direction) + T[:3, 3]
            if f.kind == "circle":
                above = T[:3, :3] @ (f.point + 0.01 * f.direction) + T[:3, 3]
        out[name] = FeatureProbes(
            pw, above, f.kind == "line", offset=cand.offset, boss=cand.boss, depth=cand.depth
        )
    return out


# --------------------------------------------------------------------------- calibrate


@dataclass
class CalibrationResult:
    """Solutions per conditioned frame, and the overlay of calibrated poses (relative to
    parents, SI).
    """

    cell: str
    solutions: dict[str, FrameSolution]
    fits: dict[str, FeatureFit]
    overlay: dict[str, np.ndarray]
    undetermined: dict[str, str]
    files: list[dict]
    warnings: list[str] = field(default_factory=list)


def _fit(feature: Feature, m: Measurement, T_owner: np.ndarray) -> FeatureFit:
    """The feature's fit from its probe points, the offset compensated in the owner's pose
    ``T_owner`` (nominal, or calibrated when known); ``points`` stay the raw ball centres (the
    maximum-likelihood solve compensates exactly, in the owner's frame)."""
    R = T_owner[:3, :3]
    side = R @ feature.direction if feature.direction is not None else None
    points = m.points
    if m.offset is not None:  # a line touched by a ball: its centres, moved onto the edge
        points = points - R @ m.offset
    if m.depth is not None:  # a circle probed on its wall: the points, moved up to the rim
        points = points + m.depth * (R @ feature.direction)
    if feature.kind == "plane":
        fit = fit_plane(feature.name, points, m.above, m.probe_radius, side)
    elif feature.kind == "line":
        fit = fit_line(feature.name, points, m.ordered)
    elif feature.kind == "circle":
        fit = fit_circle(feature.name, points, m.above, m.probe_radius, side, m.boss)
        fit.axis_only = m.depth is not None
    else:
        fit = fit_point(feature.name, points)
    fit.points = m.points
    return fit


MAX_CORRECTION = 0.05  # m: nominal poses further off than this are not a calibration's work
MAX_ROTATION = np.radians(10.0)  # rad: the same for turns
RESIDUAL_SIGMAS = 10.0  # residuals above this many of the instrument's sigma do not fit
UNIT_FACTORS = {"m read as mm": 1000.0, "mm read as m": 0.001}


def nominal_distances(cell: CellModel, measured: MeasurementSet) -> dict[str, float]:
    """Per measured feature, the median distance of its probe points from the nominal feature
    [m] (ball radius left in: it is small beside what this looks for)."""
    world = World(cell)
    out = {}
    for name, m in measured.measurements.items():
        f = cell.features[name]
        T = world.T_world(f.owner)
        p0 = T[:3, :3] @ f.point + T[:3, 3]
        v = m.points - p0
        d = T[:3, :3] @ f.direction if f.direction is not None else None
        if f.kind == "plane":
            dist = np.abs(v @ d)
        elif f.kind == "line":
            dist = np.linalg.norm(np.cross(v, d), axis=1)
        elif f.kind == "circle":
            axial = v @ d
            radial = np.linalg.norm(v - axial[:, None] * d, axis=1)
            dist = np.hypot(axial, radial - (f.radius or 0.0))
        else:
            dist = np.linalg.norm(v, axis=1)
        out[name] = float(np.median(dist))
    return out


def _unit_hint(cell: CellModel, measured: MeasurementSet, max_correction: float) -> str:
    """What the points look like when read in the other unit, if that makes them fit."""
    for what, k in UNIT_FACTORS.items():
        scaled = MeasurementSet(
            {
                n: replace(
                    m,
                    points=m.points * k,
                    above=None if m.above is None else m.above * k,
                    probe_radius=m.probe_radius * k,
                    offset=None if m.offset is None else m.offset * k,
                    depth=None if m.depth is None else m.depth * k,
                )
                for n, m in measured.measurements.items()
            },
            measured.files,
            measured.sigma,
        )
        far = float(np.median(list(nominal_distances(cell, scaled).values())))
        if far <= max_correction:
            return (
                f" Scaled by {k:g} they lie {1000 * far:.2f} mm from them: the points are most "
                f"likely in the other unit ({what}); check the unit the file states (units:, a "
                "CSV header's x_mm, --csv-units)."
            )
    return (
        " Check the unit the file states (units:, a CSV header's x_mm, --csv-units) - a unit "
        "read wrongly is the usual cause - and that the points belong to this cell."
    )


def _implausible_before(cell: CellModel, measured: MeasurementSet, max_correction: float) -> None:
    far = nominal_distances(cell, measured)
    median = float(np.median(list(far.values()))) if far else 0.0
    if median > max_correction:
        worst = sorted(far.items(), key=lambda kv: -kv[1])[:3]
        raise UserError(
            "implausible measurements, nothing written: the probe points lie a median "
            f"{1000 * median:.1f} mm from their nominal features ("
            + ", ".join(f"{n} {1000 * d:.1f} mm" for n, d in worst)
            + f"), more than --max-correction {1000 * max_correction:g} mm."
            + _unit_hint(cell, measured, max_correction)
        )


def _implausible_after(
    cell: CellModel,
    measured: MeasurementSet,
    solutions: dict[str, FrameSolution],
    max_correction: float,
) -> None:
    problems = []
    for name, sol in solutions.items():
        if not sol.determined:
            continue
        move, turn = sol.correction
        if move > max_correction:
            problems.append(
                f"{name} moves by {1000 * move:.2f} mm (more than --max-correction "
                f"{1000 * max_correction:g} mm)"
            )
        elif turn > MAX_ROTATION:
            problems.append(
                f"{name} turns by {np.degrees(turn):.1f} deg (more than "
                f"{np.degrees(MAX_ROTATION):g} deg)"
            )
        if measured.sigma and sol.residual_rms > RESIDUAL_SIGMAS * measured.sigma:
            problems.append(
                f"{name}'s probe points miss its features by {1000 * sol.residual_rms:.3f} mm "
                f"RMS, {sol.residual_rms / measured.sigma:.0f} times the instrument's sigma "
                f"{1000 * measured.sigma:g} mm"
            )
    if problems:
        raise UserError(
            "implausible calibration, nothing written: "
            + "; ".join(problems)
            + "."
            + _unit_hint(cell, measured, max_correction)
        )


def calibrate(
    cell: CellModel,
    measured: MeasurementSet,
    frames: list[str] | None = None,
    max_correction: float = MAX_CORRECTION,
) -> CalibrationResult:
    """Calibrate the conditioned frames of ``cell`` from the measurements.

    Parameters
    ----------
    max_correction : float
        The largest plausible correction of a frame [m]; points farther from their nominal
        features, or a larger correction, are refused (units read wrongly, a wrong cell).

    Raises
    ------
    UserError
        A measured feature's points cannot define it (collinear plane points, ...), with the
        figure; implausible measurements or corrections, naming units as the likely cause.
    """
    world = World(cell)
    conditions = {c.frame: c for c in cell.conditions}
    wanted = list(conditions) if frames is None else frames
    for name in wanted:
        if name not in conditions:
            from ..errors import did_you_mean

            raise UserError(
                f"'{name}' has no frame condition in the cell{did_you_mean(name, conditions)}; "
                f"conditioned frames: {', '.join(conditions)}"
            )
    fits: dict[str, FeatureFit] = {}
    problems = []
    for name, m in measured.measurements.items():
        f = cell.features[name]
        try:
            fits[name] = _fit(f, m, world.T_world(f.owner))
        except FitError as exc:
            problems.append(f"{name} ({m.source}): {exc}")
    if problems:
        raise UserError("measured points do not define their features:\n  " + "\n  ".join(problems))
    _implausible_before(cell, measured, max_correction)
    solutions: dict[str, FrameSolution] = {}
    undetermined: dict[str, str] = {}
    # natural frames first, then auxiliary frames parents-first (a frame's parent may be conditioned
    # too)
    order = sorted(
        conditions.values(),
        key=lambda c: (c.code not in ("C1", "C2"), len(world.subtree(c.frame)) * -1),
    )
    probing = {n: m.probing for n, m in measured.measurements.items()}
    for c in order:
        missing = [f for f in c.features if f not in fits]
        ways_out = (
            f"measure {', '.join(missing)}, or leave {c.frame} out (--frames), or drop "
            f"{'it' if len(missing) == 1 else 'them'} from {c.frame}'s condition in the cell"
        )
        if missing and (c.code not in ("C1", "C2") or len(missing) == len(c.features)):
            undetermined[c.frame] = f"not measured: {', '.join(missing)}: {ways_out}"
            continue
        T_nom = world.T_world(c.frame)
        if c.code in ("C1", "C2"):
            # the measured features alone, when they determine the frame (said in a warning)
            present = [f for f in c.features if f in fits]
            feats = [cell.features[f] for f in present]
            own = {f: fits[f] for f in present}
            offsets = [
                f
                for f in feats
                if measured.measurements[f.name].offset is not None
                or measured.measurements[f.name].depth is not None
            ]
            # a probing offset is compensated in the owner's pose: the nominal one first, then
            # the solution's, so the closed form converges to the exact one too
            for _ in range(3 if offsets else 1):
                sol = solve_natural(c.frame, c.code, feats, own, probing, T_nom, measured.sigma)
                if not sol.determined:
                    break
                for f in offsets:
                    T_owner = sol.T_world @ world.T(c.frame, f.owner)
                    own[f.name] = _fit(f, measured.measurements[f.name], T_owner)
                    fits[f.name] = own[f.name]
            if not sol.determined:
                undetermined[c.frame] = (
                    f"{sol.reason}; not measured: {', '.join(missing)}: {ways_out}"
                    if missing
                    else sol.reason
                )
                solutions[c.frame] = sol
                continue
            if missing:
                sol.warnings.append(
                    f"solved from the measured features {', '.join(present)}, which determine "
                    f"it; not measured: {', '.join(missing)}"
                )
            world.place(c.frame, sol.T_world)
            solutions[c.frame] = sol
        else:
            f = cell.features[c.features[0]]
            owner = f.owner
            T_owner = world.T_world(owner)  # calibrated when the owner's natural frame was
            fit = _fit(f, measured.measurements[f.name], T_owner)  # offsets in that pose
            Ti = np.linalg.inv(T_owner)
            p = Ti[:3, :3] @ fit.point + Ti[:3, 3]
            d = Ti[:3, :3] @ fit.direction if fit.direction is not None else None
            T_owner_frame = world.T(owner, c.frame)
            T_new_owner = apply_condition(c.code, T_owner_frame, f.kind, p, d)
            T_new = T_owner @ T_new_owner
            sol = FrameSolution(
                c.frame,
                c.code,
                True,
                T_new,
                T_nom,
                residual_rms=fit.rms,
                warnings=list(fit.warnings),
            )
            if owner not in solutions:
                sol.warnings.append(
                    f"the owner '{owner}' is not calibrated: the condition is applied in its "
                    "nominal frame"
                )
            world.place(c.frame, T_new)
            solutions[c.frame] = sol
    overlay = {}
    for name, sol in solutions.items():
        if sol.determined:
            overlay[name] = world.T_parent(name)
    for name in wanted:
        if name not in solutions and name not in undetermined:
            undetermined[name] = "not solved"
    _implausible_after(
        cell, measured, {n: s for n, s in solutions.items() if n in wanted}, max_correction
    )
    return CalibrationResult(
        cell.name,
        solutions,
        fits,
        overlay,
        {k: v for k, v in undetermined.items() if k in wanted},
        measured.files,
    )

"""Calibrate a cell from measurement files; plan where to probe; simulate probing.

``calibrate``: fit every measured feature, solve the conditioned natural
frames (C1, C2), then the auxiliary frames (C3-C13) in their owners'
calibrated frames, parents before children; frames chained to a
calibrated frame follow it (their poses are relative).  The result is an
overlay of calibrated poses; nominal pose files are never rewritten.
"""

from __future__ import annotations

from dataclasses import dataclass, field

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


def calibrate(
    cell: CellModel, measured: MeasurementSet, frames: list[str] | None = None
) -> CalibrationResult:
    """Calibrate the conditioned frames of ``cell`` from the measurements.

    Raises
    ------
    UserError
        A measured feature's points cannot define it (collinear plane points, ...), with the figure.
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
        if missing:
            undetermined[c.frame] = f"not measured: {', '.join(missing)}"
            continue
        T_nom = world.T_world(c.frame)
        if c.code in ("C1", "C2"):
            feats = [cell.features[f] for f in c.features]
            own = {f: fits[f] for f in c.features}
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
                undetermined[c.frame] = sol.reason
                solutions[c.frame] = sol
                continue
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
    return CalibrationResult(
        cell.name,
        solutions,
        fits,
        overlay,
        {k: v for k, v in undetermined.items() if k in wanted},
        measured.files,
    )

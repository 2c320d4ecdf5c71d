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

# --------------------------------------------------------------------------- where to probe


def feature_extent(cell: CellModel, feature: Feature):
    """The owner's bounding box (a :class:`~rworld_cli.model.cell.Box`) or None."""
    shape = None
    if feature.owner in cell.objects:
        shape = cell.objects[feature.owner].shape
    elif feature.owner in cell.devices:
        shape = cell.devices[feature.owner].shape
    return shape.bounding_box if shape is not None else None


def _inside(points, box, margin=1e-9):
    if box is None:
        return np.ones(len(points), dtype=bool)
    T = box.T_owner_box
    local = (points - T[:3, 3]) @ T[:3, :3]
    return np.all(np.abs(local) <= box.half_extents + margin, axis=1)


def probe_points(cell: CellModel, feature: Feature, n: int, inset: float = 0.15):
    """Where to probe a feature, in its owner's frame: spread over the face it lies on.

    Returns
    -------
    points : ndarray, shape (n, 3)
    above : ndarray, shape (3,) or None
        For planes and circles: a point 10 mm outside, for orientation.
    ordered : bool
        Lines are probed first -> last along their direction.
    """
    box = feature_extent(cell, feature)
    default = 0.05
    if feature.kind == "point":
        return np.repeat(feature.point[None], n, axis=0), None, False
    if feature.kind == "circle":
        nrm = feature.direction
        u = np.cross(nrm, [1.0, 0, 0] if abs(nrm[0]) < 0.9 else [0, 1.0, 0])
        u /= np.linalg.norm(u)
        v = np.cross(nrm, u)
        ang = np.linspace(0, 2 * np.pi, n, endpoint=False)
        pts = feature.point + feature.radius * (np.cos(ang)[:, None] * u + np.sin(ang)[:, None] * v)
        return pts, feature.point + 0.01 * nrm, False
    if feature.kind == "line":
        d = feature.direction
        if box is not None:
            s = (box.corners() - feature.point) @ d
            lo, hi = s.min(), s.max()
        else:
            lo, hi = -default, default
        span = hi - lo
        s = np.linspace(lo + inset * span, hi - inset * span, n)
        return feature.point + s[:, None] * d, None, True
    nrm = feature.direction  # plane: a grid over the face within the owner's box
    u = np.cross(nrm, [1.0, 0, 0] if abs(nrm[0]) < 0.9 else [0, 1.0, 0])
    u /= np.linalg.norm(u)
    v = np.cross(nrm, u)
    if box is not None:
        corners = box.corners()
        cu, cv = (corners - feature.point) @ u, (corners - feature.point) @ v
        (u0, u1), (v0, v1) = (cu.min(), cu.max()), (cv.min(), cv.max())
    else:
        u0 = v0 = -default
        u1 = v1 = default
    k = max(2, int(np.ceil(np.sqrt(n))))
    for _ in range(6):  # shrink until enough grid points lie on the face
        gu = np.linspace(u0 + inset * (u1 - u0), u1 - inset * (u1 - u0), k)
        gv = np.linspace(v0 + inset * (v1 - v0), v1 - inset * (v1 - v0), k)
        grid = feature.point + gu[:, None, None] * u + gv[None, :, None] * v
        grid = grid.reshape(-1, 3)
        on_face = grid[_inside(grid, box)]
        if len(on_face) >= n:
            pick = np.round(np.linspace(0, len(on_face) - 1, n)).astype(int)
            centre = on_face.mean(axis=0)
            return on_face[pick], centre + 0.01 * nrm, False
        k += 1
    raise UserError(
        f"feature '{feature.name}' does not meet its owner's geometry: cannot place probe points "
        "on it"
    )


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
    [m].
    """
    rng = np.random.default_rng(seed)
    world = World(truth)
    out = {}
    for name in features:
        f = nominal.features[name]
        pts, above, ordered = probe_points(nominal, f, n_points.get(name, 8))
        T = world.T_world(f.owner)
        pw = pts @ T[:3, :3].T + T[:3, 3] + rng.normal(0.0, sigma, pts.shape)
        out[name] = FeatureProbes(
            pw, T[:3, :3] @ above + T[:3, 3] if above is not None else None, bool(ordered)
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


def _fit(feature: Feature, m: Measurement, T_nominal_owner: np.ndarray) -> FeatureFit:
    side = T_nominal_owner[:3, :3] @ feature.direction if feature.direction is not None else None
    if feature.kind == "plane":
        return fit_plane(feature.name, m.points, m.above, m.probe_radius, side)
    if feature.kind == "line":
        return fit_line(feature.name, m.points, m.ordered)
    if feature.kind == "circle":
        return fit_circle(feature.name, m.points, m.above, m.probe_radius, side)
    return fit_point(feature.name, m.points)


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
    radii = {n: m.probe_radius for n, m in measured.measurements.items()}
    for c in order:
        missing = [f for f in c.features if f not in fits]
        if missing:
            undetermined[c.frame] = f"not measured: {', '.join(missing)}"
            continue
        T_nom = world.T_world(c.frame)
        if c.code in ("C1", "C2"):
            feats = [cell.features[f] for f in c.features]
            sol = solve_natural(
                c.frame,
                c.code,
                feats,
                {f: fits[f] for f in c.features},
                radii,
                T_nom,
                measured.sigma,
            )
            if not sol.determined:
                undetermined[c.frame] = sol.reason
                solutions[c.frame] = sol
                continue
            world.place(c.frame, sol.T_world)
            solutions[c.frame] = sol
        else:
            f = cell.features[c.features[0]]
            fit = fits[f.name]
            owner = f.owner
            T_owner = world.T_world(owner)  # calibrated when the owner's natural frame was
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

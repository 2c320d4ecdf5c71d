"""Measuring directives: which features to probe, how many points, where, in what order.

Step 4 of the calibration report's procedure, automated.  For each
conditioned frame the points are spread over each feature's face (using the
owner's geometry); their number is the smallest of a ladder for which the
predicted pose error (the Cramer-Rao bound at the nominal pose: probe noise
``sigma`` through the maximum-likelihood Jacobian) is within the tolerance
at two standard deviations.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..model.cell import CellModel
from ..units import MIN_POINTS as MINIMUM
from ..world.tree import World
from .fit import fit_circle, fit_line, fit_plane, fit_point
from .pipeline import probe_points
from .solve import REFUSE_CONDITION, _jacobian

LADDER = [3, 4, 6, 8, 10, 15, 20, 30, 50]


@dataclass
class Directive:
    feature: str
    kind: str
    points: np.ndarray  # (n, 3) world, nominal
    above: np.ndarray | None  # a point outside, probed last (planes, circles)
    ordered: bool  # lines: probe first -> last as listed

    @property
    def how(self) -> str:
        if self.kind == "plane":
            return (
                f"{len(self.points)} points spread over the face, then 1 point above it "
                "(outside the object)"
            )
        if self.kind == "line":
            return (
                f"{len(self.points)} points along the edge, in the listed order (first -> last "
                "gives the direction)"
            )
        if self.kind == "circle":
            return f"{len(self.points)} points round the rim, then 1 point above its plane"
        return f"{len(self.points)} probe(s) of the point"


@dataclass
class FramePlan:
    frame: str
    code: str
    directives: list[Directive]
    determined: bool
    sigma_translation: float  # [m], norm of the per-axis standard errors
    sigma_rotation: float  # [rad]
    condition: float = 1.0
    reason: str = ""
    warnings: list[str] = field(default_factory=list)


def _fits(cell: CellModel, world: World, names: list[str], n: int):
    fits, directives = {}, []
    for name in names:
        f = cell.features[name]
        count = max(n, MINIMUM[f.kind])
        pts, above, ordered = probe_points(cell, f, count)
        T = world.T_world(f.owner)
        pw = pts @ T[:3, :3].T + T[:3, 3]
        aw = T[:3, :3] @ above + T[:3, 3] if above is not None else None
        if f.kind == "plane":
            fit = fit_plane(name, pw, aw)
        elif f.kind == "line":
            fit = fit_line(name, pw, ordered)
        elif f.kind == "circle":
            fit = fit_circle(name, pw, aw)
        else:
            fit = fit_point(name, pw)
        fits[name] = fit
        directives.append(Directive(name, f.kind, pw, aw, ordered))
    return fits, directives


def plan_measurements(
    cell: CellModel, frames: list[str] | None = None, sigma: float = 5e-5, tolerance: float = 1e-4
) -> list[FramePlan]:
    """Directives per conditioned frame (all by default), with predicted errors."""
    world = World(cell)
    plans = []
    for c in cell.conditions:
        if frames is not None and c.frame not in frames:
            continue
        if c.code not in ("C1", "C2"):
            f = cell.features[c.features[0]]
            n = (
                next(
                    k
                    for k in LADDER
                    if k >= MINIMUM[f.kind] and sigma / np.sqrt(k) * 2 <= tolerance
                )
                if sigma * 2 / np.sqrt(50) <= tolerance
                else 50
            )
            _, directives = _fits(cell, world, list(c.features), n)
            plans.append(FramePlan(c.frame, c.code, directives, True, sigma / np.sqrt(n), 0.0))
            continue
        feats = [cell.features[f] for f in c.features]
        T = world.T_world(c.frame)
        chosen = None
        for n in LADDER:
            fits, directives = _fits(cell, world, list(c.features), n)
            J = _jacobian(feats, fits, {}, T)
            pts = np.concatenate([fit.points for fit in fits.values()])
            scale = max(float(np.sqrt(((pts - pts.mean(axis=0)) ** 2).sum(axis=1).mean())), 1e-6)
            Jn = J.copy()
            Jn[:, :3] /= scale
            s = np.linalg.svd(Jn, compute_uv=False)
            condition = float(s[0] / s[-1]) if len(J) >= 6 and s[-1] > 0 else np.inf
            if condition > REFUSE_CONDITION:
                chosen = FramePlan(
                    c.frame,
                    c.code,
                    directives,
                    False,
                    np.inf,
                    np.inf,
                    condition,
                    "the conditions cannot determine this frame (condition number "
                    f"{condition:.3g}): add features",
                )
                break
            cov = sigma**2 * np.linalg.inv(J.T @ J)
            sig_t = float(np.sqrt(np.trace(cov[3:, 3:])))
            sig_r = float(np.sqrt(np.trace(cov[:3, :3])))
            chosen = FramePlan(c.frame, c.code, directives, True, sig_t, sig_r, condition)
            if 2 * np.sqrt(np.max(np.diag(cov[3:, 3:]))) <= tolerance:
                break
        else:
            chosen.warnings.append(
                f"even {LADDER[-1]} points per feature leave a predicted error above the tolerance"
            )
        plans.append(chosen)
    # a feature serving several frames is probed once, with the most points any of them needs
    most: dict[str, int] = {}
    for plan in plans:
        for d in plan.directives:
            most[d.feature] = max(most.get(d.feature, 0), len(d.points))
    for plan in plans:
        if any(len(d.points) < most[d.feature] for d in plan.directives):
            plan.directives = [
                _fits(cell, world, [d.feature], most[d.feature])[1][0] for d in plan.directives
            ]
            if plan.code not in ("C1", "C2"):
                plan.sigma_translation = sigma / np.sqrt(most[plan.directives[0].feature])
    return plans

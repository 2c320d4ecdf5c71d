"""Measuring directives: which features to probe, how many points, where, in what order.

Step 4 of the calibration report's procedure, automated.  For each
conditioned frame:

1. **Targets on material** (``targets.py``): candidate contacts on each
   feature's actual face, hole wall or edge, ``margin`` from edges and holes,
   with the ball centre at contact for the probe's radius.
2. **Chosen for information**: natural frames (C1, C2) take their points by
   greedy D-optimal selection - each point the candidate that most increases
   the determinant of the information matrix ``J^T J`` of the frame's pose,
   ``J`` the maximum-likelihood Jacobian of ``solve.py``; auxiliary frames
   (C3-C13, one feature) spread theirs by farthest-point sampling.
3. **How many**: the smallest count of a ladder for which the predicted
   pose error (the Cramer-Rao bound sigma^2 (J^T J)^-1 at the nominal pose)
   is within the tolerance at two standard deviations.
4. **Reachable** (optional, ``feasible``): a point the robot cannot probe is
   dropped and the next best taken; see ``probing.py``.

The same number of points spread uniformly (farthest-point sampling over the
candidates) gives the comparison figure ``uniform_sigma_*``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import SimpleNamespace

import numpy as np

from ..model.cell import CellModel
from ..model.measurements import Probing
from ..units import MIN_POINTS as MINIMUM
from ..world.tree import World
from .solve import REFUSE_CONDITION, _jacobian, residual_widths
from .targets import Candidates, d_optimal, farthest_points, feature_candidates

LADDER = [3, 4, 6, 8, 10, 15, 20, 30, 50]
MAX_REFUSED = 30  # a feature whose first this many targets are all refused is given up
SUBSAMPLE = 120  # candidates kept per feature, spread by farthest-point sampling
ABOVE = 0.01  # [m]: the 'above' point of planes and circles, this far out along the normal


@dataclass
class Directive:
    """Where to probe one feature (world, nominal, SI).

    ``points`` are the ball centres at contact (what a measurement file holds); ``contacts``
    the surface points they touch, ``normals`` the outward surface normals there (the ball
    comes in along ``-normals``).  ``index`` picks the candidates of ``candidates``.
    """

    feature: str
    kind: str
    points: np.ndarray  # (n, 3)
    contacts: np.ndarray  # (n, 3)
    normals: np.ndarray  # (n, 3)
    above: np.ndarray | None  # a point outside (planes, circles)
    ordered: bool  # lines: probe first -> last as listed
    index: np.ndarray
    candidates: Candidates
    probe_radius: float

    @property
    def offset(self) -> np.ndarray | None:
        return self.candidates.offset

    @property
    def probing(self) -> Probing:
        return _probing(self.candidates, self.probe_radius)

    @property
    def how(self) -> str:
        n = len(self.points)
        if self.kind == "plane":
            return f"{n} points on the face, then 1 point above it (outside the object)"
        if self.kind == "line":
            return (
                f"{n} points on the edge, the ball coming in between its two faces, in the listed "
                "order (first -> last gives the direction)"
            )
        if self.kind == "circle":
            what = "boss" if self.candidates.boss else "hole"
            return (
                f"{n} points round the {what}'s wall {self.candidates.depth * 1000:.3g} mm below "
                "the rim, then 1 point above its plane"
            )
        return f"{n} probe(s) of the point"


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
    uniform_sigma_translation: float = np.nan  # the same counts spread uniformly [m]
    uniform_sigma_rotation: float = np.nan  # [rad]
    dropped: list[str] = field(default_factory=list)  # unreachable candidates, with reasons
    rows: dict[str, np.ndarray] | None = field(default=None, repr=False)  # C1/C2: per feature


@dataclass
class ProbeGeometry:
    """The probe the plan is for: ball radius and margin [m], probing depth per circle [m]."""

    radius: float = 0.0
    margin: float | None = None  # default radius + 1 mm
    depths: dict[str, float] = field(default_factory=dict)
    default_depth: float | None = None

    @property
    def edge_margin(self) -> float:
        return self.radius + 1e-3 if self.margin is None else self.margin


def _probing(c: Candidates, radius: float) -> Probing:
    """How the candidates of a feature are probed (for the Jacobian and the template)."""
    return Probing(radius if c.feature.kind != "point" else 0.0, c.offset, c.boss, c.depth)


def _rows(cand: Candidates, T_world_owner: np.ndarray, T_frame: np.ndarray, probing) -> np.ndarray:
    """Each candidate's residual rows (M, r, 6) for the frame pose (rotation vector, translation
    in world axes), at the nominal pose."""
    f = cand.feature
    centres = cand.centres @ T_world_owner[:3, :3].T + T_world_owner[:3, 3]
    fake = {f.name: SimpleNamespace(points=centres, n_points=len(centres))}
    J = _jacobian([f], fake, {f.name: probing}, T_frame)
    M = len(centres)
    if f.kind == "plane":
        return J.reshape(M, 1, 6)
    width = residual_widths([f], {f.name: probing})[f.name]
    if f.kind == "circle" and width == 2:  # axial rows first, then radial
        return np.stack([J[:M], J[M:]], axis=1)
    return J.reshape(M, width, 6)


def _stack(rows: list[np.ndarray]) -> np.ndarray:
    return np.concatenate([r.reshape(-1, 6) for r in rows])


def _covariance(rows: list[np.ndarray], sigma: float) -> np.ndarray:
    """sigma^2 (J^T J)^-1 of the pose (rotation vector, translation); inf when singular."""
    J = _stack(rows)
    try:
        return sigma**2 * np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError:
        return np.full((6, 6), np.inf)


def _condition(J: np.ndarray, points: np.ndarray) -> float:
    scale = max(float(np.sqrt(((points - points.mean(axis=0)) ** 2).sum(axis=1).mean())), 1e-6)
    Jn = J.copy()
    Jn[:, :3] /= scale
    s = np.linalg.svd(Jn, compute_uv=False)
    return float(s[0] / s[-1]) if len(J) >= 6 and s[-1] > 0 else np.inf


def plan_measurements(
    cell: CellModel,
    frames: list[str] | None = None,
    sigma: float = 5e-5,
    tolerance: float = 1e-4,
    probe: ProbeGeometry | None = None,
    feasible=None,
) -> list[FramePlan]:
    """Directives per conditioned frame (all by default), with predicted errors.

    Parameters
    ----------
    sigma : float
        Probing noise, 1 sigma [m].
    tolerance : float
        Wanted pose accuracy at 2 sigma [m].
    probe : ProbeGeometry, optional
        Ball radius, margin and depths (default: a point probe, 1 mm margin).
    feasible : callable(feature name, centre_world (3,), normal_world (3,)) -> str or None
        Why the robot cannot probe there (None: it can); default every target is feasible.

    Raises
    ------
    UserError
        A feature has no material to probe, or the probe does not fit (the figure named).
    """
    probe = probe or ProbeGeometry()
    world = World(cell)
    cands: dict[str, Candidates] = {}
    verdicts: dict[tuple[str, int], str | None] = {}
    dropped: dict[str, list[str]] = {}

    def candidates(name: str) -> Candidates:
        if name not in cands:
            f = cell.features[name]
            cands[name] = feature_candidates(
                cell,
                f,
                probe.radius,
                probe.edge_margin,
                probe.depths.get(name, probe.default_depth),
            )
            c = cands[name]
            if len(c) > SUBSAMPLE:  # spread evenly: neighbours of a refused target stay apart
                keep = np.sort(farthest_points(c.points, SUBSAMPLE))
                cands[name] = Candidates(
                    c.feature,
                    c.points[keep],
                    c.normals[keep],
                    c.centres[keep],
                    c.offset,
                    c.boss,
                    c.depth,
                    c.wall_depth,
                )
        return cands[name]

    def ok(name: str, k: int) -> bool:
        if feasible is None:
            return True
        refused = dropped.get(name, [])
        if (
            (name, k) not in verdicts
            and len(refused) >= MAX_REFUSED
            and len(refused) == sum(1 for key in verdicts if key[0] == name)
        ):  # nothing on this feature has worked yet: stop trying, the reasons are listed
            return False
        if (name, k) not in verdicts:
            c = candidates(name)
            T = world.T_world(c.feature.owner)
            why = feasible(c, k, T)
            verdicts[name, k] = why
            if why is not None:
                dropped.setdefault(name, []).append(why)
        return verdicts[name, k] is None

    def directive(name: str, index) -> Directive:
        c = candidates(name)
        f = c.feature
        index = np.asarray(index, dtype=int)
        if f.kind == "line":  # probed first -> last along the direction
            index = index[np.argsort(c.points[index] @ f.direction)]
        T = world.T_world(f.owner)
        R, t = T[:3, :3], T[:3, 3]
        contacts = c.points[index] @ R.T + t
        above = None
        if f.kind == "plane" and len(contacts):
            above = contacts.mean(axis=0) + ABOVE * (R @ f.direction)
        elif f.kind == "circle":
            above = R @ f.point + t + ABOVE * (R @ f.direction)
        return Directive(
            name,
            f.kind,
            c.centres[index] @ R.T + t,
            contacts,
            c.normals[index] @ R.T,
            above,
            f.kind == "line",
            index,
            c,
            probe.radius,
        )

    def uniform(name: str, n: int) -> np.ndarray:
        c = candidates(name)
        return farthest_points(c.points, n)

    plans: list[FramePlan] = []
    for cond in cell.conditions:
        if frames is not None and cond.frame not in frames:
            continue
        names = list(cond.features)
        if cond.code not in ("C1", "C2"):
            f = cell.features[names[0]]
            n = next(
                (k for k in LADDER if k >= MINIMUM[f.kind] and 2 * sigma / np.sqrt(k) <= tolerance),
                LADDER[-1],
            )
            c = candidates(f.name)
            order = farthest_points(c.points, len(c))  # spread first, every candidate ranked
            chosen = [int(k) for k in order if ok(f.name, int(k))][:n]
            plan = FramePlan(cond.frame, cond.code, [directive(f.name, chosen)], True, 0.0, 0.0)
            plan.sigma_translation = sigma / np.sqrt(max(len(chosen), 1))
            if len(chosen) < MINIMUM[f.kind]:
                plan.determined = False
                plan.reason = (
                    f"only {len(chosen)} reachable point(s) on {f.name}, a {f.kind} needs "
                    f"{MINIMUM[f.kind]}"
                )
            plans.append(plan)
            continue
        T_frame = world.T_world(cond.frame)
        rows, positions = [], []
        for name in names:
            c = candidates(name)
            T_owner = world.T_world(c.feature.owner)
            probing = _probing(c, probe.radius)
            rows.append(_rows(c, T_owner, T_frame, probing))
            positions.append(c.points)
        plan = None
        for n in LADDER:
            counts = [max(n, MINIMUM[cell.features[name].kind]) for name in names]
            spacing = []
            for name, count in zip(names, counts):
                pts = candidates(name).points
                spread = pts[uniform(name, count)]
                gaps = np.linalg.norm(spread[:, None] - spread[None], axis=2)
                gaps[np.diag_indices(len(spread))] = np.inf
                spacing.append(0.5 * float(gaps.min()) if len(spread) > 1 else 0.0)
            seeds = [
                list(uniform(name, 12)) if cell.features[name].kind == "plane" else []
                for name in names
            ]  # a plane's own fit needs 3 points spread in two directions
            chosen = d_optimal(
                rows, counts, spacing, positions, lambda f, k: ok(names[f], k), seeds
            )
            short = [
                f"{name} ({len(ch)} reachable, a {cell.features[name].kind} needs "
                f"{MINIMUM[cell.features[name].kind]})"
                for name, ch in zip(names, chosen)
                if len(ch) < MINIMUM[cell.features[name].kind]
            ]
            directives = [directive(name, ch) for name, ch in zip(names, chosen)]
            if short:
                plan = _undetermined(
                    cond, directives, np.inf, "too few reachable targets: " + ", ".join(short)
                )
                break
            picked = [r[ch] for r, ch in zip(rows, chosen)]
            J = _stack(picked)
            points = np.concatenate([d.points for d in directives])
            condition = _condition(J, points)
            if condition > REFUSE_CONDITION:
                plan = _undetermined(
                    cond,
                    directives,
                    condition,
                    f"the conditions cannot determine this frame (condition number "
                    f"{condition:.3g}): add features",
                )
                break
            cov = _covariance(picked, sigma)
            plan = FramePlan(
                cond.frame,
                cond.code,
                directives,
                True,
                float(np.sqrt(np.trace(cov[3:, 3:]))),
                float(np.sqrt(np.trace(cov[:3, :3]))),
                condition,
            )
            cov_u = _covariance(
                [r[uniform(name, len(ch))] for r, name, ch in zip(rows, names, chosen)], sigma
            )
            plan.uniform_sigma_translation = float(np.sqrt(np.trace(cov_u[3:, 3:])))
            plan.uniform_sigma_rotation = float(np.sqrt(np.trace(cov_u[:3, :3])))
            if 2 * np.sqrt(np.max(np.diag(cov[3:, 3:]))) <= tolerance:
                break
        else:
            plan.warnings.append(
                f"even {LADDER[-1]} points per feature leave a predicted error above the tolerance"
            )
        plan.rows = dict(zip(names, rows))
        plans.append(plan)
    _share_features(plans, directive, sigma)
    for plan in plans:
        plan.dropped = [why for d in plan.directives for why in dropped.get(d.feature, [])]
    return plans


def _undetermined(cond, directives: list[Directive], condition: float, reason: str) -> FramePlan:
    return FramePlan(cond.frame, cond.code, directives, False, np.inf, np.inf, condition, reason)


def _share_features(plans: list[FramePlan], directive, sigma: float) -> None:
    """A feature serving several frames is probed once, with the most points any of them
    chose; each frame's predicted error is recomputed for the points it then gets."""
    best: dict[str, Directive] = {}
    for plan in plans:
        for d in plan.directives:
            if d.feature not in best or len(d.points) > len(best[d.feature].points):
                best[d.feature] = d
    for plan in plans:
        plan.directives = [best[d.feature] for d in plan.directives]
        rows = plan.rows
        if rows is None:
            n = len(plan.directives[0].points)
            if plan.determined:
                plan.sigma_translation = sigma / np.sqrt(max(n, 1))
        elif plan.determined:
            cov = _covariance([rows[d.feature][d.index] for d in plan.directives], sigma)
            plan.sigma_translation = float(np.sqrt(np.trace(cov[3:, 3:])))
            plan.sigma_rotation = float(np.sqrt(np.trace(cov[:3, :3])))

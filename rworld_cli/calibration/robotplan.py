"""Pose selection for robot calibration (``rworld plan-robot-calibration``): which joint states
to measure so that the identification is best determined.

Each candidate contributes rows of the scaled identification Jacobian (the error model of
:mod:`.robot`): three for a tracker's point, one for a touch of the robot's ball probe on a
known surface (the gap's gradient, the surface normal times the point's rows).  Projected on the
combinations the candidates can identify at all, they are the candidate's information ``G``.
Poses are added one at a time: D-optimal until the information matrix ``M`` is whole
(``log det(I + G M^-1 G^T)``, an m x m determinant per candidate), then the pose that lowers the
predicted error at the validation poses most (I-optimal: the trace drop
``tr((I + G M^-1 G^T)^-1 G M^-1 S M^-1 G^T)`` by Woodbury), and exchanges.  The predicted error
of the calibrated model at a pose is ``sigma^2 G_v M^-1 G_v^T`` (the point's rows).

What any choice of N poses can reach is bounded by the optimal *approximate* design: weights
over all candidates minimising ``tr(S M(w)^-1)``, approached by the multiplicative algorithm
(Silvey, Titterington and Torsney 1978), with a certified lower bound from convexity.  N poses
cannot predict less than ``sigma sqrt(phi* / N)``; the planner prints it so that the choice can
be judged against the best possible, not only against random poses.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # the model is built by the caller; importing it here would load kinematics
    from .robot import RobotModel


def _predicted(G_set: np.ndarray, G_check: np.ndarray, sigma: float) -> float:
    M = np.einsum("kai,kaj->ij", G_set, G_set)
    try:
        cov = sigma**2 * np.linalg.inv(M)
    except np.linalg.LinAlgError:
        return float("inf")
    per = np.einsum("kai,ij,kaj->k", G_check, cov, G_check)
    return float(np.sqrt(np.mean(per)))


@dataclass
class Information:
    """Candidates' information on the identifiable combinations.

    Attributes
    ----------
    G : ndarray, shape (M, m, r)
        Each candidate's scaled rows (m = 3 for a point, 1 for a touch), projected on the ``r``
        combinations the candidates identify.
    G_check : ndarray, shape (K, 3, r)
        The measured point's rows at the validation poses: where the predicted error is taken.
    """

    G: np.ndarray
    G_check: np.ndarray

    @property
    def rank(self) -> int:
        return self.G.shape[2]


def information(
    model: RobotModel,
    candidates: np.ndarray,
    check: np.ndarray,
    normals: np.ndarray | None = None,
) -> Information:
    """The candidates' rows on the combinations they identify.

    Parameters
    ----------
    model : RobotModel
        The error model (nominal: all parameters 0).
    candidates : ndarray, shape (M, n)
        Joint states [rad or m].
    check : ndarray, shape (K, n)
        Validation states, where the predicted error is evaluated.
    normals : ndarray, shape (M, 3), optional
        Touches of a ball on a known surface: the unit normal each gap is measured along
        (instrument frame).  Without it, each candidate is a measured point (3 rows).
    """
    zero = np.zeros(len(model.names))
    M = len(candidates)
    J = model.jacobian(zero, np.vstack([candidates, check])) * model.scales
    J = J.reshape(M + len(check), 3, -1)
    rows = J[:M] if normals is None else np.einsum("ka,kai->ki", normals, J[:M])[:, None, :]
    flat = rows.reshape(-1, rows.shape[2])
    _, s, Vt = np.linalg.svd(flat, full_matrices=False)
    rank = int(np.sum(s > s[0] * 1e-6))
    basis = Vt[:rank].T
    return Information(rows @ basis, J[M:] @ basis)


def best_possible(info: Information, iterations: int = 500, tolerance: float = 0.01) -> float:
    """A lower bound on the I-criterion ``tr(S M(w)^-1)`` of any design over the candidates
    (``S`` the validation poses' mean information): N poses predict at least
    ``sigma sqrt(value / N)``.

    The optimal approximate design is approached by multiplicative updates
    ``w <- w d / phi`` (``d_k = tr(G_k M^-1 S M^-1 G_k^T)``); by convexity every design ``w``
    certifies ``phi* >= 2 phi(w) - max_k d_k``, and the updates stop when that is within
    ``tolerance`` of ``phi(w)``.
    """
    G, Gc = info.G, info.G_check
    S = np.einsum("kai,kaj->ij", Gc, Gc) / len(Gc)
    w = np.full(len(G), 1.0 / len(G))
    lower = 0.0
    for _ in range(iterations):  # iterations of the design, each vectorised over candidates
        Mi = np.linalg.inv(np.einsum("k,kai,kaj->ij", w, G, G))
        d = np.einsum("kai,ij,kaj->k", G, Mi @ S @ Mi, G)
        phi = float(np.trace(S @ Mi))
        lower = max(lower, 2 * phi - float(d.max()))
        if lower >= (1 - tolerance) * phi:
            break
        w = w * d / phi
        w /= w.sum()
    return lower


def select(
    info: Information, count: int, sigma: float, seed: int = 0, passes: int = 10
) -> tuple[np.ndarray, dict]:
    """Greedy D- then I-optimal choice of ``count`` candidates, improved by exchanges.

    Returns
    -------
    chosen : ndarray of int, shape (count,)
        Indices into the candidates.
    figures : dict
        ``predicted``, ``random_same``, ``random_double``, ``best_possible`` [m],
        ``identifiable``.
    """
    rng = np.random.default_rng(seed)
    G, G_check = info.G, info.G_check
    M, m, rank = G.shape
    eye = np.eye(m)
    info_matrix = np.eye(rank) * 1e-9 * float(np.einsum("kai,kai->", G, G)) / M
    chosen: list[int] = []
    free = np.ones(M, dtype=bool)
    S = np.einsum("kai,kaj->ij", G_check, G_check) / len(G_check)
    for _ in range(count):
        inv = np.linalg.inv(info_matrix)
        B = np.einsum("kai,ij,kbj->kab", G, inv, G) + eye
        if len(chosen) * m < rank + m:  # until the information is whole: D-optimal
            score = np.linalg.slogdet(B)[1]
        else:  # then the pose that lowers the predicted error at the validation poses most
            X = np.einsum("kai,ij,kbj->kab", G, inv @ S @ inv, G)
            score = np.einsum("kaa->k", np.linalg.solve(B, X))
        score = np.where(free, score, -np.inf)
        best = int(np.argmax(score))
        chosen.append(best)
        free[best] = False
        info_matrix = info_matrix + G[best].T @ G[best]
    # exchanges: a chosen pose swapped for the candidate that lowers the prediction most
    for _ in range(passes):
        improved = False
        for slot in range(len(chosen)):
            rest = info_matrix - G[chosen[slot]].T @ G[chosen[slot]]
            try:
                inv = np.linalg.inv(rest)
            except np.linalg.LinAlgError:
                continue
            B = np.einsum("kai,ij,kbj->kab", G, inv, G) + eye
            X = np.einsum("kai,ij,kbj->kab", G, inv @ S @ inv, G)
            score = np.einsum("kaa->k", np.linalg.solve(B, X))
            score[~free] = -np.inf
            score[chosen[slot]] = np.einsum(
                "aa->", np.linalg.solve(B[chosen[slot]], X[chosen[slot]])
            )
            best = int(np.argmax(score))
            if best != chosen[slot] and score[best] > score[chosen[slot]] * (1 + 1e-9):
                free[chosen[slot]], free[best] = True, False
                chosen[slot] = best
                improved = True
            info_matrix = rest + G[chosen[slot]].T @ G[chosen[slot]]
        if not improved:
            break
    figures = {
        "predicted": _predicted(G[chosen], G_check, sigma),
        "identifiable": rank,
        "best_possible": sigma * float(np.sqrt(best_possible(info) / count)),
    }
    for key, size in (("random_same", count), ("random_double", 2 * count)):
        draws = [
            _predicted(G[rng.choice(M, min(size, M), replace=False)], G_check, sigma)
            for _ in range(20)
        ]
        figures[key] = float(np.median(draws))
    return np.array(chosen), figures


def select_poses(
    model: RobotModel,
    candidates: np.ndarray,
    count: int,
    sigma: float,
    seed: int = 0,
    passes: int = 10,
    normals: np.ndarray | None = None,
) -> tuple[np.ndarray, dict]:
    """Choose ``count`` of ``candidates`` (M, n) for a tracker (points) or, with ``normals``
    (M, 3), for touches of the robot's ball on known surfaces; the predicted error is taken at
    up to 500 of the candidates (the region the robot is calibrated for).  See :func:`select`.
    """
    rng = np.random.default_rng(seed)
    check = candidates[rng.permutation(len(candidates))[: min(len(candidates), 500)]]
    return select(information(model, candidates, check, normals), count, sigma, seed, passes)


@dataclass
class Touches:
    """Candidate touches of the robot's ball probe on known features (SI).

    Attributes
    ----------
    features : list of str
        The feature each touch is on.
    q : ndarray, shape (M, n)
        Joint values with the ball at contact.
    q_approach : ndarray, shape (M, n)
        Joint values at the approach, ``approach`` out along the normal, same orientation.
    normals : ndarray, shape (M, 3)
        Unit outward surface normals, world frame: the gap is measured along them.
    T_owner_approach, T_owner_end : ndarray, shape (M, 4, 4)
        The probe TCP at the approach and at the guarded move's end (``overtravel`` past the
        contact), in the feature owner's frame.
    """

    features: list[str]
    q: np.ndarray
    q_approach: np.ndarray
    normals: np.ndarray
    T_owner_approach: np.ndarray
    T_owner_end: np.ndarray


def _stylus_frames(normals: np.ndarray, tilt: float, rng) -> np.ndarray:
    """(M, 3, 3) rotations whose z axis (the stylus, towards the ball) is ``-normal`` tilted by
    up to ``tilt`` [rad] in a random direction, spun at random about itself."""
    M = len(normals)
    z0 = -normals
    helper = np.where(np.abs(z0[:, [0]]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    u = np.cross(z0, helper)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(z0, u)
    angle = np.arccos(1 - rng.uniform(0, 1, M) * (1 - np.cos(tilt)))  # uniform on the cap
    turn = rng.uniform(0, 2 * np.pi, M)
    z = np.cos(angle)[:, None] * z0 + np.sin(angle)[:, None] * (
        np.cos(turn)[:, None] * u + np.sin(turn)[:, None] * v
    )
    a = rng.normal(size=(M, 3))  # a random spin about the stylus
    x = a - np.einsum("ki,ki->k", a, z)[:, None] * z
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    return np.stack([x, np.cross(z, x), z], axis=2)


def touch_candidates(
    cell,
    device: str,
    tcp: str,
    radius: float,
    features: list[str],
    count: int,
    seed: int = 0,
    approach: float = 0.02,
    overtravel: float = 0.004,
    tilt: float = np.radians(40.0),
) -> tuple[Touches, int]:
    """Touches of the ball (radius [m], centred on ``tcp``) spread over ``features`` (planes and
    edges of the cell's objects): points on material (:func:`.targets.feature_candidates`), the
    stylus within ``tilt`` of the normal at random, each solved by IK from three random starts,
    so that the robot's configurations vary as much as the features allow.

    Returns
    -------
    Touches
        Those the robot reaches within its limits, at the contact, the approach and the end.
    int
        How many were tried.

    Raises
    ------
    UserError
        A feature that is unknown, carried by the device, or neither a plane nor an edge.
    """
    from ..errors import UserError, did_you_mean
    from ..kinematics.inverse import solve_ik_many
    from ..kinematics.jacobian import ToolMount
    from ..world.tree import World
    from .targets import feature_candidates

    world = World(cell)
    dev = cell.devices[device]
    carried = set(world.subtree(device))
    mount = ToolMount(*world.mount_of(device, tcp))
    T_base_world = np.linalg.inv(world.T_world(device))
    rng = np.random.default_rng(seed)
    per = -(-count // len(features))
    names, T_world_owner, T_owner_contact, normals_owner = [], [], [], []
    for name in features:
        f = cell.features.get(name)
        if f is None:
            raise UserError(f"unknown feature '{name}'{did_you_mean(name, cell.features)}")
        if f.owner in carried:
            raise UserError(f"'{name}' is carried by '{device}': touch features of the cell")
        if f.kind not in ("plane", "line"):
            raise UserError(
                f"'{name}' is a {f.kind}: touches are planned on planes and edges (lines); list "
                "touches of spheres and hole walls in the contacts file yourself"
            )
        c = feature_candidates(cell, f, radius, radius)
        pick = rng.integers(0, len(c), per)
        R = _stylus_frames(c.normals[pick], tilt, rng)
        T = np.tile(np.eye(4), (per, 1, 1))
        T[:, :3, :3], T[:, :3, 3] = R, c.centres[pick]
        names += [name] * per
        T_world_owner += [world.T_world(f.owner)] * per
        T_owner_contact.append(T)
        normals_owner.append(c.normals[pick])
    T_wo = np.array(T_world_owner)
    T_oc = np.concatenate(T_owner_contact)
    n_o = np.concatenate(normals_owner)
    M = len(T_oc)

    def moved(distance: float) -> np.ndarray:
        T = T_oc.copy()
        T[:, :3, 3] += distance * n_o
        return T

    lower, upper = dev.limit_array("lower"), dev.limit_array("upper")
    lo = np.where(np.isfinite(lower), lower, -np.pi)
    hi = np.where(np.isfinite(upper), upper, np.pi)
    T_base = T_base_world @ T_wo @ T_oc
    starts = 3
    Q, ok = solve_ik_many(
        dev, np.tile(T_base, (starts, 1, 1)), rng.uniform(lo, hi, (starts * M, dev.dof)), mount
    )
    Q, ok = Q.reshape(starts, M, -1), ok.reshape(starts, M)
    first = np.argmax(ok, axis=0)
    q = Q[first, np.arange(M)]
    reached = ok.any(axis=0)
    T_app, T_end = moved(approach), moved(-overtravel)
    q_app, ok_app = solve_ik_many(dev, T_base_world @ T_wo @ T_app, q, mount)
    _, ok_end = solve_ik_many(dev, T_base_world @ T_wo @ T_end, q, mount)
    # the guarded move is a short straight line: its ends on the contact's branch
    keep = reached & ok_app & ok_end & (np.abs(q_app - q).max(axis=1) < 0.3)
    normals = np.einsum("kij,kj->ki", T_wo[:, :3, :3], n_o)
    touches = Touches(
        [n for n, k in zip(names, keep, strict=True) if k],
        q[keep],
        q_app[keep],
        normals[keep],
        T_app[keep],
        T_end[keep],
    )
    return touches, M


# --------------------------------------------------------------------------- candidates


def collision_free_states(cell, device: str, Q: np.ndarray) -> np.ndarray:
    """Which joint states (K, n) of ``device`` touch nothing it may not touch (K,) bool: the
    collision room's configuration check, with no overlap tolerated."""
    from ..collision.bodies import collision_model
    from ..collision.configurations import ConfigurationChecker
    from ..world.tree import World

    checker = ConfigurationChecker(World(cell), collision_model(cell), device, tolerance=0.0)
    return checker.free(Q)


SIGHT_CLEARANCE = 0.01  # [m]: the line of sight's radius: no robot body within it
SIGHT_START = 0.03  # [m]: from this far out from the target (its own mount is not in the way)


def tracker_visible(cell, device, target, Q, floor, instrument_at, acceptance, world):
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
        result = distances(  # overlap or not: no depth wanted
            bodies,
            np.full(len(near), i),
            np.full(len(near), ball),
            Tb[owner[near]],
            Tc,
            deep_enough=0.0,
        )
        hidden[owner[near[result.overlap]]] = True
    lost["with the arm in the line of sight"] = int((keep & hidden).sum())
    return keep & ~hidden, lost


@dataclass
class CandidatePool:
    """Candidates of one instrument: the states to choose from and how a program visits them."""

    q: np.ndarray  # (M, n) where the instrument measures
    q_path: np.ndarray  # (M, n) reached from home by a joint move (touches: the approach)
    normals: np.ndarray | None = None  # touches: (M, 3) world
    touches: Touches | None = None


def tracker_pool(dev, rng, candidates: int) -> CandidatePool:
    lower, upper = dev.limit_array("lower"), dev.limit_array("upper")
    lo = np.where(np.isfinite(lower), lower, -np.pi)
    hi = np.where(np.isfinite(upper), upper, np.pi)
    q = rng.uniform(lo, hi, (candidates, dev.dof))
    return CandidatePool(q, q)

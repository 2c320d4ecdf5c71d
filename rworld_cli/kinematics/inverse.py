"""Inverse kinematics by damped least squares (Levenberg-Marquardt), restarts batched.

All starts (the seed and random configurations within the joint limits)
iterate together as one ``(K, n)`` batch through the generated tool pose
and Jacobian; each keeps its own damping.  Steps are projected onto the
joint limits.  Among the starts that converge, the one nearest the seed
wins - so consecutive targets along a path stay on one branch.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import spatial
from ..model.cell import DeviceModel
from .jacobian import ToolMount, tool_pose_and_jacobian


@dataclass
class IKResult:
    """Outcome of :func:`solve_ik`.

    Attributes
    ----------
    q : ndarray, shape (n,)
        The best joint values found (SI).
    success : bool
        Both residuals within tolerance.
    position_error : float
        Distance from the tool origin to the target [m].
    rotation_error : float
        Angle between tool and target orientation [rad] (0 for position-only).
    iterations : int
    at_limits : list of (joint index, "lower" | "upper")
        Joints of ``q`` resting on a position limit.
    """

    q: np.ndarray
    success: bool
    position_error: float
    rotation_error: float
    iterations: int
    at_limits: list = field(default_factory=list)

    def unreachable(self, target: str, tcp: str, joint_names, position_only: bool = False) -> str:
        """Why the target was not reached, with the figures: the closest pose found and the
        joints at a limit.
        """
        limits = (
            ", ".join(f"{joint_names[i]} at its {side} limit" for i, side in self.at_limits)
            or "no joint at a limit"
        )
        rot = "" if position_only else f" and {np.degrees(self.rotation_error):.3g} deg"
        return (
            f"'{target}' is unreachable for {tcp}: the closest pose found is "
            f"{self.position_error * 1000:.4g} mm{rot} away ({limits})"
        )


def _errors(T: np.ndarray, target: np.ndarray) -> np.ndarray:
    """(K, 6): position error, then rotation vector from tool to target, base frame; one target
    (4, 4) for every pose, or one each (K, 4, 4)."""
    if T.ndim == 2:  # one pose (the tracking loop's every step)
        return np.concatenate(
            [target[:3, 3] - T[:3, 3], spatial.rotation_vector(target[:3, :3] @ T[:3, :3].T)]
        )
    e = np.empty(T.shape[:-2] + (6,))
    e[..., :3] = target[..., :3, 3] - T[..., :3, 3]
    e[..., 3:] = spatial.rotation_vector(target[..., :3, :3] @ np.swapaxes(T[..., :3, :3], -1, -2))
    return e


def _revolute(device: DeviceModel) -> np.ndarray:
    return np.array([j.kind == "revolute" for j in device.joints])


def nearest_turns(q, seed, revolute, lower, upper) -> np.ndarray:
    """Each revolute joint of ``q`` (..., n) moved by whole turns to lie nearest ``seed`` (n,)
    within ``[lower, upper]``; the same tool pose. Prismatic joints, and revolute ones no turn
    brings nearer within the limits, stay.

    Returns
    -------
    ndarray, shape like ``q`` [rad or m]
    """
    q = np.asarray(q, dtype=float)
    best = q.copy()
    gap = np.abs(q - seed)
    for k in (-2, -1, 1, 2):  # a joint's range is at most a few turns
        shifted = q + 2.0 * np.pi * k
        better = revolute & (shifted >= lower - 1e-12) & (shifted <= upper + 1e-12)
        better &= np.abs(shifted - seed) < gap - 1e-12
        best = np.where(better, shifted, best)
        gap = np.where(better, np.abs(shifted - seed), gap)
    return best


def _tolerances(position_only: bool, position: float, rotation: float) -> np.ndarray:
    return np.array([position] * 3 + ([] if position_only else [rotation] * 3))


def _levenberg_marquardt(device, mount, target, Q, tol, max_iterations, stop=None):
    """Damped least squares on a batch of starts ``Q`` (K, n), each with its own damping, steps
    projected on the limits; ``target`` (4, 4) for all or (K, 4, 4) each; ``tol`` (3,) or (6,)
    (position only or full pose).  Stops when every start is within ``tol`` or
    ``stop(done, Q, iterations)`` says so.

    Returns
    -------
    Q, T, err, cost, iterations
        The best state of each start, its tool pose, errors (K, 3 or 6) and squared error.
    """
    lower, upper = device.limit_array("lower"), device.limit_array("upper")
    rows = slice(0, len(tol))
    lam = np.full(len(Q), 1e-2)
    T, J = tool_pose_and_jacobian(device, Q, mount)
    err = _errors(T, target)[:, rows]
    cost = np.einsum("ki,ki->k", err, err)
    eye = np.eye(len(tol))
    iterations = 0
    for iterations in range(1, max_iterations + 1):  # iterations of the batch, not samples
        done = np.all(np.abs(err) <= tol, axis=1)
        if done.all() or (stop is not None and stop(done, Q, iterations)):
            break
        Jr = J[:, rows, :]
        A = Jr @ np.swapaxes(Jr, 1, 2) + (lam**2)[:, None, None] * eye
        try:
            x = np.linalg.solve(A, err[..., None])[..., 0]
        except np.linalg.LinAlgError:  # a start on a singularity with the damping at its floor
            x = np.einsum("kij,kj->ki", np.linalg.pinv(A), err)
        step = np.einsum("kji,kj->ki", Jr, x)
        Q_new = np.clip(Q + step, lower, upper)
        T_new, J_new = tool_pose_and_jacobian(device, Q_new, mount)
        err_new = _errors(T_new, target)[:, rows]
        cost_new = np.einsum("ki,ki->k", err_new, err_new)
        better = (cost_new < cost) & ~done
        Q[better], T[better], J[better], err[better], cost[better] = (
            Q_new[better],
            T_new[better],
            J_new[better],
            err_new[better],
            cost_new[better],
        )
        lam = np.where(better, np.maximum(lam / 3, 1e-9), np.minimum(lam * 4, 1e6))
    return Q, T, err, cost, iterations


def solve_ik(
    device: DeviceModel,
    T_base_target,
    mount: ToolMount | None = None,
    seed=None,
    position_only: bool = False,
    restarts: int = 16,
    position_tolerance: float = 1e-7,
    rotation_tolerance: float = 1e-7,
    max_iterations: int = 300,
    random_seed: int = 0,
    accept=None,
) -> IKResult:
    """Joint values that put the tool frame on a target.

    Parameters
    ----------
    device : DeviceModel
    T_base_target : array_like, shape (4, 4)
        Target pose of the tool frame in the device's base frame.
    mount : ToolMount, optional
        The tool frame; default the flange.
    seed : array_like, shape (n,), optional
        Start (e.g. the current joint values); default the device's home.
    position_only : bool
        Match the tool origin only (3 equations).
    restarts : int
        Random starts within the limits besides the seed.
    position_tolerance, rotation_tolerance : float
        Success thresholds [m], [rad].
    accept : callable, optional
        ``accept(Q) -> bool array (K,)`` of joint states ``Q`` (K, n): only solutions it accepts
        count (an arm configuration).  When none of the starts lands on one, 8 and then 64 times
        as many random starts are tried.

    Returns
    -------
    IKResult
        ``success`` False when no start reached the target; ``q`` is then the
        closest configuration found and the errors say how far off it is.
    """
    n = device.dof
    target = np.asarray(T_base_target, dtype=float)
    lower = device.limit_array("lower")
    upper = device.limit_array("upper")
    lo = np.where(np.isfinite(lower), lower, -np.pi)
    hi = np.where(np.isfinite(upper), upper, np.pi)
    seed = device.home if seed is None else np.asarray(seed, dtype=float)
    rng = np.random.default_rng(random_seed)
    Q = np.vstack([np.clip(seed, lower, upper), rng.uniform(lo, hi, (restarts, n))])
    tol = _tolerances(position_only, position_tolerance, rotation_tolerance)
    revolute = _revolute(device)
    settled = 0

    def stop(done: np.ndarray, Q: np.ndarray, iterations: int) -> bool:
        nonlocal settled
        if accept is None:
            return bool(done[0]) and iterations > 1  # the seed itself landed
        if done.sum() > settled:  # a start has landed: which?
            settled = int(done.sum())
            return bool((done & accept(nearest_turns(Q, seed, revolute, lower, upper))).any())
        return False

    Q, T, err, cost, iterations = _levenberg_marquardt(
        device, mount, target, Q, tol, max_iterations, stop
    )
    done = np.all(np.abs(err) <= tol, axis=1)
    # a revolute joint reaches the same pose a whole turn away: of each solution, the turns
    # nearest the seed within the limits (a wrist with a +-400 deg range turns 360 deg for nothing
    # otherwise), then the solution nearest the seed
    Q = nearest_turns(Q, seed, revolute, lower, upper)
    if accept is not None:
        done &= accept(Q)
        if not done.any() and restarts < 64 * 16:
            return solve_ik(
                device,
                T_base_target,
                mount,
                seed,
                position_only,
                max(restarts, 16) * 8,
                position_tolerance,
                rotation_tolerance,
                max_iterations,
                random_seed + 1,
                accept,
            )
    if done.any():
        candidates = np.nonzero(done)[0]
        best = candidates[np.argmin(np.linalg.norm(Q[candidates] - seed, axis=1))]
    else:
        best = int(np.argmin(cost))
    full = _errors(T[best], target)
    q = Q[best]
    at_limits = [(i, "lower") for i in np.nonzero(np.isclose(q, lower, atol=1e-9))[0]]
    at_limits += [(i, "upper") for i in np.nonzero(np.isclose(q, upper, atol=1e-9))[0]]
    return IKResult(
        q=q.copy(),
        success=bool(done[best]),
        position_error=float(np.linalg.norm(full[:3])),
        rotation_error=0.0 if position_only else float(np.linalg.norm(full[3:])),
        iterations=iterations,
        at_limits=sorted(at_limits),
    )


def solve_ik_many(
    device: DeviceModel,
    T_base_targets: np.ndarray,
    seeds: np.ndarray,
    mount: ToolMount | None = None,
    position_only: bool = False,
    position_tolerance: float = 1e-7,
    rotation_tolerance: float = 1e-7,
    max_iterations: int = 300,
) -> tuple[np.ndarray, np.ndarray]:
    """Many targets at once, each from its own start: the same damped least squares as
    :func:`solve_ik`, one batch for all (no restarts; give several rows per target for more).

    Parameters
    ----------
    T_base_targets : ndarray, shape (K, 4, 4)
        Tool frame targets in the device's base frame.
    seeds : ndarray, shape (K, n)
        Starts [rad or m], clipped to the limits.

    Returns
    -------
    q : ndarray, shape (K, n)
        The joint values reached, within the limits.
    success : ndarray of bool, shape (K,)
        Both residuals within tolerance.
    """
    lower, upper = device.limit_array("lower"), device.limit_array("upper")
    Q = np.clip(np.asarray(seeds, dtype=float), lower, upper)
    tol = _tolerances(position_only, position_tolerance, rotation_tolerance)
    Q, _, err, _, _ = _levenberg_marquardt(
        device, mount, np.asarray(T_base_targets, dtype=float), Q, tol, max_iterations
    )
    return Q, np.all(np.abs(err) <= tol, axis=1)


def distinct_solutions(
    device: DeviceModel,
    T_base_target,
    starts,
    mount: ToolMount | None = None,
    position_only: bool = False,
    accept=None,
    apart: float = 1e-3,
) -> np.ndarray:
    """The distinct joint solutions of one target reached from ``starts`` (S, n) in one batch
    (:func:`solve_ik_many`), in the order of their starts: a solution within ``apart`` [rad or
    m] of an earlier one (largest joint difference) is dropped; ``accept(Q) -> (S,) bool``
    keeps only those in a configuration asked for.  Shape (M, n), M <= S."""
    starts = np.atleast_2d(np.asarray(starts, dtype=float))
    T = np.asarray(T_base_target, dtype=float)
    Q, ok = solve_ik_many(device, np.repeat(T[None], len(starts), 0), starts, mount, position_only)
    if accept is not None and ok.any():
        ok = ok & np.asarray(accept(Q), dtype=bool)
    return distinct_states(Q[ok], apart).reshape(-1, starts.shape[1])


def distinct_states(Q, apart: float) -> np.ndarray:
    """The joint states ``Q`` (K, n) without repeats, in their order: a state within ``apart``
    [rad or m] of an earlier one (largest joint difference) is dropped.  Shape (M, n)."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    found: list[np.ndarray] = []
    for q in Q:
        if all(np.abs(q - other).max() > apart for other in found):
            found.append(q)
    return np.array(found).reshape(-1, Q.shape[1])


def solve_ik_soonest(
    device: DeviceModel,
    T_base_targets: np.ndarray,
    q_now: np.ndarray,
    mount: ToolMount | None = None,
    position_only: bool = False,
    seed: np.ndarray | None = None,
    accept=None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Candidate targets (the free turns of one target) solved in one batch from ``seed``
    (default ``q_now``) and ranked by how soon a joint move from ``q_now`` reaches them: the
    largest joint travel over its velocity limit (1 where none is given).

    Returns
    -------
    Q : ndarray, shape (K, n)
    ok : ndarray of bool, shape (K,)
        Reached, and accepted by ``accept(Q) -> (K,) bool`` when given (a configuration).
    order : ndarray of int, shape (K,)
        The candidates that are ``ok`` soonest first, then the others.
    """
    q_now = np.asarray(q_now, dtype=float)
    start = q_now if seed is None else np.asarray(seed, dtype=float)
    Q, ok = solve_ik_many(
        device,
        T_base_targets,
        np.repeat(start[None], len(T_base_targets), 0),
        mount,
        position_only,
    )
    if accept is not None and ok.any():
        ok &= np.asarray(accept(Q), dtype=bool)
    vmax = device.limit_array("velocity")
    travel = np.max(np.abs(Q - q_now) / np.where(np.isfinite(vmax), vmax, 1.0), axis=1)
    return Q, ok, np.lexsort((travel, ~ok))


@dataclass
class TrackResult:
    """Outcome of :func:`track`: joint values for the poses reached, and where it stopped if it
    failed.
    """

    q: np.ndarray  # (K, n) - rows after a failure repeat the last solution
    failed_at: int | None  # index of the first pose not reached
    reason: str  # "" | "unreachable" | "singular"
    error: float  # remaining position error at the failure [m]
    condition: float  # largest Jacobian condition number met


# a tracked state whose Jacobian is worse conditioned than this stops at a residual of
# NEAR_SINGULAR_TOLERANCE (m, rad) where it does not reach the tolerance asked
NEAR_SINGULAR_CONDITION = 1e4
NEAR_SINGULAR_TOLERANCE = 1e-6


def track(
    device: DeviceModel,
    targets: np.ndarray,
    q0,
    mount: ToolMount | None = None,
    position_only: bool = False,
    tolerance: float = 1e-7,
    max_iterations: int = 30,
    max_condition: float = 1e6,
) -> TrackResult:
    """Follow a dense sequence of tool poses, each solution seeding the next.

    Why sequential: along a path the previous solution is the right seed and
    keeps one branch; each step is a few Gauss-Newton iterations on one state.

    Parameters
    ----------
    targets : ndarray, shape (K, 4, 4)
        Tool poses in the base frame, close to each other.
    q0 : array_like, shape (n,)
        Joint values at (or near) the first pose.
    tolerance : float
        The largest position [m] or rotation [rad] error left at each pose; beside a
        singularity (condition number past ``NEAR_SINGULAR_CONDITION``) a pose that does not
        reach it within 4 iterations keeps ``NEAR_SINGULAR_TOLERANCE``.
    max_condition : float
        A Jacobian worse conditioned than this is a singularity: the path is refused there.
    """
    lower, upper = device.limit_array("lower"), device.limit_array("upper")
    rows = slice(0, 3) if position_only else slice(0, 6)
    damping = 1e-10 * np.eye(3 if position_only else 6)  # made once: every step adds it
    q = np.asarray(q0, dtype=float).copy()
    out = np.empty((len(targets), device.dof))
    worst = 1.0
    for k, target in enumerate(targets):  # sequential by nature: each pose seeds the next
        for iteration in range(max_iterations):
            T, J = tool_pose_and_jacobian(device, q, mount)
            err = _errors(T, target)[rows]
            largest = abs(err).max()
            if largest <= tolerance:
                break
            if iteration >= 4 and largest <= NEAR_SINGULAR_TOLERANCE:
                # beside a singularity the residual left lies along the lost direction: a
                # step for it swings the joints that lose it (a wrist upright: R and T turn
                # by up to pi for 1e-7 rad) and may never settle; 1e-6 (m, rad) is kept
                s = np.linalg.svd(J[rows], compute_uv=False)
                if s[-1] < s[0] / NEAR_SINGULAR_CONDITION:
                    break
            Jr = J[rows]
            dq = Jr.T @ np.linalg.solve(Jr @ Jr.T + damping, err)
            # a joint at its limit that the step pushes further: held there and the step
            # solved by the others (clamping it only stalls the iteration: a 7-axis arm
            # whose home has a joint at its limit failed a line by 2e-8 m)
            held = ((q <= lower) & (dq < 0)) | ((q >= upper) & (dq > 0))
            if held.any() and not held.all():
                free = ~held
                Jf = Jr[:, free]
                dq = np.zeros_like(dq)
                dq[free] = Jf.T @ np.linalg.solve(Jf @ Jf.T + damping, err)
            q = np.minimum(np.maximum(q + dq, lower), upper)
        else:
            out[k:] = q
            return TrackResult(out, k, "unreachable", float(np.linalg.norm(err[:3])), worst)
        s = np.linalg.svd(J[rows], compute_uv=False)
        cond = s[0] / s[-1] if s[-1] > 0 else np.inf
        worst = max(worst, cond)
        if cond > max_condition:
            out[k:] = q
            return TrackResult(out, k, "singular", 0.0, cond)
        out[k] = q
    return TrackResult(out, None, "", 0.0, worst)

"""``rworld plan path``: a collision-free joint path for a device in its cell, to a frame, a
named position or joint values (``planning/motion.py``, checked by the collision room's
configuration and segment checks)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import CheckFailed, UserError
from ..units import COLLISION_TOLERANCE
from .physics import DeviceContext

if TYPE_CHECKING:
    from ..planning.motion import PathPlan

IK_SEEDS = 24  # random IK starts besides the start state: the goal's configurations


@dataclass
class PlannedPath:
    """A path planned for ``rworld plan path``.

    Attributes
    ----------
    plan : PathPlan
        Waypoints (W, n) [rad or m], counters, lengths (``planning.motion.PathPlan``).
    device, target : str
    start : ndarray, shape (n,)
    goals : ndarray, shape (G, n)
        The goal states given to the search (a frame's IK solutions, nearest the start first;
        those not free or touching something are dropped there).
    clearance, tolerance : float
        The clearance asked (0: none) and the collision tolerance [m]; the path's ``kept``
        clearance (``plan.kept``) is what it keeps from every pair not inside the search
        margin at its ends (``plan.inside_margin``); those keep ``plan.tight_kept``.
    written : str or None
        The path file written.
    offset : list of float or None
        [m] the frame target moved along its own axes (``--offset``).
    """

    plan: PathPlan
    device: str
    target: str
    start: np.ndarray
    goals: np.ndarray
    clearance: float
    tolerance: float
    written: str | None = None
    offset: list[float] | None = None  # [m] a frame target moved along its axes

    def kept_words(self) -> str:
        """The clearance the path keeps, in words: 'clearance 1 mm (none asked)', and the
        pairs an end holds closer, which keep only the clearance asked."""
        p = self.plan
        words = f"clearance {p.kept * 1000:g} mm" + (
            " (none asked)" if self.clearance == 0 and p.kept > 0 else ""
        )
        if p.inside_margin:
            words += (
                f" except {len(p.inside_margin)} pair(s) an end holds closer (kept "
                f"{p.tight_kept * 1000:.3g} mm: " + "; ".join(p.inside_margin) + ")"
            )
        return words

    @property
    def knots(self) -> np.ndarray:
        """The waypoints' path parameters (W,), by joint-space length (the plan's)."""
        return self.plan.knots

    def as_dict(self) -> dict:
        p = self.plan
        return {
            "device": self.device,
            "target": self.target,
            "offset": self.offset,
            "found": p.found,
            "outcome": p.outcome,
            "reason": p.reason,
            "waypoints": p.waypoints.tolist(),
            "knots": p.knots.tolist(),
            "blends": p.blends.tolist(),
            "corners_blended": int((p.blends > 0).sum()),
            "goal": p.goal,
            "goals_tried": self.goals.tolist(),
            "length": p.length,
            "length_before_shortcuts": p.raw_length,
            "iterations": p.iterations,
            "tree_states": p.tree_states,
            "states_checked": p.states_checked,
            "segments_checked": p.segments_checked,
            "repairs": p.repairs,
            "attempts": p.attempts,
            "failed_segment": None if p.blocked is None else p.blocked.tolist(),
            "bodies_met": p.bodies,
            "inside_margin": p.inside_margin,
            "seconds": p.seconds,
            "clearance": self.clearance,
            "clearance_kept": p.kept,
            "clearance_kept_inside_margin": p.tight_kept if p.inside_margin else None,
            "collision_tolerance": self.tolerance,
            "written": self.written,
        }


def named_state(ctx: DeviceContext, text: str, what: str) -> np.ndarray:
    """Joint values [SI] from 'home', a named position of the device, or comma-separated
    values (SI: rad, m)."""
    dev = ctx.device
    if text == "home":
        return np.asarray(dev.home, dtype=float)
    if text in dev.positions:
        return np.asarray(dev.positions[text], dtype=float)
    try:
        q = np.array([float(v) for v in text.split(",")])
    except ValueError:
        q = None
    if q is None or len(q) != dev.dof or not np.isfinite(q).all():
        from ..errors import did_you_mean

        named = ["home", *dev.positions]
        raise UserError(
            f"{what} '{text}' is neither a named position of '{dev.name}' ("
            f"{', '.join(named)}){did_you_mean(text, named)} nor {dev.dof} joint values [rad, m]"
        )
    return q


def goal_states(
    ctx: DeviceContext, to: str, start: np.ndarray, seed: int, offset=None
) -> np.ndarray:
    """The goal states for ``to``: a named position or joint values (one state), or a frame of
    the cell - moved by ``offset`` (3,) [m] along its own axes (a pre-grasp point above a
    grasp frame) - whose IK solutions within the limits (from the start and from
    :data:`IK_SEEDS` random starts, one batch), each at the turns nearest the start, are the
    goals, nearest the start first (G, n)."""
    from ..kinematics.inverse import (
        distinct_solutions,
        distinct_states,
        nearest_turns,
        solve_ik,
    )
    from ..planning.motion import sampled_box

    cell = ctx.world.cell
    if to not in cell.frames:
        if offset is not None:
            raise UserError(f"--offset moves a frame; '{to}' is a joint position")
        return named_state(ctx, to, "--to")[None]
    dev = ctx.device
    T_world = ctx.world.T_world(to).copy()
    if offset is not None:
        T_world[:3, 3] += T_world[:3, :3] @ np.asarray(offset, dtype=float)
    T_base = np.linalg.inv(ctx.T_world_base) @ T_world
    lower, upper = dev.limit_array("lower"), dev.limit_array("upper")
    rng = np.random.default_rng(seed)
    seeds = np.concatenate(
        [start[None], rng.uniform(sampled_box(lower), sampled_box(upper), (IK_SEEDS, dev.dof))]
    )
    goals = distinct_solutions(dev, T_base, seeds, ctx.mount, dev.dof < 6)
    if not len(goals):  # with restarts, for the figures of why not
        result = solve_ik(dev, T_base, ctx.mount, start, dev.dof < 6)
        if not result.success:
            raise UserError(
                result.unreachable(to, ctx.tcp, [j.name for j in dev.joints], dev.dof < 6)
            )
        goals = np.asarray(result.q, dtype=float)[None]
    # each solution at the turns nearest the start (a wrist at -200 deg is at +160 too: the
    # same pose, 360 deg less to travel), then the nearest first; turns that meet, once
    revolute = np.array([j.kind == "revolute" for j in dev.joints])
    goals = nearest_turns(goals, start, revolute, lower, upper)
    goals = goals[np.argsort(np.linalg.norm(goals - start, axis=1), kind="stable")]
    return distinct_states(goals, 1e-6)  # IK's answers agree to its tolerance, not to the bit


def plan_free_path(
    ctx: DeviceContext,
    to: str,
    start=None,
    *,
    seed: int = 0,
    timeout: float = 10.0,
    clearance: float | None = None,
    tolerance: float = COLLISION_TOLERANCE,
    output: str | None = None,
    progress=None,
    offset=None,
    blend: bool = True,
) -> PlannedPath:
    """``rworld plan path``: a collision-free joint path of ``ctx``'s device from ``start``
    (default the joints now) to ``to`` (a frame of the cell for the TCP, a named position,
    'home', or joint values; ``offset`` (3,) [m] moves a frame along its own axes), in the
    cell as it is (other devices where the pose files put them;
    ``planning.motion.plan_in_world``), its corners blended where the blends' curves are
    free (``blend``).  ``clearance`` [m] is kept from everything everywhere; None (not asked):
    the path keeps ``planning.motion.PATH_CLEARANCE`` (1 mm) from every pair its start and
    goal leave room for, the others only out of contact deeper than ``tolerance``.  Written
    to ``output`` as a path file (``boundary: blended``: the straight lines and blends
    checked) when one was found.

    Raises
    ------
    UserError
        Unknown target, wrong joint count, a start outside the limits, a frame no joint
        solution reaches (exit 2).
    CheckFailed
        No path: the start not free, every goal not free or touching something (naming the
        nearest pairs), or none found within ``timeout`` (exit 1).
    """
    from ..collision.bodies import collision_model
    from ..planning.motion import PATH_CLEARANCE, plan_in_world

    dev = ctx.device
    q0 = (
        np.asarray(ctx.world.joints(dev.name), dtype=float)
        if start is None
        else (named_state(ctx, start, "--from") if isinstance(start, str) else np.asarray(start))
    )
    if q0.shape != (dev.dof,):
        raise UserError(f"device '{dev.name}' has {dev.dof} joint(s); the start has {q0.size}")
    lower, upper = dev.limit_array("lower"), dev.limit_array("upper")
    outside = np.flatnonzero((q0 < lower - 1e-12) | (q0 > upper + 1e-12))
    if len(outside):
        j = int(outside[0])
        raise UserError(
            f"the start puts {dev.joints[j].name} at {q0[j]:.6g}, outside its limits "
            f"[{lower[j]:.6g}, {upper[j]:.6g}]"
        )
    goals = goal_states(ctx, to, q0, seed, offset)
    plan, _ = plan_in_world(
        ctx.world,
        collision_model(ctx.world.cell),
        dev.name,
        q0,
        goals,
        tolerance=tolerance,
        clearance=clearance or 0.0,
        kept=PATH_CLEARANCE if clearance is None else clearance,
        seed=seed,
        timeout=timeout,
        progress=None
        if progress is None
        else lambda rounds, states: progress(rounds, None, f"searching: {states} states"),
        blend=blend,
    )
    out = PlannedPath(plan, dev.name, to, q0, goals, clearance or 0.0, tolerance)
    out.offset = None if offset is None else [float(v) for v in offset]
    if not plan.found:
        raise CheckFailed(f"no path to '{to}': {plan.reason}", report=out.as_dict())
    if output is not None:
        from ..schema.paths import write_planned_path

        write_planned_path(output, dev, plan.waypoints, plan.blends, _note(out))
        out.written = output
    return out


def _moved(offset) -> str:
    return "" if offset is None else " moved by [" + ", ".join(f"{v:g}" for v in offset) + "] m"


def _note(out: PlannedPath) -> str:
    p = out.plan
    return (
        f"rworld plan path: '{out.device}' to '{out.target}'{_moved(out.offset)}, "
        f"{len(p.waypoints)} waypoints, "
        f"{p.length:.4g} rad of joint travel, {out.kept_words()}, collision "
        f"tolerance {out.tolerance * 1000:g} mm; straight joint segments, "
        f"{int((p.blends > 0).sum())} of {max(len(p.waypoints) - 2, 0)} corners blended, each "
        "line and blend checked continuously (docs/planning.md)"
    )

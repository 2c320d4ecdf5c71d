"""Move steps (``move:``: joint and linear moves, feature targets' IK choice, collision-free
solutions and turns, ``path: free`` and path files timed as legs) as the scheduler's methods
(a mixin: ``self`` is an ``engine._Scheduler``)."""

from __future__ import annotations

import numpy as np

from ..dynamics import DeviceDynamics
from ..errors import UserError
from ..kinematics.configuration import arm_configurations, is_arm, vendor_words
from ..kinematics.inverse import solve_ik, solve_ik_soonest
from ..kinematics.jacobian import ToolMount, tool_pose
from ..model.program import BlendZone, MoveTarget, ResolvedStep, Step
from ..motion.linear import PathError, linear_move
from ..motion.trajectory import UntimedMove, joint_move
from ..units import MAX_SAMPLES
from .errors import NoFreePath
from .timeline import Event, Track

IK_STARTS = 24  # seeded IK starts for a target's other joint solutions (a blocked move)
PATH_START_TOLERANCE = 1e-6  # [rad or m] a path file's first waypoint against the joints


class MotionSteps:
    """The move steps of the scheduler."""

    def _move(self, device: str, tr: Track, step: Step) -> bool:
        spec = step.spec
        dev = self.run.cell.devices[device]
        q_now = self.world.joints(device)
        if step.waypoints is not None:  # move: {path: FILE}
            way = step.waypoints
            off = np.abs(way[0] - q_now)
            if off.max() > PATH_START_TOLERANCE:
                j = int(np.argmax(off))
                self.fail(
                    device,
                    step,
                    f"the path starts with {dev.joints[j].name} at {way[0][j]:.6g}, and the "
                    f"device is at {q_now[j]:.6g} (SI): a path file is driven from where it "
                    "starts - plan it from the joints this step starts at ('rworld plan path "
                    "--from'), or move there first",
                )
            self._drive_through(
                device,
                tr,
                step,
                np.concatenate([q_now[None], way[1:]]),
                step.spec.path,
                self._resolve_tcp(device, step.spec.tcp),
                None,
                None,
                step.blends,
            )
            return True
        if step.joints is not None:  # move: {joints: [...]}
            seg = self._joint_move(device, tr, step, q_now, step.joints)
            self._record_move(device, tr, step, q_now, seg, seg, "joint values", until=spec.until)
            return True
        if step.goal is None and (spec.to == "home" or spec.to in dev.positions):
            q_goal = dev.home if spec.to == "home" else dev.positions[spec.to]
            seg = self._joint_move(device, tr, step, q_now, q_goal)
            self._record_move(device, tr, step, q_now, seg, seg, spec.to, until=spec.until)
            return True
        tcp = self._resolve_tcp(device, spec.tcp)
        if step.goal is not None:  # a target on a feature: each free spin a candidate
            targets = self._feature_targets(device, step) @ step.T_offset
            name = step.goal.feature
        else:
            targets = (self.world.T_world(spec.to) @ step.T_offset)[None]
            name = spec.to
        self._go(
            device,
            tr,
            step,
            tcp,
            targets,
            spec.motion,
            spec.speed,
            spec.acceleration,
            spec.until,
            name,
        )
        return True

    def _go(
        self,
        device: str,
        tr: Track,
        step: Step,
        tcp: str,
        T_world_targets: np.ndarray,
        motion: str,
        speed: float,
        acceleration: float,
        until: str | None,
        name: str,
    ):
        """Move ``tcp`` to one of the candidate poses ``T_world_targets`` (S, 4, 4) - the
        first that a joint move reaches nearest in time (or, for a line, the one nearest the
        tool's orientation) - and record it; the segment (None: already there)."""
        dev = self.run.cell.devices[device]
        q_now = self.world.joints(device)
        try:
            mount = ToolMount(*self.world.mount_of(device, tcp))
        except UserError as exc:
            self.fail(device, step, exc.message)
        T_base = np.linalg.inv(self.world.T_world(device)) @ T_world_targets
        position_only = step.spec.position_only if step.kind == "move" else False
        position_only = position_only or dev.dof < 6
        if motion == "joint":
            seg = self._joint_to(
                device,
                tr,
                step,
                dev,
                mount,
                q_now,
                T_base,
                position_only,
                name,
                tcp,
                speed,
                acceleration,
            )
        else:
            if len(T_base) > 1:  # the candidate nearest the tool's orientation now
                R_now = tool_pose(dev, q_now, mount)[:3, :3]
                turn = np.einsum("ij,sij->s", R_now, T_base[:, :3, :3])  # trace(R_now^T R_s)
                T_base = T_base[[int(np.argmax(turn))]]
            try:
                seg = linear_move(
                    dev,
                    mount,
                    tr.t,
                    q_now,
                    T_base[0],
                    self.run.dt,
                    speed,
                    acceleration,
                    position_only,
                )
            except PathError as exc:
                if exc.reason == "samples":  # too slow to simulate: bad input, not a fail
                    self._too_long(device, step, exc.detail, speed)
                self.unreachable(device, step, exc.detail)
            wanted = step.configuration
            if wanted:
                end = seg.q_end if seg is not None else q_now
                have = arm_configurations(dev, end).names()
                if any(have[k] != v for k, v in wanted.items()):
                    self.fail(
                        device,
                        step,
                        f"the line ends with {_said(have)}, not {_said(wanted)}: a straight "
                        "line keeps the configuration it starts in; reach the start with a "
                        "joint move in the configuration wanted",
                    )
        return self._record_move(
            device, tr, step, q_now, seg, seg, name, tcp, until, motion, speed, acceleration
        )

    def _joint_to(
        self,
        device,
        tr,
        step,
        dev,
        mount,
        q_now,
        T_base,
        position_only,
        name,
        tcp,
        speed,
        acceleration,
    ):
        """A joint move to the candidate pose reached soonest (one IK per candidate, the
        step's configuration asked for)."""
        wanted = step.configuration
        accept = None
        if wanted:

            def accept(Q, dev=dev, wanted=wanted):
                return arm_configurations(dev, Q).matches(wanted)

        seed = q_now if step.near is None else step.near
        if self._transit_near is not None:  # a feature step's transit: the joints it planned
            seed = self._transit_near
        if step.arm_angle is not None:  # a 7-axis arm's arm angle (config: {arm_angle})
            from ..kinematics.redundancy import solve_ik_arm_angle

            for T in T_base:  # the candidates in their order (a free turn: the first that is)
                held = solve_ik_arm_angle(dev, T, step.arm_angle, mount, seed)
                if held is not None:
                    return self._joint_move(device, tr, step, q_now, held, speed, acceleration)
            self.unreachable(
                device,
                step,
                f"no joint solution within the limits reaches '{name}' with the arm angle "
                f"{np.degrees(step.arm_angle):.6g} deg",
            )
        if len(T_base) == 1:
            result = solve_ik(dev, T_base[0], mount, seed, position_only, accept=accept)
            best = result.q if result.success else None
            if best is not None and step.kind == "move" and not step.touch and step.near is None:
                best = self._clear_solution(
                    device,
                    tr,
                    step,
                    dev,
                    mount,
                    q_now,
                    T_base[0],
                    position_only,
                    best,
                    accept,
                    name,
                )
        else:
            best, result = None, None
            Q, ok, order = solve_ik_soonest(dev, T_base, q_now, mount, position_only, seed, accept)
            if ok.any():
                reached = [int(k) for k in order if ok[k]]
                best = Q[reached[0]]
                if step.goal is not None and not step.touch:  # a free turn: one that is clear
                    best = Q[self._clear_turn(device, tr, step, q_now, Q, reached)]
            else:  # from the joints now no candidate converged: restarts, nearest turn first
                for T in T_base:
                    result = solve_ik(dev, T, mount, seed, position_only, accept=accept)
                    if result.success:
                        best = result.q
                        break
        if best is None:
            if wanted:
                anyhow = solve_ik(dev, T_base[0], mount, seed, position_only)
                if anyhow.success:
                    have = arm_configurations(dev, anyhow.q).names()
                    self.unreachable(
                        device,
                        step,
                        f"no joint solution within the limits reaches '{name}' with "
                        f"{_said(wanted)} (one with {_said(have)} does)",
                    )
            if result is None:
                result = solve_ik(dev, T_base[0], mount, seed, position_only)
            self.unreachable(
                device,
                step,
                result.unreachable(name, tcp, [j.name for j in dev.joints], position_only),
            )
        return self._joint_move(device, tr, step, q_now, best, speed, acceleration)

    def _path_of(self, step) -> str:
        """A step's ``path:``: its own when it gives one (or a path file), else the run's
        default (``paths:``) - never for a linear or guarded move, nor one that may touch
        (``touch:``: contact is its point, and the planner avoids it)."""
        spec = step.spec
        if self._transit:  # a feature step's transit: planned unless the step says straight
            explicit = "path" in getattr(spec, "model_fields_set", ())
            return "straight" if explicit and spec.path == "straight" else "free"
        path = getattr(spec, "path", "straight")
        if path not in ("straight", "free") or "path" in getattr(spec, "model_fields_set", ()):
            return path
        if step.kind == "move" and (
            spec.motion == "linear" or spec.until is not None or step.touch
        ):
            return "straight"
        return self.run.paths

    def _checker_at(self, device: str, t: float, q):
        """A ``ConfigurationChecker`` of ``device`` in the world at instant ``t`` (the other
        devices where their programs have them, the affixments of the moment), the device
        at ``q``: collisions by the run's tolerance (what a turn or a route is chosen by; a
        required clearance is the check's to report, not a reason to refuse a step)."""
        from ..collision.configurations import ConfigurationChecker

        return ConfigurationChecker(
            self.world,
            self._world_at(device, t, q),
            device,
            tolerance=self.run.collision_tolerance,
        )

    def _world_at(self, device: str, t: float, q):
        """The world at instant ``t`` with ``device`` at ``q``; returns the collision model
        (built by the first caller)."""
        from ..collision.bodies import collision_model

        if self._collisions is None:
            self._collisions = collision_model(self.run.cell)
        self.set_time(t)
        self.world.set_joints(device, q)
        return self._collisions

    def _clear_solution(
        self, device, tr, step, dev, mount, q_now, T_base, position_only, best, accept, name
    ):
        """The joint solution a move takes: ``best`` (the one IK reached from the seed) when
        its move collides with nothing, else the soonest reached of the target's other
        solutions (other arm configurations, found from :data:`IK_STARTS` seeded starts;
        the configuration asked for, if any) whose move is clear.  None clear: ``best``,
        with a warning naming each solution tried and its first contact (the check then
        reports the collision, and the run can be watched)."""
        from ..kinematics.inverse import distinct_solutions
        from ..planning.motion import sampled_box

        checker = self._checker_at(device, tr.t, q_now)  # the world now, for every solution
        hit = self._joint_line_collision(checker, step, q_now, best)
        if hit is None:
            return best
        rng = np.random.default_rng(step.index)
        lo, hi = (sampled_box(dev.limit_array(side)) for side in ("lower", "upper"))
        starts = np.concatenate(
            [np.asarray(best, dtype=float)[None], rng.uniform(lo, hi, (IK_STARTS, dev.dof))]
        )
        found = distinct_solutions(dev, T_base, starts, mount, position_only, accept)
        found = found[np.abs(found - best).max(axis=1) > 1e-3]  # best is tried already
        v = dev.limit_array("velocity")
        v = np.where(np.isfinite(v) & (v > 0), v, 1.0)
        others = sorted(found, key=lambda q: float(np.max(np.abs(q - q_now) / v)))
        tried = [(np.asarray(best, dtype=float), hit)]
        for q in others:
            hit = self._joint_line_collision(checker, step, q_now, q)
            if hit is None:
                return q
            tried.append((q, hit))
        words = [
            f"{_said(arm_configurations(dev, q).names()) if is_arm(dev) else f'solution {k + 1}'}"
            f": {why}"
            for k, (q, why) in enumerate(tried)
        ]
        self.warn(
            device,
            tr,
            step,
            f"no joint solution for '{name}' is reached without a collision (the "
            f"first is taken, and the check reports it); tried {len(tried)}: " + "; ".join(words),
        )
        return best

    def _clear_turn(self, device, tr, step, q_now, Q, reached: list[int]) -> int:
        """Of the free turns reached (``reached``: indices into Q, soonest first), the first
        whose joint move from ``q_now`` collides with nothing (the continuous segment check;
        for ``path: free`` its end state alone, free and touching nothing: the planner finds
        the way).  None clear: the soonest, with a warning naming each turn tried and its
        collision (the check reports it)."""
        hits = []
        checker = self._checker_at(device, tr.t, q_now)  # the world now, for every turn
        for k in reached:
            hit = self._joint_line_collision(checker, step, q_now, Q[k])
            if hit is None:
                return k
            hits.append(f"{self._turn_words(step.goal, [k])[0]}: {hit}")
        self.warn(
            device,
            tr,
            step,
            f"no turn about {step.goal.feature} is reached without a collision (the soonest is "
            f"taken, and the check reports it); tried {len(hits)}: " + "; ".join(hits),
        )
        return reached[0]

    def _joint_line_collision(self, checker, step, q0, q1) -> str | None:
        """Whether the joint move q0 -> q1 (its end alone, for ``path: free``) collides
        (``checker``: :meth:`_checker_at` the move's start): None, or the collision in words."""
        from ..planning.motion import first_contact_words, nearest_words

        if self._path_of(step) == "free":
            report = checker.check(np.asarray(q1)[None])
            if report.free[0] and report.distance[0] >= 0.0:
                return None
            return nearest_words(checker, report, 0)
        found = checker.check_segment(q0, q1)
        return None if found.free else first_contact_words(checker, found)

    def _record_move(
        self,
        device,
        tr,
        step,
        q_now,
        seg,
        planned,
        name,
        tcp=None,
        until=None,
        motion="joint",
        speed=None,
        acceleration=None,
        via=None,
    ):
        """Guard, resolve and time a move's segment (None: already there); returns it.  A
        joint move with ``path: free`` goes through the via points of a collision-free path
        (:meth:`_free_path`), each recorded as a joint move of its own (``via``: a leg of a
        path timed as one, its via point and blend as :meth:`_timed_legs` gives them)."""
        if (
            seg is not None
            and motion == "joint"
            and step.kind in ("move", "insert", "place", "follow", "probe")  # approach moves
            and self._path_of(step) == "free"
            and not self._in_free_path
        ):
            return self._free_path(device, tr, step, q_now, seg, name, tcp, speed, acceleration)
        if seg is not None and not (seg.t1 - seg.t0) / self.run.dt <= MAX_SAMPLES:
            T = seg.t1 - seg.t0
            self._too_long(
                device,
                step,
                f"the move takes {T:.4g} s: {T / self.run.dt:.3g} clock samples at dt "
                f"{self.run.dt:g} s, above the bound of {MAX_SAMPLES:,}",
                step.spec.speed if speed is None else speed,
            )
        if seg is not None and until is not None:
            seg = self._guard(device, tr, step, seg, until)
        spec = step.spec
        target = self._target(
            device,
            tr,
            step,
            q_now,
            seg,
            planned,
            name,
            tcp or self._resolve_tcp(device, getattr(spec, "tcp", None)),
            motion,
            spec.speed if speed is None else speed,
            spec.acceleration if acceleration is None else acceleration,
            until,
            via,
        )
        self._actions.append(ResolvedStep(step, target.t0, target))
        if seg is None:
            self.events.append(
                Event(tr.t, device, step.index, "move", f"{step.describe()}: already there")
            )
            return None
        tr.segments.append(seg)
        took, words = self._configuration_taken(device, seg.q_end)
        via = f", {self._free_leg}" if self._in_free_path and self._free_leg else ""  # its leg
        self.events.append(
            Event(
                tr.t,
                device,
                step.index,
                "move",
                f"{step.describe()}{via} ({seg.t1 - seg.t0:.3f} s{words})",
                reading={"configuration": took} if took else None,
            )
        )
        tr.t = seg.t1
        return seg

    def _free_path(self, device, tr, step, q_now, seg, name, tcp, speed, acceleration):
        """``move: {..., path: free}``: a collision-free joint path from the joints now to the
        move's end (``planning.motion.plan_in_world``: in the world at this instant - other
        devices where their programs have them, grasps, tools, calibrated poses; the run's
        clearance (none: the path keeps ``PATH_CLEARANCE`` where its ends leave room) and
        collision tolerance; the step's or the run's seed and timeout
        (:meth:`_planner_settings`); its corners blended
        where the blends are free), driven through its via points without stopping at the
        blended ones (:meth:`_drive_through`).  No path: the target is unreachable (exit 1),
        with the planner's reason."""
        from ..planning.motion import PATH_CLEARANCE, plan_in_world

        seed, timeout = self._planner_settings(step)
        plan, _ = plan_in_world(
            self.world,
            self._world_at(device, tr.t, q_now),
            device,
            q_now,
            seg.q_end[None],
            tolerance=self.run.collision_tolerance,
            clearance=self.run.clearance,
            # none asked of the run: the path keeps 1 mm where its ends leave room
            kept=self.run.clearance or PATH_CLEARANCE,
            seed=seed,
            timeout=timeout,
        )
        if not plan.found:
            hint = ""
            if plan.outcome == "timeout":
                hint = f" ({timeout:g} s; 'timeout:' on the step or the run gives it longer)"
            raise NoFreePath(
                f"{step.where}: {device} step {step.index + 1} ({step.describe()}): no "
                f"collision-free path to '{name}': {plan.reason}{hint}"
                f"{self._calibrated_near(plan.bodies)}",
                str(plan.reason),
            )
        return self._drive_through(
            device, tr, step, plan.waypoints, name, tcp, speed, acceleration, plan.blends
        )

    def _calibrated_near(self, bodies: list[str]) -> str:
        """What a calibration moved that bears on a failed plan, in words ('' when the cell
        has no calibrated pose): the calibrated frames that carry a body the failing segment
        met first, then the others by how far they moved (five at most), with the overlay."""
        moved = self.run.cell.calibrated
        if not moved:
            return ""
        known = set(self.world.frames)  # a body's label is its frame
        carriers = {b: set(self.world.ancestors(b)) if b in known else set() for b in bodies}
        carries = {f: [b for b in bodies if f in carriers[b]] for f in moved}
        order = sorted(moved, key=lambda f: (not carries[f], -moved[f][1]))
        said = []
        for frame in order[:5]:
            _, shift, turn = moved[frame]
            words = f"{frame} by {shift * 1000:.3g} mm, {np.degrees(turn):.3g} deg"
            if carries[frame]:
                words += f" (it carries {', '.join(carries[frame])}, met here)"
            said.append(words)
        more = f" and {len(order) - 5} more" if len(order) > 5 else ""
        files = ", ".join(sorted({str(source.name) for source, _, _ in moved.values()}))
        return f"; the calibration ({files}) moved {'; '.join(said)}{more}"

    def _planner_settings(self, step) -> tuple[int, float]:
        """(seed, timeout [s]) of a step's planned path: the step's own (``seed:``,
        ``timeout:``), else the run's seed plus the step's index and the run's timeout."""
        seed = getattr(step.spec, "seed", None)
        timeout = getattr(step.spec, "timeout", None)
        return (
            self.run.seed + step.index if seed is None else int(seed),
            self.run.timeout if timeout is None else float(timeout),
        )

    def _drive_through(self, device, tr, step, way, name, tcp, speed, acceleration, blends=None):
        """Drive through the states ``way`` (W, n) - a planned path's or a path file's - each
        leg (via point to via point) recorded as a move of the step, its event naming the leg;
        returns the last.  One leg: a joint move.  More: the whole path timed as one
        (:meth:`_timed_legs`), through each corner ``blends`` (W,) blends without stopping,
        at rest at the others.  A via point that repeats the one before (a path file driven
        from where the device already is) is dropped with its blend."""
        way = np.asarray(way, dtype=float)
        keep = np.r_[True, np.abs(np.diff(way, axis=0)).max(axis=1) > 1e-12]
        if not keep.all():
            way = way[keep]
            blends = None if blends is None else np.asarray(blends, dtype=float)[keep]
            if blends is not None:
                blends[[0, -1]] = 0.0  # the ends are at rest
            if len(way) == 1:  # already at the path's end
                way = np.stack([way[0], way[0]])
        legs = self._timed_legs(device, step, tr.t, way, blends, speed, acceleration)
        self._in_free_path = True
        try:
            last = None
            for k in range(1, len(way)):
                if legs is None:
                    piece = self._joint_move(
                        device, tr, step, way[k - 1], way[k], speed, acceleration
                    )
                    via = None
                else:
                    piece, via = legs[k - 1]
                leg = f"via point {k} of {len(way) - 2}" if k < len(way) - 1 else "last leg"
                leg = leg if len(way) > 2 else ""  # the straight line was free: one move
                self._free_leg = leg
                label = name if k == len(way) - 1 else f"{name} ({leg})"
                last = self._record_move(
                    device,
                    tr,
                    step,
                    way[k - 1],
                    piece,
                    piece,
                    label,
                    tcp,
                    None,
                    "joint",
                    speed,
                    acceleration,
                    via,
                )
        finally:
            self._in_free_path = False
        return last

    def _timed_legs(self, device, step, t0, way, blends, speed, acceleration):
        """The legs of the path through ``way`` (W > 2 states) timed as one, starting at
        ``t0``: ``planning.topp``'s time-optimal timing of the ``blended`` path (straight
        joint lines, corners cut by ``blends``; all 0 or None: at rest at every via point)
        under the joints' velocity and acceleration limits times the step's speed and
        acceleration fractions, and their torque limits where the cell gives them (what the
        device carries now on its links; no friction: the run's overload check sees it).
        A list of (PathLeg, (via point, blend fraction, the blend's two ends, the fractions of
        the legs before and after it the blend takes)) - the leg ends
        where the path passes its via point's knot (the middle of its blend) - or None for a
        single leg."""
        if len(way) <= 2:
            return None
        from ..motion.trajectory import PathLeg
        from ..planning.path import JointPath, blend_corners, blend_half_widths
        from ..planning.topp import InfeasiblePath, Limits, sample_path, time_optimal

        dev = self.run.cell.devices[device]
        speed = step.spec.speed if speed is None else speed
        acceleration = step.spec.acceleration if acceleration is None else acceleration
        blends = np.zeros(len(way)) if blends is None else np.asarray(blends, dtype=float)
        path = JointPath(way, None, "blended", blends)
        effort = dev.limit_array("effort")
        dynamics = gravity = None
        if np.isfinite(effort).any():
            dynamics = DeviceDynamics(
                dev, friction=False, link_loads=self.world.carried_loads(device)
            )
            gravity = self.world.T_world(device)[:3, :3].T @ self.run.cell.gravity
        limits = Limits(
            dev.limit_array("velocity") * speed,
            dev.limit_array("acceleration") * acceleration,
            effort if dynamics is not None else None,
        )
        if not np.isfinite(limits.acceleration).any():
            names = ", ".join(j.name for j in dev.joints)
            self.fail(
                device,
                step,
                f"nothing times this path: its joints ({names}) have no acceleration limit; "
                "add one to the cell",
            )
        try:
            timing, _ = time_optimal(path, limits, dynamics, gravity)
        except InfeasiblePath as exc:
            self.fail(device, step, f"no timing of the path keeps the joints' limits: {exc}")

        def sampler(times):
            rows = sample_path(path, timing, np.asarray(times, dtype=float) - t0)
            return rows.q, rows.qd, rows.qdd

        # when the path passes each via point's knot (s rises with t: invert by interpolation)
        at = t0 + np.interp(path.knots, timing.s, timing.t)
        at[0], at[-1] = t0, t0 + timing.duration
        controls = blend_corners(path.knots, way, blends)  # (W, 3, n): each blend's ends
        h = np.diff(path.knots)
        tau = blend_half_widths(path.knots, blends)
        before, after = tau[1:] / h, np.r_[tau[1:-1] / h[1:], 0.0]  # of leg k-1, of leg k
        return [
            (
                PathLeg(float(at[k - 1]), float(at[k]), sampler),
                (
                    way[k],
                    float(blends[k]),
                    controls[k, 0],
                    controls[k, 2],
                    float(before[k - 1]),
                    float(after[k - 1]),
                ),
            )
            for k in range(1, len(way))
        ]

    def _configuration_taken(self, device: str, q) -> tuple[dict | None, str]:
        """A 6-axis arm's configuration at ``q``: rworld's words, and the text for the move's
        event - those words and the controller's (KUKA S/T, ABB confdata, FANUC CONFIG)."""
        dev = self.run.cell.devices[device]
        if not is_arm(dev):
            from ..kinematics.redundancy import arm_angle, is_seven_axis_arm

            if is_seven_axis_arm(dev):
                psi = float(np.degrees(arm_angle(dev, np.asarray(q)[None])[0]))
                return {"arm_angle_deg": psi}, f"; arm angle {psi:.2f} deg"
            return None, ""
        names = arm_configurations(dev, q).names()
        profile = dev.controller
        axes = profile.axes(q) if profile is not None else np.asarray(q)
        vendor = vendor_words(profile.vendor if profile is not None else None, axes, names)
        took = {**names, **({"controller": vendor} if vendor else {})}
        words = "; " + ", ".join(f"{k} {v}" for k, v in names.items())
        return took, words + (f"; {vendor}" if vendor else "")

    def _target(
        self,
        device,
        tr,
        step,
        q_now,
        seg,
        planned,
        name,
        tcp,
        motion,
        speed,
        acceleration,
        until,
        via=None,
    ) -> MoveTarget:
        """The resolved move, for exporters: the TCP steered, where the joints ended (a leg
        of a path timed as one: its via point, ``via``), the TCP pose there in the base
        frame; a blended via point's blend (the joint and TCP distances from the via point
        at which its blend leaves and joins the lines, the smaller side)."""
        dev = self.run.cell.devices[device]
        link, T_link_tcp = self.world.mount_of(device, tcp)
        q_goal = np.array(q_now if seg is None else seg.q_end, dtype=float)
        q_planned = np.array(q_now if planned is None else planned.q_end, dtype=float)
        mount = ToolMount(link, T_link_tcp)
        blend = None
        if via is not None:
            q_goal = q_planned = np.array(via[0], dtype=float)
            corner, fraction, p0, p2, before, after = via
            if fraction > 0:
                tcp_at = tool_pose(dev, np.stack([p0, corner, p2]), mount)[..., :3, 3]
                blend = BlendZone(
                    fraction,
                    before,
                    after,
                    float(min(np.abs(corner - p0).max(), np.abs(p2 - corner).max())),
                    float(
                        min(
                            np.linalg.norm(tcp_at[1] - tcp_at[0]),
                            np.linalg.norm(tcp_at[2] - tcp_at[1]),
                        )
                    ),
                )
        T_base_tcp = tool_pose(dev, q_goal, mount)
        return MoveTarget(
            motion,
            name,
            tcp,
            link,
            np.asarray(T_link_tcp, dtype=float),
            np.array(q_now, dtype=float),
            q_goal,
            T_base_tcp,
            tr.t,
            tr.t if seg is None else seg.t1,
            speed,
            acceleration,
            until,
            q_planned,
            tool_pose(dev, q_planned, mount),
            blend,
        )

    def _joint_move(
        self, device: str, tr: Track, step: Step, q_now, q_goal, speed=None, acceleration=None
    ):
        """A synchronised joint move; a joint with no velocity or acceleration limit is
        unlimited in it, alone.
        """
        dev = self.run.cell.devices[device]
        try:
            return joint_move(
                tr.t,
                q_now,
                q_goal,
                dev.limit_array("velocity"),
                dev.limit_array("acceleration"),
                step.spec.speed if speed is None else speed,
                step.spec.acceleration if acceleration is None else acceleration,
            )
        except UntimedMove as exc:
            names = ", ".join(dev.joints[j].name for j in exc.joints)
            self.fail(
                device,
                step,
                f"nothing times this move: the joints that move ({names}) have no acceleration "
                "limit; "
                "add one to the cell",
            )


def _said(configuration: dict[str, str]) -> str:
    """{'elbow': 'up', 'wrist': 'noflip'} as 'elbow up, wrist noflip'."""
    return ", ".join(f"{k} {v}" for k, v in configuration.items())

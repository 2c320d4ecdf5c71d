"""Program steps on features, resolved when they run (``docs/programs.md``).

Every target here is a frame on a feature (``world.feature_targets``) placed by the feature
owner's pose *now*: the pose files, a calibration overlay included, and the affixments of the
moment.  A calibration that moves the owner moves every target on its features by exactly its
correction; no frame is placed by hand beside a feature.

The steps are methods of the scheduler (``engine._Scheduler``), which owns the world, the
tracks and the move machinery (``_go``, ``_record_move``, the guard).  A step that makes
several moves records each as a resolved move of the same program line: the exporters write
them all.
"""

from __future__ import annotations

import numpy as np

from ..errors import UserError
from ..kinematics.inverse import solve_ik_soonest
from ..kinematics.jacobian import ToolMount, reach_bound
from ..units import LINEAR_ACCELERATION, LINEAR_SPEED
from ..world.feature_targets import (
    SPINS,
    along,
    feature_frame,
    outward_frame,
    plane_coordinates,
    spun,
)
from .errors import NoFreePath, UnreachableTarget


class FeatureSteps:
    """The feature steps of the scheduler (a mixin: ``self`` is an ``engine._Scheduler``)."""

    # ------------------------------------------------------------------ targets
    def _toward(self, owner: str) -> np.ndarray:
        """A line's material side: the owner's centre of mass (owner frame)."""
        obj = self.run.cell.objects.get(owner)
        return np.zeros(3) if obj is None else np.asarray(obj.inertial.com, dtype=float)

    def _spins(self, goal) -> np.ndarray:
        return SPINS if goal.spin is None else np.array([goal.spin])

    def _owner_targets(self, goal, at=None, standoff=None) -> np.ndarray:
        """``T_world_target`` of every spin candidate on the goal's feature (S, 4, 4)."""
        f = self.run.cell.features[goal.feature]
        at = goal.at if at is None else at
        if isinstance(at, str):  # another feature of the owner: its point on the plane
            at = plane_coordinates(f, self.run.cell.features[at].point)
        T_owner = feature_frame(
            f,
            at,
            goal.standoff if standoff is None else standoff,
            self._toward(f.owner),
        )
        return self.world.T_world(f.owner) @ spun(T_owner, f.kind, self._spins(goal))

    def _within_reach(self, device: str, step, tcp: str, T_world_targets: np.ndarray) -> None:
        """A target beyond any reach of the device (its standoff or ``at`` put it there) is
        bad input: exit 2 at the feature's place in the program."""
        dev = self.run.cell.devices[device]
        bound = reach_bound(dev, ToolMount(*self.world.mount_of(device, tcp)))
        base = self.world.T_world(device)[:3, 3]
        far = float(np.linalg.norm(T_world_targets[0, :3, 3] - base))
        if far > bound:
            raise UserError(
                f"{step.goal.where}: {device} step {step.index + 1} ({step.describe()}): the "
                f"target is {far * 1000:.0f} mm from {device}'s base, beyond its reach "
                f"({bound * 1000:.0f} mm at most): the standoff or position leaves the workspace"
            )

    def _feature_targets(self, device: str, step) -> np.ndarray:
        """A move's candidate targets on its feature, checked for reach."""
        targets = self._owner_targets(step.goal)
        self._within_reach(device, step, self._resolve_tcp(device, step.spec.tcp), targets)
        return targets

    def _held(self, device: str, step, feature: str) -> tuple[str, np.ndarray]:
        """(the TCP holding the feature's object, ``T_tcp_feature`` of its outward frame)."""
        f = self.run.cell.features[feature]
        if not self._held_by(device, f.owner):
            self.fail(device, step, f"{device} does not hold '{f.owner}' ({feature} is on it)")
        tcp = self.world.affixment(f.owner).parent  # held: the frame it is affixed to
        return tcp, self.world.T(tcp, f.owner) @ outward_frame(f)

    def _through(self, device, tr, step, tcp, routes, speeds, until=None, turns=None, clear=True):
        """Run the first route whose moves all work and collide with nothing: each route a
        list of (motion, ``T_world_tcp``); the first move a joint move, the others straight
        lines at ``speeds[k]``.  A route that fails (no solution, a line out of the
        workspace) or whose moves collide (:meth:`_route_collision`: a link into another, the
        wrist through the table) gives way to the next, in the order given (soonest reached
        first).  When none is reachable: the first's failure; when every reachable one
        collides: the first reachable is driven (``clear`` False: no route check), with a
        warning naming each turn tried (``turns``: their labels) and what stopped it - the
        check then reports the collision, and the run can be watched."""
        first_error = None
        tried: list[str] = []
        reachable = None  # the first route whose moves work, collisions aside
        checker = None  # the world at the routes' start, built by the first route checked
        turns = turns or [f"route {k + 1}" for k in range(len(routes))]
        for route, turn in zip(routes, turns):
            mark = (tr.t, len(tr.segments), len(self._actions), len(self.events))
            q_mark = self.world.joints(device).copy()
            try:
                for n, ((motion, T), speed) in enumerate(zip(route, speeds)):
                    self.set_time(tr.t)
                    last = n == len(route) - 1
                    self._go(
                        device,
                        tr,
                        step,
                        tcp,
                        T[None],
                        motion,
                        speed,
                        1.0,
                        until if last else None,
                        step.goal.feature,
                    )
                if not clear:
                    return
                checker = checker or self._checker_at(device, mark[0], q_mark)
                hit = self._route_collision(checker, tr.segments[mark[1] :])
                if hit is None:
                    return
                tried.append(f"{turn}: {hit}")
                reachable = reachable or (route, turn)
            except NoFreePath as exc:
                first_error = first_error or exc
                tried.append(f"{turn}: no free path ({exc.reason})")
            except UnreachableTarget as exc:
                first_error = first_error or exc
                tried.append(f"{turn}: unreachable")
            tr.t = mark[0]
            del tr.segments[mark[1] :], self._actions[mark[2] :], self.events[mark[3] :]
            self.set_time(tr.t)
            self.world.set_joints(device, q_mark)
        if reachable is None:
            assert first_error is not None  # every route raised
            if not any(": no free path (" in t for t in tried):
                raise first_error
            raise UnreachableTarget(  # the planner's reason for each turn it could not serve
                f"{step.where}: {device} step {step.index + 1} ({step.describe()}): no turn "
                f"about the feature has a collision-free approach; tried {len(tried)}: "
                + "; ".join(tried)
            )
        # every reachable route collides: the first is driven, the check reports it
        self.warn(
            device,
            tr,
            step,
            f"no turn about {step.goal.feature} works without a collision (the first reached, "
            f"{reachable[1]}, is taken, and the check reports it); tried {len(tried)}: "
            + "; ".join(tried),
        )
        self._through(device, tr, step, tcp, [reachable[0]], speeds, until, [reachable[1]], False)

    def _route_collision(self, checker, segments) -> str | None:
        """Whether a route's moves (``segments``) collide in the world as it is at their start
        (``checker``: :meth:`_checker_at` there) - the rule of ``rworld check`` (no overlap
        deeper than the run's tolerance, nothing buried; a required clearance is the check's
        to report): joint moves by the continuous segment check, straight lines at their
        samples; a planned path's legs were proved free by the planner in this world (its
        continuous checks of lines and blends).  None, or
        the first collision in words ('link_2_l into link_4_r at 40 % of the move')."""
        from ..motion.trajectory import JointMove, PathLeg
        from ..planning.motion import first_contact_words

        for n, seg in enumerate(segments):
            if isinstance(seg, PathLeg):
                continue
            if isinstance(seg, JointMove):
                report = checker.check_segment(seg.q_start, seg.q_end)
                if not report.free:
                    return first_contact_words(checker, report)
                continue
            times = np.append(np.arange(seg.t0, seg.t1, self.run.dt), seg.t1)
            Q = seg.sample(times)[0]
            free = checker.free(Q)
            if not free.all():
                report = checker.check(Q[int(np.argmin(free))][None])
                i, j = report.pair[0]
                bodies = checker.model.bodies
                return f"{bodies[i].label} into {bodies[j].label} on straight move {n}"
        return None

    def _turn_words(self, goal, order) -> list[str]:
        """The turns about the feature, as the messages name them ('spin 45 deg')."""
        spins = self._spins(goal)
        return [f"spin {np.degrees(spins[k]):.0f} deg" for k in order]

    def _ranked(self, device, step, tcp, T_world_first: np.ndarray) -> list[int]:
        """Spin candidates in the order a joint move reaches their first pose soonest; those
        the device cannot reach last (they fail with the reason)."""
        if len(T_world_first) == 1:
            return [0]
        mount = ToolMount(*self.world.mount_of(device, tcp))
        T_base = np.linalg.inv(self.world.T_world(device)) @ T_world_first
        _, _, order = solve_ik_soonest(
            self.run.cell.devices[device], T_base, self.world.joints(device), mount
        )
        return [int(k) for k in order]

    # ------------------------------------------------------------------ insert, place
    def _bring(self, device, tr, step, T_world_goal_frames, approach, speed, until, depth=0.0):
        """Bring the held feature (``step.goal.held``) onto one of the goal frames (S, 4, 4):
        a joint move to ``approach`` back along the frame's z, then a straight move in, to
        ``depth`` past the frame."""
        tcp, T_tcp_feature = self._held(device, step, step.goal.held)
        T_feature_tcp = np.linalg.inv(T_tcp_feature)
        ends = along(T_world_goal_frames, depth) @ T_feature_tcp
        starts = along(T_world_goal_frames, -approach) @ T_feature_tcp
        self._within_reach(device, step, tcp, starts)
        order = self._ranked(device, step, tcp, starts)
        routes = [[("joint", starts[k]), ("linear", ends[k])] for k in order]
        turns = self._turn_words(step.goal, order) if len(starts) > 1 else None
        self._through(device, tr, step, tcp, routes, [1.0, speed], until, turns)  # in at speed

    def _insert(self, device, tr, step) -> bool:
        goal = step.goal
        rims = self._owner_targets(goal)  # on the hole's axis at the rim, z into the hole
        self._bring(
            device, tr, step, rims, goal.approach, step.spec.speed, step.spec.until, goal.depth
        )
        return True

    def _place_face(self, device, tr, step) -> bool:
        """Set the held object's face down on a plane feature, then let it rest there."""
        goal = step.goal
        self._bring(
            device, tr, step, self._owner_targets(goal), goal.approach, step.spec.speed, None
        )
        held = self.run.cell.features[goal.held].owner
        owner = self.run.cell.features[goal.feature].owner
        self.set_time(tr.t)  # the world where the moves ended: the object rests from there
        return self._tree_change(
            device,
            tr,
            step,
            "place",
            held,
            lambda: self.world.attach(held, owner, "non_rigid", "rests_on"),
        )

    # ------------------------------------------------------------------ follow
    def _edge_extent(self, step) -> tuple[float, float]:
        """The followed stretch along the line [m]: the step's from/to, else where the line
        runs on its owner's material (the owner's mesh vertices within 0.5 mm of it)."""
        from ..geometry import shape_mesh

        goal = step.goal
        f = self.run.cell.features[goal.feature]
        start, end = goal.extent
        if start is None or end is None:
            owner = self.run.cell.objects.get(f.owner) or self.run.cell.devices.get(f.owner)
            shape = getattr(owner, "shape", None)
            if shape is None:
                raise UserError(
                    f"{goal.where}: '{f.owner}' has no geometry to find the ends of "
                    f"{goal.feature} on: give 'from' and 'to'"
                )
            w = shape_mesh(shape).vertices - f.point
            s = w @ f.direction
            near = np.linalg.norm(w - s[:, None] * f.direction, axis=1) < 5e-4
            if not near.any():
                raise UserError(
                    f"{goal.where}: {goal.feature} does not run along '{f.owner}''s material: "
                    "give 'from' and 'to'"
                )
            start = float(s[near].min()) if start is None else start
            end = float(s[near].max()) if end is None else end
        return start, end

    def _follow(self, device, tr, step) -> bool:
        goal = step.goal
        tcp = self._resolve_tcp(device, step.spec.tcp)
        if goal.speed > LINEAR_SPEED:
            raise UserError(
                f"{goal.where}: {goal.speed * 1000:g} mm/s is above the linear speed limit "
                f"({LINEAR_SPEED * 1000:g} mm/s)"
            )
        s0, s1 = self._edge_extent(step)
        a = self._owner_targets(goal, at=s0) @ step.T_offset
        b = self._owner_targets(goal, at=s1) @ step.T_offset
        start, end = along(a, -goal.approach), along(b, -goal.approach)
        self._within_reach(device, step, tcp, a)
        self._within_reach(device, step, tcp, b)
        order = self._ranked(device, step, tcp, start)
        fraction = goal.speed / LINEAR_SPEED
        routes = [
            [("joint", start[k]), ("linear", a[k]), ("linear", b[k]), ("linear", end[k])]
            for k in order
        ]
        turns = self._turn_words(goal, order)
        self._through(device, tr, step, tcp, routes, [1.0, 0.25, fraction, 0.25], turns=turns)
        # the speed held: the line along the edge took its trapezoid's time, no longer
        along_edge = self._actions[-2].move
        length = abs(s1 - s0)
        ramp = goal.speed / LINEAR_ACCELERATION
        ideal = (
            length / goal.speed + ramp
            if length > goal.speed * ramp
            else 2 * np.sqrt(length / LINEAR_ACCELERATION)
        )
        took = along_edge.t1 - along_edge.t0
        if took > ideal + 2 * self.run.dt + 1e-9:
            raise UnreachableTarget(
                f"{step.where}: {device} step {step.index + 1} ({step.describe()}): "
                f"{goal.speed * 1000:g} mm/s cannot be held along {goal.feature}: the joints' "
                f"limits stretch the {length * 1000:.1f} mm from {ideal:.3f} s to {took:.3f} s"
            )
        return True

    # ------------------------------------------------------------------ probe
    def _probe_moves(self, device, tr, step) -> bool:
        """The probing moves of a feature, as ``plan-measurements --program`` plans them: the
        points spread over the feature's material, each approached along its normal, touched
        by a guarded move and recorded; holes entered along their axis."""
        from ..calibration.plan import ProbeGeometry
        from ..calibration.probing import ProbeRig, find_probe
        from ..calibration.targets import (
            feature_candidates,
            fit_rows,
            spread_set,
            spread_warning,
        )

        goal, spec = step.goal, step.spec
        f = self.run.cell.features[goal.feature]
        try:
            tcp, sensor = find_probe(self.run.cell, device, spec.tcp, spec.sensor)
        except UserError as exc:
            self.fail(device, step, exc.message)
        rigs = self.__dict__.setdefault("_rigs", {})
        if (tcp, sensor) not in rigs:
            rigs[tcp, sensor] = ProbeRig(self.run.cell, device, tcp, sensor)
        rig = rigs[tcp, sensor]
        rig.seeds = [self.world.joints(device)]  # every search starts from where the arm is
        geometry = ProbeGeometry(radius=rig.radius)
        try:
            cand = feature_candidates(self.run.cell, f, rig.radius, geometry.edge_margin)
        except UserError as exc:
            raise UserError(f"{goal.where}: {exc.message}") from None
        T_world_owner = rig.world.T_world(f.owner)
        # the points spread for the fit: each the reachable candidate that adds most to the
        # fit's information (a face in two directions, a hole around its wall), the first the
        # farthest-point start
        rows = fit_rows(f, cand.points)
        pool = np.arange(len(cand))  # not yet tried
        solved, chosen, why = [], [], None
        while len(solved) < goal.points and len(pool):
            # the best set that keeps the points reached (the first: the farthest-point start)
            if chosen:
                wanted = spread_set(rows, goal.points, chosen, pool)
                k = wanted[len(chosen)] if len(wanted) > len(chosen) else int(pool[0])
            else:
                k = int(
                    pool[np.argmax(np.linalg.norm(cand.points[pool] - cand.points.mean(0), axis=1))]
                )
            pool = pool[pool != k]
            why = rig.solve(cand, k, T_world_owner)
            if why is None:
                solved.append(rig.solved[f.name, k])
                chosen.append(k)
        if len(solved) < goal.points:
            raise UnreachableTarget(
                f"{step.where}: {device} step {step.index + 1} ({step.describe()}): "
                f"{len(solved)} of {goal.points} points on {f.name} can be probed ({why})"
            )
        warning = spread_warning(f, cand.points[chosen])
        if warning is not None:  # what calibrate would say of these points, said now
            self.warn(device, tr, step, warning)
        T_world = self.world.T_world(f.owner)  # the owner now: its targets move with it
        first = solved[0]

        last: list = [None]

        def go(T_owner, motion="linear", until=None, speed=1.0):
            if until is None and last[0] is not None and np.allclose(last[0], T_owner, atol=1e-12):
                return  # already there: inside a hole, back at its centre before the next touch
            last[0] = T_owner
            self.set_time(tr.t)
            self._go(
                device, tr, step, tcp, (T_world @ T_owner)[None], motion, speed, 1.0, until, f.name
            )

        def transit(T_owner, q_near):
            # to the joints the rig solved (and checked the lines from): the straight joint
            # move where its states are clear, else a free path around what is in the way
            blocked = rig.transit_collides(self.world.joints(device), q_near)
            self._transit, self._transit_near = blocked, q_near
            try:
                go(T_owner, "joint")
            finally:
                self._transit, self._transit_near = False, None

        transit(first.T_owner_lift, first.q_lift)
        way_in = first.T_owner_entry if first.T_owner_entry is not None else first.T_owner_approach
        if not np.allclose(first.T_owner_lift, way_in):
            go(way_in)
        if first.T_owner_entry is not None:
            go(first.T_owner_approach)
        for s in solved:
            if s is not first:  # inside a hole: along its axis; else from point to point
                if first.T_owner_entry is not None:
                    go(s.T_owner_approach)
                else:
                    transit(s.T_owner_approach, s.q_approach)
            go(s.T_owner_end, until=sensor, speed=rig.speed)
            self._record_probe(device, tr, step, f.name)
            go(s.T_owner_approach)
        if first.T_owner_entry is not None:
            go(first.T_owner_entry)
        if not np.allclose(first.T_owner_lift, way_in):
            go(first.T_owner_lift)
        return True

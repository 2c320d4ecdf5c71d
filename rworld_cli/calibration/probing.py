"""The robot's side of probing: poses for each target, a short order, and the probe program.

A target (``targets.py``) is a ball centre at contact and the surface normal
there.  :class:`ProbeRig` turns it into poses of the probe TCP:

* planes, lines, points: the stylus (TCP +z) along ``-normal``; the
  **approach** pose ``approach`` out along the normal, the **contact** pose,
  and the guarded move's **end** ``overtravel`` past the nominal contact;
* holes and bosses: the stylus along ``-axis``; the **entry** above the rim
  on the axis, the approach on the axis at the probing depth (a boss: outside
  it), then sideways to the wall.

Each pose is solved by IK within the joint limits, for spins of the TCP
about the stylus in 30 degree steps (the first that works, nearest the start
configuration), and checked collision-free: the device's links against
every body they may not touch, in the cell's affixment tree, by exact
distance (the collision room's).  The reason a target fails names the figure:
the IK miss and the joints at their limits, or the colliding pair and depth.

The **order** visits the targets (a hole is one stop: all its points at one
depth) by nearest neighbour from the start position, improved by 2-opt, with
the joint-move time between approach poses as the distance (the largest
``|dq_j| / v_max_j``).

The **program** names the feature's owner and gives each pose as an offset in
the owner's frame, so a calibrated owner moves every target with it and the
program never changes; a guarded move ``until:`` the probe's touch sensor is
followed by ``probe: feature``, which records the contact.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

from .. import spatial
from ..errors import UserError
from ..kinematics.inverse import distinct_states, solve_ik
from ..kinematics.jacobian import ToolMount, reach_bound
from ..model.cell import CellModel
from ..world.tree import World
from .targets import Candidates

SPINS = np.radians([0, 60, -60, 120, -120, 180])  # the probe's turns about its stylus
RESTARTS = 16  # seeded random IK starts of a contact that no seed reaches clear
THOROUGH = 3  # the orientations tried with them (the first: what worked last, or upright)
TILTS = np.radians([0, 30, 50])  # the stylus tilted down from the normal, for side faces
# a line whose states 4 mm apart reach this Jacobian condition number may pass a singularity
# between two of them (a spherical wrist 0.1 deg from upright is about 2000): it is followed
# again every DENSE_STEP, as the simulator follows it, and refused where that fails (the
# wrist would flip)
LINE_CONDITION = 1e3
DENSE_STEP = 1e-4  # [m]
MAX_TURN = 50.0  # [rad/m]: 2.9 deg a mm, 720 deg/s at 250 mm/s, past the wrists' rates
SINGULAR = "passes a singularity"  # the words of a line refused for it


@dataclass
class Solved:
    """A target the robot can probe: TCP poses in the owner's frame and joint values."""

    feature: str
    index: int  # the candidate
    spin: float
    T_owner_approach: np.ndarray  # (4, 4): planes/lines: out along the normal; holes: the axis
    T_owner_contact: np.ndarray
    T_owner_end: np.ndarray  # the guarded move's end, past the nominal contact
    q_approach: np.ndarray
    T_owner_entry: np.ndarray | None = None  # holes and bosses: above the rim, on the axis
    q_entry: np.ndarray | None = None
    T_owner_lift: np.ndarray | None = None  # the way in and out, raised to the safe height
    q_lift: np.ndarray | None = None


@dataclass
class ProbeRig:
    """A device with a ball-tip touch probe on one of its TCPs, in a cell (nominal poses).

    Attributes
    ----------
    approach : float
        Ball travel before the nominal contact [m] (and the retract).
    overtravel : float
        How far past the nominal contact the guarded move may go [m]: more than the largest
        expected error of the world model.
    speed : float
        Guarded moves' fraction of the linear speed.
    clearance : float
        Required distance of the device's links from what they may not touch [m].
    """

    cell: CellModel
    device: str
    tcp: str
    sensor: str
    approach: float = 0.02
    overtravel: float = 0.004
    speed: float = 0.04
    clearance: float = 0.0
    start: str = "home"
    lift: float = 0.03  # [m]: transits between targets pass this far above the parts
    seeds: list = field(default_factory=list)  # joints to start IK from first (the arm's now)
    world: World = field(init=False)
    solved: dict = field(init=False, default_factory=dict)

    def __post_init__(self) -> None:
        from ..collision.allowed import allowed_pairs
        from ..collision.bodies import collision_model

        self.world = World(self.cell)
        dev = self.cell.devices[self.device]
        self.dev = dev
        self.mount = ToolMount(*self.world.mount_of(self.device, self.tcp))
        self.T_tcp_sensor = self.world.T(self.tcp, self.sensor)
        self.T_base_world = np.linalg.inv(self.world.T_world(self.device))
        self.q_start = np.array(
            dev.home if self.start == "home" else dev.positions[self.start], dtype=float
        )
        self.radius = float(self.cell.sensors[self.sensor].ball)
        tops = []
        for f in self.cell.features.values():
            owner = self.cell.objects.get(f.owner) or self.cell.devices.get(f.owner)
            if getattr(owner, "shape", None) is not None:
                box = owner.shape.bounding_box
                T = self.world.T_world(f.owner) @ box.T_owner_box
                corners = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
                tops.append(
                    float(((corners * box.half_extents) @ T[:3, :3].T + T[:3, 3])[:, 2].max())
                )
        self.safe_z = (max(tops) if tops else 0.0) + self.lift
        model = collision_model(self.cell)
        self.bodies = model.bodies
        allowed = allowed_pairs(self.world, model)
        mine = set(self.world.subtree(self.device))
        moving = [i for i, b in enumerate(self.bodies) if b.frame in mine]
        fixed = [i for i, b in enumerate(self.bodies) if b.frame not in mine]
        pairs = [
            (i, j)
            for i in moving
            for j in fixed + [k for k in moving if k > i]
            if (min(i, j), max(i, j)) not in allowed
        ]
        self.pairs = np.array(pairs, dtype=int).reshape(-1, 2)
        self.fixed = fixed
        self.T_box = np.array([b.shape.bounding_box.T_owner_box for b in self.bodies])
        self.half = np.array([b.shape.bounding_box.half_extents for b in self.bodies])
        self.centres = np.array([b.center for b in self.bodies]).reshape(-1, 3)
        self.radii = np.array([b.radius for b in self.bodies])
        self._hole_spin: dict[str, tuple] = {}
        self._last: dict[str, tuple] = {}  # per feature: stylus, spin, joints of the last success
        self._recent = None  # the joints of the last success of any feature
        self.reach = _reach_bound(dev, self.mount, self.T_tcp_sensor)
        self.T_world_base = self.world.T_world(self.device)
        self.vmax = np.where(
            np.isfinite(dev.limit_array("velocity")), dev.limit_array("velocity"), 1.0
        )

    # ------------------------------------------------------------------ poses
    def tcp_pose(self, centre: np.ndarray, stylus: np.ndarray, spin: float) -> np.ndarray:
        """``T_world_tcp`` putting the sensor origin (the ball's centre) at ``centre`` with the
        TCP's +z along ``stylus``, turned by ``spin`` about it."""
        z = stylus / np.linalg.norm(stylus)
        x0 = np.cross(z, [0.0, 0.0, 1.0] if abs(z[2]) < 0.9 else [1.0, 0.0, 0.0])
        x0 /= np.linalg.norm(x0)
        x = np.cos(spin) * x0 + np.sin(spin) * np.cross(z, x0)
        R = np.column_stack([x, np.cross(z, x), z])
        return spatial.make_transform(R, centre - R @ self.T_tcp_sensor[:3, 3])

    def ik(self, T_world_tcp: np.ndarray, seed: np.ndarray, restarts: int = 2):
        # from a good seed IK converges in a few iterations; 80 bounds the cost of a miss
        return solve_ik(
            self.dev,
            self.T_base_world @ T_world_tcp,
            self.mount,
            seed,
            restarts=restarts,
            max_iterations=80,
        )

    def collision(self, q: np.ndarray) -> str | None:
        """The first pair closer than the clearance at joint values ``q``, described; None."""
        from ..collision.bodies import distances
        from ..geometry import obb_overlap

        if not len(self.pairs):
            return None
        self.world.set_joints(self.device, q)
        T = {b.frame: self.world.T_world(b.frame) for b in self.bodies}
        I, J = self.pairs[:, 0], self.pairs[:, 1]
        TI = np.stack([T[self.bodies[i].frame] for i in I])
        TJ = np.stack([T[self.bodies[j].frame] for j in J])
        for cull in ("spheres", "boxes"):  # bounding spheres, then boxes, then the exact shapes
            if cull == "spheres":
                ci = np.einsum("kij,kj->ki", TI[:, :3, :3], self.centres[I]) + TI[:, :3, 3]
                cj = np.einsum("kij,kj->ki", TJ[:, :3, :3], self.centres[J]) + TJ[:, :3, 3]
                gap = np.linalg.norm(ci - cj, axis=1) - self.radii[I] - self.radii[J]
                near = gap <= self.clearance
            else:  # the report's second level: bounding boxes, by separating axes
                near = obb_overlap(
                    TI @ self.T_box[I],
                    self.half[I],
                    TJ @ self.T_box[J],
                    self.half[J],
                    self.clearance + 1e-9,
                )
            if not near.any():
                return None
            I, J, TI, TJ = I[near], J[near], TI[near], TJ[near]
        keep = np.array([self._near_mesh(i, j, Ti, Tj) for i, j, Ti, Tj in zip(I, J, TI, TJ)])
        if not keep.any():
            return None
        I, J, TI, TJ = I[keep], J[keep], TI[keep], TJ[keep]
        res = distances(self.bodies, I, J, TI, TJ)
        bad = np.flatnonzero((res.distance <= self.clearance) | res.buried)
        if not len(bad):
            return None
        k = bad[np.argmin(res.distance[bad] - res.depth[bad])]
        a, b = self.bodies[I[k]].label, self.bodies[J[k]].label
        if res.distance[k] > 0:
            return f"{a} comes within {res.distance[k] * 1000:.3g} mm of {b}"
        return f"{a} collides with {b} (depth {res.depth[k] * 1000:.3g} mm)"

    def _near_mesh(self, i: int, j: int, Ti: np.ndarray, Tj: np.ndarray) -> bool:
        """False when a mesh body (triangles) is farther than the clearance from the other
        body's bounding sphere and does not enclose its centre: no exact check needed."""
        from ..collision.bodies import point_triangle_distance
        from ..geometry import winding_number

        a, b = self.bodies[i], self.bodies[j]
        for mesh, other, Tm, To in ((a, b, Ti, Tj), (b, a, Tj, Ti)):
            if not mesh.is_mesh:
                continue
            centre = To[:3, :3] @ other.center + To[:3, 3]
            local = (centre - Tm[:3, 3]) @ Tm[:3, :3]
            tri = mesh.mesh().triangles()
            if point_triangle_distance(local, tri).min() > other.radius + self.clearance and not (
                mesh.shape.closed and winding_number(local[None], tri)[0] > 0.5
            ):
                return False
        return True

    # ------------------------------------------------------------------ one target
    def solve(self, cand: Candidates, k: int, T_world_owner: np.ndarray) -> str | None:
        """Solve target ``k`` of ``cand``; None when the robot can probe it (kept in
        ``solved``), else why not."""
        f = cand.feature
        R, t = T_world_owner[:3, :3], T_world_owner[:3, 3]
        centre = R @ cand.centres[k] + t
        normal = R @ cand.normals[k]
        if f.kind == "circle":
            stylus = -(R @ f.direction)
            axis_point = R @ (f.point - cand.depth * f.direction) + t
            if cand.boss:  # start outside the boss, out along the radial direction
                start = centre + self.approach * normal
            else:
                start = axis_point
            entry = R @ f.point + t + self.approach * (R @ f.direction)
            if cand.boss:
                entry = start + (cand.depth + self.approach) * (R @ f.direction)
            spins = [self._hole_spin[f.name]] if f.name in self._hole_spin else SPINS
        else:
            stylus = -normal
            start, entry = centre + self.approach * normal, None
            spins = SPINS
        end = centre - self.overtravel * normal
        distance = float(np.linalg.norm(centre - self.T_world_base[:3, 3]))
        if distance > self.reach:  # no pose can reach: say so without trying
            return (
                f"{f.name} target {k + 1} is {distance * 1000:.0f} mm from {self.device}'s base, "
                f"beyond its reach ({self.reach * 1000:.0f} mm at most)"
            )
        for point, what in ((start, "its approach would start"), (entry, "its entry is")):
            inside = None if point is None else self._ball_inside(point)
            if inside is not None:  # no pose can put the ball there: say so without trying
                return f"{f.name} target {k + 1}: {what} inside {inside}"
        why = "no spin of the probe about its stylus"
        best = None
        orientations = list(self._orientations(f.kind, stylus, spins))
        last = self._last.get(f.name)
        if last is not None:  # what worked on this feature's last target first, from its joints
            orientations.sort(
                key=lambda o: abs(o[1] - last[1]) + float(np.linalg.norm(o[0] - last[0]))
            )
        # where the search starts: the feature's last success, the joints given (where the arm
        # is at this step), the start position; then, for a target none of them reaches
        # clear, every IK branch from seeded restarts (the second pass)
        recent = self._recent  # the last target solved, of any feature: where the arm will be
        seeds = [None if last is None else last[2], recent, *self.seeds, self.q_start]
        seeds = list(distinct_states([q for q in seeds if q is not None], 1e-9))
        for thorough in (False, True):  # the second pass: the preferred orientations only
            for stylus_k, spin in orientations[:THOROUGH] if thorough else orientations:
                best, why_k = self._orientation(
                    f.name, k, stylus_k, spin, (centre, start, end, entry), seeds, thorough
                )
                if best is not None:
                    break
                why = why_k
            if best is not None:
                break
        if best is None and why is not None:
            why += (
                f" (IK from {len(seeds)} seed(s), then {RESTARTS} seeded restarts in the first "
                f"{min(THOROUGH, len(orientations))} of {len(orientations)} orientations)"
            )
        if best is None:
            return why
        spin, stylus, poses, qs, (T_lift, q_lift) = best
        self._last[f.name] = (stylus, spin, qs[1])
        self._recent = qs[1]
        if f.kind == "circle":
            self._hole_spin.setdefault(f.name, (spin, stylus))
        T_owner_world = np.linalg.inv(T_world_owner)
        self.solved[f.name, k] = Solved(
            f.name,
            k,
            float(spin),
            T_owner_world @ poses[0],
            T_owner_world @ poses[1],
            T_owner_world @ poses[2],
            qs[0],
            T_owner_world @ self.tcp_pose(entry, stylus, spin) if entry is not None else None,
            qs[3],
            T_owner_world @ T_lift,
            q_lift,
        )
        return None

    def _orientation(self, feature, k, stylus, spin, points, seeds, thorough: bool):
        """The poses and joints of target ``k`` with the stylus along ``stylus`` turned by
        ``spin``: (best, None) as :meth:`solve` keeps it, or (None, why not).  The contact from
        ``seeds`` in turn (``thorough``: every IK branch found from seeded restarts, nearest the
        first seed first), each collision-free; the approach, end and entry from the contact's
        joints; the straight lines the program drives (the way in, the entry to the approach,
        the guarded line) followed by IK from their start and checked collision-free, so that
        the program passes its own check."""
        centre, start, end, entry = points
        poses = [self.tcp_pose(p, stylus, spin) for p in (centre, start, end)]
        target = f"{feature} target {k + 1}"
        # the contact first (most targets fail there), then the approach, the end, the entry
        q_contact, why = self._contact(poses[0], seeds, target, thorough)
        if q_contact is None:
            return None, why
        q_start, why = self._at(poses[1], q_contact, 0, f"{feature} approach {k + 1}", target)
        if q_start is None:
            return None, why
        q_end, why = self._at(poses[2], q_contact, 0, f"{feature} guarded end {k + 1}")
        if q_end is None:
            return None, why
        q_entry, T_entry = None, None
        if entry is not None:
            T_entry = self.tcp_pose(entry, stylus, spin)
            q_entry, why = self._at(T_entry, q_start, 0, f"{feature} entry", target)
            if q_entry is None:
                return None, why
        way_in = T_entry if T_entry is not None else poses[1]
        q_in = q_entry if q_entry is not None else q_start
        T_lift, q_lift = way_in, q_in
        if self._ball_z(way_in) < self.safe_z:  # transits go in and out from above
            T_lift = way_in.copy()
            T_lift[2, 3] += self.safe_z - self._ball_z(way_in)
            q_lift, why = self._at(
                T_lift, q_in, 0, f"{feature} way in {k + 1}", f"{target}, above it"
            )
            if q_lift is None:
                return None, why
        # the lines as the program drives them: down to the way in, (a hole: down its axis to
        # the approach,) the guarded line through the contact to its end; the contact's own
        # overlap is the touch, so the guarded line is checked up to the contact
        lines = [(T_lift, way_in, q_lift, "the way in", True)]
        if T_entry is not None:
            lines.append((T_entry, poses[1], q_entry, "the way down the axis", True))
        lines.append((poses[1], poses[0], q_start, "the approach", True))
        lines.append((poses[0], poses[2], q_contact, "the guarded line", False))
        for T_a, T_b, q_a, what, checked in lines:
            why = self._line(T_a, T_b, q_a, f"{target}: {what}", checked)
            if why is not None:
                return None, why
        return (
            spin,
            stylus,
            [poses[1], poses[0], poses[2]],
            [q_start, q_contact, q_end, q_entry],
            (T_lift, q_lift),
        ), None

    def _contact(self, T_world_tcp, seeds, target: str, thorough: bool):
        """Joints at the contact pose, collision-free: (q, None) or (None, why not).  IK from
        the seeds in one batch (their order kept); ``thorough``: with :data:`RESTARTS` seeded
        random starts besides, every branch found tried, the soonest reached first."""
        from ..kinematics.inverse import distinct_solutions
        from ..planning.motion import sampled_box

        starts = np.asarray(seeds, dtype=float)
        if thorough:
            lo, hi = (sampled_box(self.dev.limit_array(side)) for side in ("lower", "upper"))
            rng = np.random.default_rng(len(self.solved))
            starts = np.vstack([starts, rng.uniform(lo, hi, (RESTARTS, self.dev.dof))])
        found = distinct_solutions(self.dev, self.T_base_world @ T_world_tcp, starts, self.mount)
        if not len(found):  # the figures of the closest pose: from the first seed, once
            if not thorough:
                return None, f"'{target}' is unreachable for {self.tcp} from the joints tried"
            return self._reach(T_world_tcp, seeds[0], 0, target)
        if thorough:
            found = sorted(found, key=lambda q: self.travel_time(seeds[0], q))
        why = None
        for q in found:
            hit = self.collision(q)
            if hit is None:
                return q, None
            why = f"{target}: {hit}" + (
                f" (each of its {len(found)} IK solutions collides)" if len(found) > 1 else ""
            )
        return None, why

    @functools.cached_property
    def checker(self):
        """The collision room's configuration check of the device in the nominal cell, at the
        rig's clearance and no overlap tolerated (what :meth:`collision` decides, for many
        states in one call)."""
        from ..collision.bodies import collision_model
        from ..collision.configurations import ConfigurationChecker

        return ConfigurationChecker(
            self.world, collision_model(self.cell), self.device, 0.0, self.clearance
        )

    def _line(self, T_a, T_b, q_a, what: str, checked: bool) -> str | None:
        """Whether the straight TCP line ``T_a`` -> ``T_b`` (world) can be driven from
        ``q_a``: IK followed along it every 4 mm (each solution seeding the next, as the
        simulator follows a line), and with ``checked`` those states collision-free (one
        batch); None, or why not."""
        from ..kinematics.inverse import track
        from ..motion.trajectory import interpolate_poses
        from ..planning.motion import nearest_words

        length = float(np.linalg.norm(T_b[:3, 3] - T_a[:3, 3]))
        if length < 1e-9:
            return None
        s = np.linspace(0.0, 1.0, max(2, int(np.ceil(length / 0.004)) + 1))
        targets = self.T_base_world @ interpolate_poses(T_a, T_b, s)
        found = track(self.dev, targets, q_a, self.mount)
        if found.failed_at is None and found.condition > LINE_CONDITION:
            # near a singularity 4 mm steps can slip past a wrist flip: followed again every
            # DENSE_STEP, and refused where that fails or a joint turns faster than a wrist can
            dense = np.linspace(0.0, 1.0, max(2, int(np.ceil(length / DENSE_STEP)) + 1))
            again = track(
                self.dev, self.T_base_world @ interpolate_poses(T_a, T_b, dense), q_a, self.mount
            )
            turns = np.abs(np.diff(again.q, axis=0)).max(axis=1) / (length * dense[1])
            fast = int(np.argmax(turns))
            if again.failed_at is not None or turns[fast] > MAX_TURN:
                where = dense[again.failed_at if again.failed_at is not None else fast]
                return (
                    f"{what} {SINGULAR} at {float(where):.0%} (Jacobian condition number "
                    f"{found.condition:.3g}; a joint turns {np.degrees(turns[fast]) / 1000:.3g} "
                    "deg a mm)"
                )
        if found.failed_at is not None:
            where = float(s[found.failed_at])
            return f"{what} leaves the workspace at {where:.0%} ({found.reason})"
        if checked:  # free or not in one compiled call; the nearest pair for the message only
            bad = np.flatnonzero(~self.checker.free(found.q[1:]))
            if len(bad):
                report = self.checker.check(found.q[1 + int(bad[0])][None])
                return f"{what}: {nearest_words(self.checker, report, 0)}"
        return None

    def transit_collides(self, q0, q1) -> bool:
        """Whether the straight joint move q0 -> q1 comes closer than the clearance to what it
        may not touch at one of its states 0.02 rad apart (largest joint change; one compiled
        call - the program's check is the continuous one)."""
        q0, q1 = np.asarray(q0, dtype=float), np.asarray(q1, dtype=float)
        count = max(2, int(np.ceil(np.abs(q1 - q0).max() / 0.02)) + 1)
        Q = q0 + np.linspace(0.0, 1.0, count)[:, None] * (q1 - q0)
        return not self.checker.free(Q).all()

    @functools.cached_property
    def _ball(self):
        """The probe's ball as a collision body, made once (asked at every target)."""
        from ..collision.bodies import ball_body

        return ball_body("probe ball", self.radius)

    def _ball_inside(self, centre: np.ndarray) -> str | None:
        """The body the probe's ball would overlap with its centre at ``centre`` (world), of
        those that do not move with the robot (exact distances: a ball started there touches
        at once, or is inside the material); None when it is clear of them all."""
        from ..collision.bodies import pair_distance

        ball = self._ball
        T_ball = spatial.make_transform(np.eye(3), centre)[None]
        for i in self.fixed:
            body = self.bodies[i]
            T = self.world.T_world(body.frame)
            if np.linalg.norm(T[:3, :3] @ body.center + T[:3, 3] - centre) > (
                body.radius + self.radius
            ):
                continue
            if pair_distance(ball, body, T_ball, T[None], within=0.0).overlap[0]:
                return body.label
        return None

    def _orientations(self, kind: str, stylus: np.ndarray, spins):
        """(stylus direction, spin) pairs to try: a hole keeps the one its first point used;
        a face whose normal is near horizontal also tilts the stylus down by ``TILTS``."""
        if kind == "circle" and len(spins) == 1 and isinstance(spins[0], tuple):
            yield spins[0][1], spins[0][0]
            return
        down = np.array([0.0, 0.0, -1.0])
        side = down - (down @ stylus) * stylus
        tilts = TILTS if np.linalg.norm(side) > 0.5 and kind != "circle" else TILTS[:1]
        for tilt in tilts:
            direction = stylus
            if tilt:
                direction = np.cos(tilt) * stylus + np.sin(tilt) * side / np.linalg.norm(side)
            for spin in spins:
                yield direction, float(spin)

    def _ball_z(self, T_world_tcp: np.ndarray) -> float:
        return float((T_world_tcp @ self.T_tcp_sensor)[2, 3])

    def _at(self, T_world_tcp, seed, restarts: int, what: str, collide: str | None = None):
        """Joint values at the pose, collision-free when ``collide`` names it for the message;
        or (None, why not)."""
        q, why = self._reach(T_world_tcp, seed, restarts, what)
        if q is not None and collide is not None:
            hit = self.collision(q)
            if hit is not None:
                return None, f"{collide}: {hit}"
        return q, why

    def _reach(self, T_world_tcp: np.ndarray, seed: np.ndarray, restarts: int, what: str):
        """(joint values, None) at the pose, or (None, why not)."""
        res = self.ik(T_world_tcp, seed, restarts)
        if res.success:
            return res.q, None
        return None, res.unreachable(what, self.tcp, [j.name for j in self.dev.joints])

    # ------------------------------------------------------------------ order
    def travel_time(self, qa: np.ndarray, qb: np.ndarray) -> float:
        return float(np.max(np.abs(qa - qb) / self.vmax))


def _reach_bound(dev, mount: ToolMount, T_tcp_sensor: np.ndarray) -> float:
    """An upper bound on the distance from the device's base origin to the probe ball's centre
    [m]: the TCP's bound (:func:`~rworld_cli.kinematics.jacobian.reach_bound`) plus the
    sensor's offset from the TCP."""
    return reach_bound(dev, mount) + float(np.linalg.norm(T_tcp_sensor[:3, 3]))


def tour(costs: np.ndarray, start: np.ndarray) -> list[int]:
    """A closed tour from the start through every stop: nearest neighbour, then 2-opt.

    Parameters
    ----------
    costs : ndarray, shape (S, S)
        Travel cost between stops (symmetric).
    start : ndarray, shape (S,)
        Cost from the start position to each stop (and back).
    """
    S = len(start)
    if S <= 1:
        return list(range(S))
    order = [int(np.argmin(start))]
    left = set(range(S)) - {order[0]}
    while left:
        last = order[-1]
        nxt = min(left, key=lambda j: costs[last, j])
        order.append(nxt)
        left.remove(nxt)
    # 2-opt on the closed path start -> order -> start (node -1 is the start)
    full = np.zeros((S + 1, S + 1))
    full[:S, :S] = costs
    full[S, :S] = full[:S, S] = start
    path = [S] + order + [S]
    improved = True
    while improved:
        improved = False
        for i in range(1, len(path) - 2):
            for j in range(i + 1, len(path) - 1):
                a, b, c, d = path[i - 1], path[i], path[j], path[j + 1]
                if full[a, c] + full[b, d] < full[a, b] + full[c, d] - 1e-12:
                    path[i : j + 1] = path[i : j + 1][::-1]
                    improved = True
    return path[1:-1]


# --------------------------------------------------------------------------- the program


def _offset(T: np.ndarray) -> dict:
    """A move offset in the program's units (mm, deg), to the decimals the program keeps."""
    xyz = [round(float(x) * 1000, 6) + 0.0 for x in T[:3, 3]]  # + 0.0: no -0.0 in files
    rpy = [round(float(np.degrees(a)), 9) + 0.0 for a in spatial.matrix_to_rpy(T[:3, :3])]
    return {"xyz": xyz, "rpy": rpy}


def probe_program(
    rig: ProbeRig, plans, ordered: bool = True, description: str | None = None
) -> tuple[dict, int]:
    """The probe program visiting every planned target, as data (``schema.programs.
    program_text`` writes it); and the number of stops.

    Parameters
    ----------
    rig : ProbeRig
        Every directive's targets solved (``rig.solved``).
    plans : list of FramePlan
    ordered : bool
        Visit in the short order (default) or as planned (frame by frame, feature by feature).

    Returns
    -------
    dict
        ``header`` (comment lines), ``device``, ``description``, ``units`` and ``steps``: a
        list of (step mapping, trailing comment or None), offsets in mm and deg.
    int
    """
    seen: dict[str, object] = {}
    for plan in plans:
        for d in plan.directives:
            seen.setdefault(d.feature, d)
    stops: list[tuple[str, list[Solved]]] = []
    for name, d in seen.items():
        solved = [rig.solved[name, int(k)] for k in d.index]
        if d.kind == "circle":
            stops.append((name, solved))
        else:
            stops += [(name, [s]) for s in solved]
    q_of = [s[0].q_lift for _, s in stops]
    if ordered and stops:
        costs = np.array([[rig.travel_time(a, b) for b in q_of] for a in q_of])
        start = np.array([rig.travel_time(rig.q_start, q) for q in q_of])
        stops = [stops[i] for i in tour(costs, start)]
    owner = {name: rig.cell.features[name].owner for name in seen}
    tcp = rig.tcp.split(".", 1)[1] if rig.tcp.startswith(rig.device + ".") else rig.tcp
    steps: list[tuple[dict, str | None]] = [({"move": {"to": rig.start}}, None)]

    def move(o: str, T, linear: bool = True, comment=None, near=None, free: bool = False):
        spec: dict = {"to": o, "tcp": tcp, "offset": _offset(T)}
        if linear:
            spec["motion"] = "linear"
        if free:  # a transit the straight joint move would collide on: planned around it
            spec["path"] = "free"
        if near is not None:  # the joints the plan checked there (deg; mm for prismatic)
            prismatic = np.array([j.kind == "prismatic" for j in rig.dev.joints], dtype=bool)
            values = np.where(prismatic, 1000.0 * near, np.degrees(near))
            spec["config"] = {"near": [round(float(v), 4) for v in values]}
        if steps and steps[-1][0] == {"move": spec}:
            return  # already there (inside a hole: back at its centre, then off to the next)
        steps.append(({"move": spec}, comment))

    q_here = rig.q_start  # where the arm is before each transit (as planned)
    for k, (name, solved) in enumerate(stops):
        o = owner[name]
        first = solved[0]
        label = name + (f" target {first.index + 1}" if first.T_owner_entry is None else "")
        # from the start position the nearest solution is arbitrary (a UR stretched out at its
        # zero pose reaches the plate elbow down, nowhere to go): the one planned, by a free
        # path; later stops take the one nearest where the arm is (one configuration for the
        # whole tour), by a free path where the straight joint move collides
        move(
            o,
            first.T_owner_lift,
            linear=False,
            comment=label,
            near=first.q_lift if k == 0 else None,
            free=k == 0 or rig.transit_collides(q_here, first.q_lift),
        )
        q_here = first.q_lift
        way_in = first.T_owner_entry if first.T_owner_entry is not None else first.T_owner_approach
        if not np.allclose(first.T_owner_lift, way_in):
            move(o, way_in)
        if first.T_owner_entry is not None:  # a hole or boss: down the axis to the depth
            move(o, first.T_owner_approach)
        for s in solved:
            if s is not first:
                move(o, s.T_owner_approach)
            guarded = {"to": o, "tcp": tcp, "offset": _offset(s.T_owner_end)}
            guarded.update(motion="linear", speed=float(f"{rig.speed:g}"), until=rig.sensor)
            steps.append(({"move": guarded}, None))
            steps.append(({"probe": name}, None))
            move(o, s.T_owner_approach)
        if first.T_owner_entry is not None:
            move(o, first.T_owner_entry)
        if not np.allclose(first.T_owner_lift, way_in):
            move(o, first.T_owner_lift)
    steps.append(({"move": {"to": rig.start, "path": "free"}}, None))
    header = [
        "Probe program written by 'rworld plan-measurements --program': each target is",
        "approached along its surface normal, touched by a guarded move that stops when the",
        f"probe's ball ({rig.sensor}) touches, recorded ('probe:') and left the way it came.",
        "Offsets are in the feature owner's frame (mm, deg): calibrating the owner moves them.",
    ]
    doc = {
        "header": header,
        "device": rig.device,
        "description": description or "probe the conditioned features for calibration",
        "units": {"length": "mm", "angle": "deg"},
        "steps": steps,
    }
    doc["touches"] = sum(len(solved) for _, solved in stops)
    return doc, len(stops)


def find_probe(cell: CellModel, device: str, tcp: str | None, sensor: str | None):
    """The probe TCP (full frame name) and its ball-tip touch sensor on ``device``.

    Raises
    ------
    UserError
        No such device, TCP or sensor, or the sensor is not a ball-tip touch probe carried by the
        device's TCP.
    """
    from ..errors import did_you_mean

    if device not in cell.devices:
        raise UserError(
            f"no device '{device}'{did_you_mean(device, cell.devices)}; devices: "
            f"{', '.join(cell.devices) or 'none'}"
        )
    world = World(cell)
    dev = cell.devices[device]
    carried = set(world.subtree(device))
    balls = [
        s
        for s, m in cell.sensors.items()
        if m.type == "touch" and m.ball is not None and s in carried
    ]
    if sensor is None:
        if len(balls) != 1:
            raise UserError(
                f"'{device}' carries {len(balls)} ball-tip touch probe(s)"
                + (
                    f" ({', '.join(balls)}): name one with --sensor"
                    if balls
                    else ": give a touch sensor 'ball: RADIUS' and affix it to a TCP of the device"
                )
            )
        sensor = balls[0]
    elif sensor not in balls:
        raise UserError(
            f"'{sensor}' is not a ball-tip touch probe carried by '{device}'"
            + (f"; those it carries: {', '.join(balls)}" if balls else "")
        )
    if tcp is None:
        tcp = world.parent(sensor)
    full = tcp if tcp in cell.frames else f"{device}.{tcp}"
    if full not in cell.frames or full not in carried:
        raise UserError(
            f"'{tcp}' is not a frame carried by '{device}'; its TCPs: {', '.join(dev.tcps)}"
        )
    return full, sensor

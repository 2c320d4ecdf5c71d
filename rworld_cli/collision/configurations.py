"""Configuration checks: many joint states of one device in its cell at once.

What a planner, a probing planner or a robot-calibration planner asks thousands of times: at
each joint state, does the device (its links, and what it carries) touch anything it may not
touch, and which pair is nearest, how near?  :class:`ConfigurationChecker` is built once per
device and world (the pairs, the static bodies' poses, the bodies' trees), then
:meth:`ConfigurationChecker.check` answers a batch of states.

Pairs: every body moved by the device's joints (its links; a tool or a grasped part carried by
them) against every other body, less the pairs that may touch (``allowed.py``: adjacent links,
grasps, tools, the cell's ``allowed_contacts``).  The world's affixments are as they are now.

A state is **free** when no pair overlaps deeper than the collision tolerance, none is buried
in the other (``bodies.pair_distance``), and, with a required clearance, none is closer than
it - the rules of ``rworld check`` at one instant.  Only the pairs whose bounding spheres come
within a state's nearest upper bound reach the exact query; the result equals the exact
distance of every pair (``tests/collision/test_configurations.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..units import COLLISION_TOLERANCE
from . import bvh
from .allowed import allowed_pairs
from .bodies import CollisionModel, buried_in, distances
from .convex import MAX_ITERATIONS
from .levers import _Levers
from .sweep import _signed


@dataclass
class SegmentReport:
    """A straight joint-space segment checked (:meth:`ConfigurationChecker.check_segment`).

    Attributes
    ----------
    free : bool
        No contact deeper than the tolerance (nor closer than the clearance less the tolerance)
        anywhere on the segment, between the states measured too.
    first : float or None
        Where the first contact found lies, as the segment's parameter s in [0, 1] (the state
        ``q0 + s (q1 - q0)``); None when free.
    pair : tuple of int or None
        Its body pair (indices into the model's bodies).
    unresolved : bool
        Bisection reached its depth without proving an interval before any contact clear or
        finding a contact there: reported as not free (the safe side).
    queries : int
        Exact pair queries made.
    """

    free: bool
    first: float | None
    pair: tuple[int, int] | None
    unresolved: bool
    queries: int


@dataclass
class ConfigurationReport:
    """N joint states checked.

    Attributes
    ----------
    free : ndarray of bool, shape (N,)
    distance : ndarray, shape (N,)
        The nearest pair's signed distance [m]: negative inside an overlap (minus its depth);
        inf when the device has no pair to check.
    pair : ndarray of int, shape (N, 2)
        Body indices (into the model's bodies) of each state's nearest pair (-1 without one).
    buried : ndarray of bool, shape (N,)
        A body lies inside a closed mesh of the other at that state.
    """

    free: np.ndarray
    distance: np.ndarray
    pair: np.ndarray
    buried: np.ndarray


class ConfigurationChecker:
    """Checks joint states of ``device`` in ``world`` (module docstring).

    Parameters
    ----------
    world : World
        The cell's frame tree, affixments as they are.
    model : CollisionModel
    device : str
    tolerance : float
        Collision tolerance [m]: overlaps shallower than this are touches, not collisions.
    clearance : float
        Required clearance [m] (0: none).
    only, skip : set of (int, int), optional
        Check only these pairs of bodies (indices of ``model.bodies``, lower first) of those it
        would check, or all but these (a planner's search margin relaxed for the pairs already
        inside it at the start).
    """

    def __init__(
        self,
        world,
        model: CollisionModel,
        device: str,
        tolerance: float = COLLISION_TOLERANCE,
        clearance: float = 0.0,
        only: set | None = None,
        skip: set | None = None,
    ) -> None:
        self.world, self.model, self.device = world, model, device
        self.tolerance, self.clearance = float(tolerance), float(clearance)
        bodies = model.bodies
        links = set(world.cell.devices[device].link_frames)

        def moved(frame: str) -> bool:
            node: str | None = frame
            while node is not None:
                if node in links:
                    return True
                node = world.parent(node)
            return False

        self.moving = np.array([moved(b.frame) for b in bodies], dtype=bool)
        allowed = allowed_pairs(world, model)
        pairs = [
            (i, j)
            for i in range(len(bodies))
            for j in range(i + 1, len(bodies))
            if (self.moving[i] or self.moving[j])
            and (i, j) not in allowed
            and (only is None or (i, j) in only)
            and (skip is None or (i, j) not in skip)
        ]
        self.pairs = np.array(pairs, dtype=int).reshape(-1, 2)
        self._frames = sorted({bodies[k].frame for k in self.pairs.ravel() if self.moving[k]})
        self._static = {
            bodies[k].frame: world.T_world(bodies[k].frame)
            for k in self.pairs.ravel()
            if not self.moving[k]
        }
        self._chain = self._chain_of()
        self._centre = np.array([b.center for b in bodies]).reshape(-1, 3)
        self._radius = np.array([b.radius for b in bodies])
        # every body's root box, as one tree's nodes (node i: body i), for one bound call
        trees = [b.tree for b in bodies]
        self._roots = bvh.Tree(
            np.array([tr.center[0] for tr in trees]).reshape(-1, 3),
            np.array([tr.half[0] for tr in trees]).reshape(-1, 3),
            np.array([tr.axes[0] for tr in trees]).reshape(-1, 3, 3),
            np.full(len(trees), -1),
            np.full(len(trees), -1),
            np.arange(len(trees)),
        )
        self._single = np.array([b.single_piece for b in bodies], dtype=bool)
        # a pair's cost to query, roughly: its bodies' leaves (the free-only order)
        leaves = np.array([len(b.tree.item) for b in bodies], dtype=float)
        self._cost = leaves[self.pairs[:, 0]] * leaves[self.pairs[:, 1]]
        self._fused = self._fuse()
        # each pair's place in the fused table (-1: not there: a sphere, a cylinder, no kernel)
        self._fused_row = np.full(len(self.pairs), -1)
        if self._fused is not None:
            self._fused_row[self._fused["pairs"]] = np.arange(len(self._fused["pairs"]))

    def _fuse(self) -> dict | None:
        """What the free-only check hands to one compiled call (:func:`compiled_bvh.
        free_states`): the pairs of polytope bodies, cheapest first, their bodies' rows (trees,
        leaf tables, bounding spheres), and the closed meshes' boxes for the buried test.
        None: no pair of polytopes, or no compiled kernel."""
        from .. import kernels
        from .compiled_bvh import body_table

        bodies = self.model.bodies
        if not len(self.pairs) or kernels.backend() != "llvm":
            return None
        ok = np.array([b.walk_side is not None for b in bodies], dtype=bool)
        fused = np.flatnonzero(ok[self.pairs[:, 0]] & ok[self.pairs[:, 1]])
        if not len(fused):
            return None
        fused = fused[np.argsort(self._cost[fused], kind="stable")]
        used = np.unique(self.pairs[fused])
        row = np.full(len(bodies), -1)
        row[used] = np.arange(len(used))
        lo = np.full((len(bodies), 3), np.inf)
        hi = np.full((len(bodies), 3), -np.inf)
        closed = np.array([b.is_mesh and b.shape.closed for b in bodies], dtype=bool)
        for k in np.flatnonzero(closed):
            lo[k], hi[k] = bodies[k]._triangle_box
        first = np.array([bodies[k].first_point for k in range(len(bodies))]).reshape(-1, 3)
        return {
            "pairs": fused,  # global pair indices, in the order tried
            "local": row[self.pairs[fused]],  # the same pairs as rows of the table
            "row": row,  # each body's row of the table (-1: none)
            "frames": [bodies[k].frame for k in used],
            "table": body_table([bodies[k].walk_side for k in used]),
            "spheres": np.ascontiguousarray(
                np.column_stack([self._centre[used], self._radius[used]])
            ),
            "boxes": np.ascontiguousarray(np.column_stack([lo[used], hi[used], first[used]])),
            "rest": np.setdiff1d(np.arange(len(self.pairs)), fused),
            "closed": closed,
            "lo": lo,
            "hi": hi,
            "first": first,
        }

    def poses(self, q: np.ndarray) -> _FixedPoses:
        """``T_world_frame`` (N, 4, 4) of every body frame in a pair, at joint states q (N, n);
        the fixed frames' broadcast when first read.

        The moving frames by the device's chain (:meth:`_chain_of`): ``T_world_base A_1 ...
        A_i T_link_frame``, the products of fixed frames taken once; where a frame's path is
        not that shape, through the world tree."""
        q = np.asarray(q, dtype=float)
        out = _FixedPoses(self._static, len(q))
        if self._chain is None:
            if self._frames:
                out.update(self.world.T_world_frames(self._frames, {self.device: q}))
            return out
        base, deepest, offsets = self._chain
        A = self.world.cell.devices[self.device].joint_transforms(q)  # (N, n, 4, 4)
        link = [base @ A[:, 0]]
        for i in range(1, deepest + 1):
            link.append(link[-1] @ A[:, i])
        for frame, (i, T_link_frame) in offsets.items():
            out[frame] = link[i] if T_link_frame is None else link[i] @ T_link_frame
        return out

    def _chain_of(self):
        """(T_world_base (4, 4), the deepest link index used, frame -> (its link's index, the
        frame in that link's frame (4, 4), None: the link frame itself)) for the moving body
        frames - or None when one's path to world is not fixed frames, then the device's links
        from the base in order, then fixed frames (as in a cell the world tree builds)."""
        world, dev = self.world, self.world.cell.devices[self.device]
        index = {f: i for i, f in enumerate(dev.link_frames)}
        if not dev.link_frames:
            return None
        base = world.parent(dev.link_frames[0])
        for i in range(1, len(dev.link_frames)):
            if world.parent(dev.link_frames[i]) != dev.link_frames[i - 1]:
                return None
        offsets = {}
        for frame in self._frames:
            below = []
            node: str | None = frame
            while node is not None and node not in index:
                below.append(node)
                node = world.parent(node)
            if node is None:
                return None
            T = None
            for fixed in reversed(below):
                T = world.T_parent(fixed) if T is None else T @ world.T_parent(fixed)
            offsets[frame] = (index[node], T)
        if base is None:
            return None
        T_world_base = world.T_world(base)
        deepest = max((i for i, _ in offsets.values()), default=0)
        return T_world_base, deepest, offsets

    def check(self, q, nearest: bool = True) -> ConfigurationReport:
        """Check N joint states q (N, n) [rad or m] of the device (module docstring).

        ``nearest=False`` answers free / not free only (what a planner asks): pairs farther
        apart than the clearance are not measured, and ``distance`` is then exact only where
        it is within the clearance (inf elsewhere: farther), ``pair`` -1 there; a state is
        done at its first pair found deeper than the tolerance, whose depth is then only
        known to be deeper (``distance`` at most ``-tolerance``, the pair one that collides);
        with a clearance, at its first pair found overlapping at all (``distance`` at most
        0).
        """
        q = np.atleast_2d(np.asarray(q, dtype=float))
        N, P = len(q), len(self.pairs)
        if not P:
            return ConfigurationReport(
                np.ones(N, dtype=bool), np.full(N, np.inf), np.full((N, 2), -1), np.zeros(N, bool)
            )
        bodies = self.model.bodies
        T = self.poses(q)
        watch = max(self.clearance, 0.0)
        distance = np.full(N, np.inf)
        nearest_pair = np.full((N, 2), -1)
        free = np.ones(N, dtype=bool)
        buried = np.zeros(N, dtype=bool)
        subset = np.arange(P)  # the pairs left to the steps below
        if not nearest and self._fused is not None:
            if self._free_states(T, watch, distance, nearest_pair, free, buried):
                subset = self._fused["rest"]
                if not len(subset):
                    return ConfigurationReport(free, distance, nearest_pair, buried)
        I, J = self.pairs[subset, 0], self.pairs[subset, 1]
        TI = np.stack([T[bodies[i].frame] for i in I], axis=1)  # (N, P, 4, 4)
        TJ = np.stack([T[bodies[j].frame] for j in J], axis=1)
        ci = (TI[..., :3, :3] @ self._centre[I][:, :, None])[..., 0] + TI[..., :3, 3]
        cj = (TJ[..., :3, :3] @ self._centre[J][:, :, None])[..., 0] + TJ[..., :3, 3]
        centre = np.linalg.norm(ci - cj, axis=-1)  # (N, P)
        reach = self._radius[I] + self._radius[J]
        # a pair's distance lies between its spheres' gap and centre distance + radii: only
        # pairs whose lower bound is within the state's best upper bound can be the nearest,
        # and only those within the clearance can make a state not free
        near = centre - reach <= watch
        if nearest:
            upper = (centre + reach).min(axis=1)
            near |= centre - reach <= upper[:, None] + 1e-9
        state, pair = np.nonzero(near)
        if not nearest:  # the bodies' boxes (their trees' roots) apart: the pair is farther
            state, pair = self._boxes_near(TI, TJ, state, pair, watch, subset)
        if nearest:  # every pair that may be the nearest, at once
            groups = [np.arange(len(state))]
        else:  # pair by pair, cheapest first (pairs of single pieces lead), each only at the
            # states still free: a state is done at its first collision
            pairs = np.unique(pair)
            pairs = pairs[np.argsort(self._cost[pairs], kind="stable")]
            groups = [np.flatnonzero(pair == p) for p in pairs]
        report = (distance, nearest_pair, free, buried)
        for rows in groups:
            if not nearest:
                rows = rows[free[state[rows]]]
            if not len(rows):
                continue
            s, p = state[rows], pair[rows]  # p: a column of TI, pair subset[p]
            within, deep = (np.inf, np.inf) if nearest else (watch, self.tolerance)
            self._measure(s, subset[p], TI[s, p], TJ[s, p], within, deep, report)
        return ConfigurationReport(free, distance, nearest_pair, buried)

    def free(self, q) -> np.ndarray:
        """Whether each of N joint states q (N, n) is free: ``check(q, nearest=False).free``
        (N,) bool, answered from the fused kernel's statuses alone where they settle every
        pair (what a planner asks, thousands of times a second); the states an overlap or a
        buried suspect leaves open, and checkers with pairs outside the kernel, by
        :meth:`check`."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        fused = self._fused
        if fused is None or len(fused["rest"]) or not len(self.pairs):
            return self.check(q, nearest=False).free
        poses = self._packed_by_chain(q)
        if poses is None:
            _, poses = self._packed(self.poses(q))
        watch = max(self.clearance, 0.0)
        found = self._statuses(poses, watch)
        if found is None:
            return self.check(q, nearest=False).free
        status, near = found
        # as :meth:`_free_states` tallies them: a collision's depth, a distance within the
        # watched one; an overlap the walk could not call deep enough is within a clearance
        signed = np.where((status == 1) | ((status == 0) & (near <= watch)), near, np.inf)
        bad = signed < -self.tolerance
        if self.clearance > 0:
            bad |= (signed < self.clearance) | (status == 2)
            open_ = (status == -1) | (status == 4)
        else:
            open_ = (status == 2) | (status == -1) | (status == 4)
        free = np.logical_not(bad.any(axis=1))
        redo = free & open_.any(axis=1)
        if redo.any():
            free[redo] = self.check(q[redo], nearest=False).free
        return free

    def _measure(self, s, p, TI, TJ, within, deep_enough, report) -> None:
        """Pairs ``p[r]`` (indices of :attr:`pairs`) at states ``s[r]``, their bodies at ``TI``,
        ``TJ`` (R, 4, 4), by the exact query (:func:`bodies.distances`), into ``report``
        (distance, nearest pair, free, buried: :meth:`_tally`)."""
        res = distances(
            self.model.bodies,
            self.pairs[p, 0],
            self.pairs[p, 1],
            TI,
            TJ,
            within=within,
            deep_enough=deep_enough,
            exact_above=self.tolerance,
        )
        self._tally(s, p, _signed(res), res.buried, *report)

    def _free_states(self, T, watch, distance, nearest_pair, free, buried) -> bool:
        """The free-only check of the pairs of polytopes (:meth:`_fuse`) in one compiled call,
        into the report's arrays; each state stops at its first pair deeper than the
        tolerance.  Overlaps not known to be that deep go to the exact query, a closed mesh's
        pairs with nothing overlapping to the buried test.  False: no kernel (nothing done)."""
        fused = self._fused
        assert fused is not None
        placed, poses = self._packed(T)
        found = self._statuses(poses, watch)
        if found is None:
            return False
        status, near = found
        # the common answer, every pair passed (spheres apart, or walked and farther than the
        # watched distance): free, nothing to tally
        passed = (status == 3) | ((status == 0) & ~(near <= watch))
        if passed.all():
            return True
        # the pairs that tell: a collision, one within the watched distance, a buried suspect
        s, c = np.nonzero((status == 1) | (status == 4) | ((status == 0) & (near <= watch)))
        p = fused["pairs"][c]
        value = near[s, c]
        signed = np.where((status[s, c] == 1) | (value <= watch), value, np.inf)
        # a witness point in the other's closed-mesh box (the kernel's 4): the winding number
        suspects = status[s, c] == 4
        buried_now = self._buried(placed, s, p, suspects) if suspects.any() else suspects
        self._tally(s, p, signed, buried_now, distance, nearest_pair, free, buried)
        # overlaps the walk could not call deep enough: with a clearance asked, an overlap of
        # any depth is nearer than it - not free, its depth not measured (distance 0: at
        # most); without one, measured exactly, pair by pair, each at the states still free
        if self.clearance > 0:
            s, c = np.nonzero(status == 2)
            s_free = free[s]
            s, c = s[s_free], c[s_free]
            zero = np.zeros(len(s))
            self._tally(
                s, fused["pairs"][c], zero, zero.astype(bool), distance, nearest_pair, free, buried
            )
            s, c = np.nonzero(status == -1)
        else:
            s, c = np.nonzero((status == 2) | (status == -1))
        for column in np.unique(c):
            rows = s[c == column]
            rows = rows[free[rows]]
            if len(rows):
                u, v = fused["local"][column]
                pair = np.full(len(rows), fused["pairs"][column])
                report = (distance, nearest_pair, free, buried)
                self._measure(
                    rows, pair, placed[rows, u], placed[rows, v], watch, self.tolerance, report
                )
        return True

    def _statuses(self, poses: np.ndarray, watch: float):
        """The fused kernel on the table's bodies at ``poses`` (N, U, 12): (status (N, P),
        nearest (N, P)) of its pairs, ``watch`` [m] the distance measured within; None: no
        compiled kernel."""
        from .compiled_bvh import free_states

        fused = self._fused
        assert fused is not None
        return free_states(
            fused["local"],
            poses,
            fused["table"],
            fused["spheres"],
            fused["boxes"],
            watch + 2e-9,
            self.tolerance,
            MAX_ITERATIONS,
        )

    def _packed(self, T: _FixedPoses) -> tuple[np.ndarray, np.ndarray]:
        """The fused table's bodies at the states of ``T`` (:meth:`poses`): their frames
        (N, U, 4, 4), and as the compiled kernels read them (N, U, 12): R's rows, then t."""
        assert self._fused is not None
        frames = self._fused["frames"]
        N = T.count
        placed = np.empty((N, len(frames), 4, 4))
        for u, frame in enumerate(frames):  # a fixed frame's pose broadcast on assignment
            placed[:, u] = self._static[frame] if frame in self._static else T[frame]
        poses = np.concatenate([placed[..., :3, :3].reshape(N, -1, 9), placed[..., :3, 3]], axis=2)
        return placed, poses

    def _packed_by_chain(self, q: np.ndarray) -> np.ndarray | None:
        """The fused table's bodies at states q (N, n) as the kernels read them (N, U, 12),
        as :meth:`_packed` of :meth:`poses` gives them (to rounding): the fixed frames' rows
        copied, the moving ones by one generated program of the chain
        (:func:`~rworld_cli.kinematics.forward.mounted_frames_program`).  None where the
        device's chain does not place them (:meth:`_chain_of`)."""
        plan = self.__dict__.get("_chain_plan", False)
        if plan is False:
            plan = self._chain_plan = self._plan_chain()
        if plan is None:
            return None
        program, moving, fixed, fixed_rows, count = plan
        out = np.empty((len(q), count, 12))
        out[:, fixed] = fixed_rows
        out[:, moving] = program.evaluate([q]).reshape(len(q), -1, 12)
        return out

    def _plan_chain(self):
        """What :meth:`_packed_by_chain` needs, or None."""
        if self._chain is None or self._fused is None:
            return None
        from ..kinematics.forward import mounted_frames_program

        base, _, offsets = self._chain
        moving, mounts, fixed, fixed_rows = [], [], [], []
        for u, frame in enumerate(self._fused["frames"]):
            if frame in self._static:
                T = self._static[frame]
                fixed.append(u)
                fixed_rows.append(np.concatenate([T[:3, :3].ravel(), T[:3, 3]]))
            else:
                i, T_link_frame = offsets[frame]
                moving.append(u)
                mounts.append((i, np.eye(4) if T_link_frame is None else T_link_frame))
        program = mounted_frames_program(self.world.cell.devices[self.device], base, mounts)
        return (
            program,
            np.array(moving, dtype=int),
            np.array(fixed, dtype=int),
            np.array(fixed_rows).reshape(-1, 12),
            len(self._fused["frames"]),
        )

    def _buried(self, placed, s, p, clear) -> np.ndarray:
        """Whether one body of pair ``p[r]`` lies inside the other's closed mesh at state
        ``s[r]``, for the rows ``clear`` (their surfaces do not meet): each body's witness
        point tested against the other's box, all rows at once, then the winding number of
        the few inside a box (:func:`bodies.buried_in`'s test).  ``placed`` (N, U, 4, 4): the
        poses of the table's bodies."""
        from ..geometry import winding_number

        fused = self._fused
        assert fused is not None
        out = np.zeros(len(s), dtype=bool)
        bodies = self.model.bodies
        for mesh_side in (0, 1):
            mesh = self.pairs[p, mesh_side]
            other = self.pairs[p, 1 - mesh_side]
            rows = np.flatnonzero(clear & fused["closed"][mesh])
            if not len(rows):
                continue
            Tm = placed[s[rows], fused["row"][mesh[rows]]]
            To = placed[s[rows], fused["row"][other[rows]]]
            point = np.einsum("kij,kj->ki", To[:, :3, :3], fused["first"][other[rows]])
            point += To[:, :3, 3]
            local = np.einsum("kji,kj->ki", Tm[:, :3, :3], point - Tm[:, :3, 3])
            boxed = np.all(
                (local >= fused["lo"][mesh[rows]]) & (local <= fused["hi"][mesh[rows]]), axis=1
            )
            for k in np.unique(mesh[rows][boxed]):
                pick = rows[boxed & (mesh[rows] == k)]
                inside = winding_number(local[np.searchsorted(rows, pick)], bodies[k]._triangles)
                out[pick[inside > 0.5]] = True
        return out

    def _tally(self, s, p, signed, buried_now, distance, nearest_pair, free, buried) -> None:
        """Rows (state ``s``, pair ``p``) measured: each state's nearest, and whether it is
        free (no overlap deeper than the tolerance, nothing buried, nothing within the
        clearance), into the report's arrays."""
        np.minimum.at(distance, s, signed)
        best = np.flatnonzero(signed <= distance[s])
        nearest_pair[s[best]] = self.pairs[p[best]]
        bad = (signed < -self.tolerance) | buried_now
        if self.clearance > 0:
            bad |= signed < self.clearance
        free[s[bad]] = False
        buried[s[buried_now]] = True

    def _walked(self, TI, TJ, pair: int, watch):
        """One pair of bodies with trees at R states (poses (R, 4, 4) each): both trees walked
        and their leaf pairs within ``watch`` [m] (one for all states, or (R,)) measured in one
        compiled call (:func:`compiled_bvh.contacts`, branch and bound on the nearest).
        Returns (signed (R,): the distance where within ``watch``, inf farther, at most minus
        the tolerance where a leaf pair is found deeper; buried (R,); undecided (R,) bool: an
        overlap not known to be deeper than the tolerance, left to the exact query), or None
        (no kernel; a sphere or a cylinder)."""
        from .compiled_bvh import contacts

        a, b = (self.model.bodies[k] for k in self.pairs[pair])
        if a.walk_side is None or b.walk_side is None:
            return None
        R, t = bvh._relative(TI, TJ)
        found = contacts(
            a.walk_side, b.walk_side, R, t, watch + 2e-9, self.tolerance, MAX_ITERATIONS
        )
        if found is None:
            return None
        status, nearest, _ = found
        signed = np.where((status == 1) | (nearest <= watch), nearest, np.inf)
        buried_now = np.zeros(len(status), dtype=bool)
        clear = np.flatnonzero(status == 0)
        buried_now[clear] = buried_in(a, b, TI[clear], TJ[clear])
        return signed, buried_now, status == 2

    def _boxes_near(self, TI, TJ, state, pair, watch: float, subset):
        """The (state, pair) rows whose bodies' oriented boxes (the roots of their trees) are
        within ``watch`` of each other: the separating-axis bound of :func:`bvh.box_gap`, all
        rows in one call (``pair``: columns of TI, the pairs ``subset[pair]``)."""
        R, t = bvh._relative(TI[state, pair], TJ[state, pair])
        rows = np.arange(len(state))
        I, J = self.pairs[subset[pair], 0], self.pairs[subset[pair], 1]
        gap = bvh.gap_at(self._roots, I, self._roots, J, rows, R, t)
        keep = gap <= watch + 1e-9
        return state[keep], pair[keep]

    # bisection depth of :meth:`check_segment`: intervals of 2**-40 of the segment
    SEGMENT_DEPTH = 40

    def _signed(self, q: np.ndarray, pair: np.ndarray, at: np.ndarray, within=np.inf):
        """Signed distances (and buried) of pairs ``pair[r]`` at states ``q[at[r]]``: exact up to
        ``within`` [m] (one for all rows, or per row), and ``within`` (a lower bound) where the
        pair is farther; depths exact up to the tolerance (a contact deeper is one, whatever
        its depth).  Pair by pair, trees walked and leaves measured compiled where they can
        be (:meth:`_walked`), the exact query elsewhere."""
        bodies = self.model.bodies
        T = self.poses(q)
        within = np.broadcast_to(np.asarray(within, dtype=float), (len(pair),))
        signed, buried = np.empty(len(pair)), np.zeros(len(pair), dtype=bool)
        left = []  # rows for the exact query
        todo = np.ones(len(pair), dtype=bool)  # rows not answered by the one compiled call
        if self._fused is not None:
            rows = np.flatnonzero((self._fused_row[pair] >= 0) & np.isfinite(within))
            undecided = self._rows_walked(T, pair, at, within, rows, signed, buried)
            if undecided is not None:
                todo[rows] = False
                left.append(undecided)
        for p in np.unique(pair[todo]):
            rows = np.flatnonzero((pair == p) & todo)
            i, j = self.pairs[p]
            TI, TJ = T[bodies[i].frame][at[rows]], T[bodies[j].frame][at[rows]]
            walked = (
                self._walked(TI, TJ, int(p), within[rows])
                if np.isfinite(within[rows]).all()
                else None
            )
            if walked is None:
                left.append(rows)
                continue
            signed[rows], buried[rows], undecided = walked
            left.append(rows[undecided])
        rows = np.concatenate(left) if left else np.zeros(0, dtype=int)
        if len(rows):
            I, J = self.pairs[pair[rows], 0], self.pairs[pair[rows], 1]

            def placed(index):  # each row's body at its state: one gather per body
                out = np.empty((len(index), 4, 4))
                for body in np.unique(index):
                    mine = np.flatnonzero(index == body)
                    out[mine] = T[bodies[body].frame][at[rows[mine]]]
                return out

            res = distances(
                bodies,
                I,
                J,
                placed(I),
                placed(J),
                within=within[rows],
                deep_enough=self.tolerance,
                exact_above=self.tolerance,
            )
            signed[rows], buried[rows] = _signed(res), res.buried
        return np.minimum(signed, within), buried

    def _rows_walked(self, T, pair, at, within, rows, signed, buried) -> np.ndarray | None:
        """Rows ``rows`` of :meth:`_signed` whose pairs are polytopes in the fused table, in
        one compiled call (:func:`compiled_bvh.pair_rows`: each row's bounding spheres, then
        its trees walked up to its own limit), into ``signed`` and ``buried``; returns the rows
        left to the exact query (an overlap not known to be deeper than the tolerance), or
        None (no kernel: nothing done)."""
        from .compiled_bvh import pair_rows

        fused = self._fused
        assert fused is not None
        if not len(rows):
            return rows
        placed, poses = self._packed(T)
        uv = fused["local"][self._fused_row[pair[rows]]]
        found = pair_rows(
            np.column_stack([at[rows], uv]),
            poses,
            fused["table"],
            fused["spheres"],
            fused["boxes"],
            within[rows] + 2e-9,
            self.tolerance,
            MAX_ITERATIONS,
        )
        if found is None:
            return None
        status, near = found
        signed[rows] = np.where((status == 1) | (near <= within[rows]), near, np.inf)
        suspects = status == 4  # a witness point in the other's closed-mesh box
        if suspects.any():
            s = np.flatnonzero(suspects)
            buried[rows[s]] = self._buried(
                placed, at[rows[s]], pair[rows[s]], np.ones(len(s), bool)
            )
        return rows[(status == 2) | (status == -1)]

    def check_segment(self, q0, q1) -> SegmentReport:
        """Check the straight joint-space segment from q0 to q1 (n,) [rad or m], with the
        guarantee between states of ``rworld check`` (docs/collision.md): no contact deeper
        than the tolerance is missed, however far apart the states measured.

        For each pair, a point of either body moves, while s runs over [sa, sb], by at most
        ``M (sb - sa)``: ``M`` the sum over the device's joints of ``|q1_j - q0_j|`` times
        the joint's lever on the pair (``levers._Levers``: its axis' distance to the body;
        a joint that moves both bodies does not count).  The distance is 1-Lipschitz in that
        motion, so an interval whose end distances satisfy ``da + db - M (sb - sa) >= 2 (c -
        tol)`` is clear; other intervals are halved, their midpoints measured, until every
        interval is clear or a contact is found.  Intervals after a contact found are
        dropped (the first contact is what is reported), so a colliding segment ends early.
        """
        q0 = np.asarray(q0, dtype=float).ravel()
        q1 = np.asarray(q1, dtype=float).ravel()
        return self.check_curve(
            lambda s: q0 + s[:, None] * (q1 - q0), np.abs(q1 - q0), np.stack([q0, q1])
        )

    def check_blend(self, p0, corner, p2) -> SegmentReport:
        """Check the quadratic Bezier curve from ``p0`` by ``corner`` to ``p2`` (n,) [rad or
        m] - a planned path's blend at a corner (``planning.path.blend_corners``) - with the
        same guarantee as :meth:`check_segment`.  Its dq/ds is linear in s, so each joint's
        speed in s is at most ``2 max(|corner - p0|, |p2 - corner|)``: that is the travel
        the motion bound takes (:meth:`check_curve`)."""
        p0, c, p2 = (np.asarray(v, dtype=float).ravel() for v in (p0, corner, p2))

        def state_at(s):
            s = s[:, None]
            return (1 - s) ** 2 * p0 + 2 * s * (1 - s) * c + s**2 * p2

        speed = 2.0 * np.maximum(np.abs(c - p0), np.abs(p2 - c))
        return self.check_curve(state_at, speed, np.stack([p0, c, p2]))

    def check_curve(self, state_at, speed, hull) -> SegmentReport:
        """Check the joint-space curve ``state_at(s)`` ((M,) -> (M, n)), s in [0, 1], as
        :meth:`check_segment` checks a line: ``speed`` (n,) bounds each joint's |dq/ds| on
        the whole curve, so over [sa, sb] it moves at most ``speed (sb - sa)``; ``hull``
        (K, n) are states whose convex hull holds the curve (the levers' link lengths are
        taken over them)."""
        q0, q1 = state_at(np.array([0.0, 1.0]))
        P = len(self.pairs)
        if not P:
            return SegmentReport(True, None, None, False, 0)
        bodies = self.model.bodies
        # the other devices hold still where the world has them (a two-robot cell)
        held = {}
        for d, dev in self.world.cell.devices.items():
            if d != self.device:
                still = np.zeros((2, dev.dof))
                held[d] = (np.tile(self.world.joints(d), (2, 1)), still, still)
        hull = np.asarray(hull, dtype=float)
        held[self.device] = (hull, np.zeros_like(hull), np.zeros_like(hull))
        levers = _Levers.of(self.world, bodies, held)
        travel = np.array(
            [speed[j] if d == self.device else 0.0 for d, j in levers.joints]
        ).reshape(1, -1)
        reach = levers.pair_weights(self.pairs[:, 0], self.pairs[:, 1]).bound(travel)[:, 0]
        need = 2.0 * (max(self.clearance, 0.0) - self.tolerance)

        def bad(signed, buried):
            out = (signed < -self.tolerance) | buried
            return out | (signed < self.clearance) if self.clearance > 0 else out

        first, queries = np.inf, 0
        first_pair: tuple[int, int] | None = None

        def found(s_values, pairs, signed, buried) -> None:
            nonlocal first, first_pair
            hit = np.flatnonzero(bad(signed, buried))
            if len(hit):
                k = hit[np.argmin(s_values[hit])]
                if s_values[k] < first:
                    first, first_pair = (
                        float(s_values[k]),
                        _pair(self.pairs[pairs[k]]),
                    )

        # the ends, each exact only up to what clears the whole segment whatever the other
        # end (an end not itself a contact): the segment's motion bound and the clearance
        rows = np.arange(P)
        ends = np.stack([q0, q1])
        far = reach + max(self.clearance, 0.0) + 1e-6
        d0, b0 = self._signed(ends, rows, np.zeros(P, dtype=int), far)
        d1, b1 = self._signed(ends, rows, np.ones(P, dtype=int), far)
        queries += 2 * P
        found(np.zeros(P), rows, d0, b0)
        found(np.ones(P), rows, d1, b1)
        pair, sa, sb, da, db = rows, np.zeros(P), np.ones(P), d0, d1
        unresolved = False
        for _ in range(self.SEGMENT_DEPTH):
            open_ = (da + db - reach[pair] * (sb - sa) < need) & (sa < first)
            # an interval that runs up to the contact found: the contact is known to 2**-20
            # of the segment (refining further would chase the tolerance's boundary)
            open_ &= ~((sb >= first) & (sb - sa < 2.0**-20))
            pair, sa, sb, da, db = pair[open_], sa[open_], sb[open_], da[open_], db[open_]
            if not len(pair):
                break
            mid = (sa + sb) / 2
            states = state_at(mid)
            # a midpoint farther than this clears both halves with either end at 0 or more:
            # nearer ones are measured exactly, farther ones only known to be farther
            enough = np.maximum(reach[pair] * (sb - sa) / 2 + need, 0.0) + 1e-6
            dm, bm = self._signed(states, pair, np.arange(len(pair)), enough)
            queries += len(pair)
            found(mid, pair, dm, bm)
            pair = np.concatenate([pair, pair])
            sa, sb = np.concatenate([sa, mid]), np.concatenate([mid, sb])
            da, db = np.concatenate([da, dm]), np.concatenate([dm, db])
        else:
            open_ = (da + db - reach[pair] * (sb - sa) < need) & (sb < first)
            unresolved = bool(open_.any())
            if unresolved and not np.isfinite(first):
                first = float(sa[open_].min())
                first_pair = _pair(self.pairs[pair[open_][np.argmin(sa[open_])]])
        if not np.isfinite(first):
            return SegmentReport(True, None, None, False, queries)
        return SegmentReport(False, first, first_pair, unresolved, queries)


class _FixedPoses(dict):
    """Body frames' poses at N states: the moving frames set, the fixed ones (``static``:
    frame -> (4, 4)) broadcast to (N, 4, 4) when first read (a batch every pair of which
    passes reads none)."""

    def __init__(self, static: dict, count: int):
        super().__init__()
        self._static_poses, self.count = static, count

    def __missing__(self, frame):
        T = np.broadcast_to(self._static_poses[frame], (self.count, 4, 4))
        self[frame] = T
        return T


def _pair(row) -> tuple[int, int]:
    return int(row[0]), int(row[1])

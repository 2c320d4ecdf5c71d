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
from .allowed import allowed_pairs
from .bodies import CollisionModel, distances


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
    """

    def __init__(
        self,
        world,
        model: CollisionModel,
        device: str,
        tolerance: float = COLLISION_TOLERANCE,
        clearance: float = 0.0,
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
            if (self.moving[i] or self.moving[j]) and (i, j) not in allowed
        ]
        self.pairs = np.array(pairs, dtype=int).reshape(-1, 2)
        self._frames = sorted({bodies[k].frame for k in self.pairs.ravel() if self.moving[k]})
        self._static = {
            bodies[k].frame: world.T_world(bodies[k].frame)
            for k in self.pairs.ravel()
            if not self.moving[k]
        }
        self._centre = np.array([b.center for b in bodies]).reshape(-1, 3)
        self._radius = np.array([b.radius for b in bodies])

    def poses(self, q: np.ndarray) -> dict[str, np.ndarray]:
        """``T_world_frame`` (N, 4, 4) of every body frame in a pair, at joint states q (N, n)."""
        N = len(q)
        out = self.world.T_world_frames(self._frames, {self.device: q}) if self._frames else {}
        for frame, T in self._static.items():
            out[frame] = np.broadcast_to(T, (N, 4, 4))
        return out

    def check(self, q, nearest: bool = True) -> ConfigurationReport:
        """Check N joint states q (N, n) [rad or m] of the device (module docstring).

        ``nearest=False`` answers free / not free only (what a planner asks): pairs farther
        apart than the clearance are not measured, and ``distance`` is then exact only where
        it is within the clearance (inf elsewhere: farther), ``pair`` -1 there.
        """
        q = np.atleast_2d(np.asarray(q, dtype=float))
        N, P = len(q), len(self.pairs)
        if not P:
            return ConfigurationReport(
                np.ones(N, dtype=bool), np.full(N, np.inf), np.full((N, 2), -1), np.zeros(N, bool)
            )
        bodies = self.model.bodies
        T = self.poses(q)
        I, J = self.pairs[:, 0], self.pairs[:, 1]
        TI = np.stack([T[bodies[i].frame] for i in I], axis=1)  # (N, P, 4, 4)
        TJ = np.stack([T[bodies[j].frame] for j in J], axis=1)
        ci = (TI[..., :3, :3] @ self._centre[I][:, :, None])[..., 0] + TI[..., :3, 3]
        cj = (TJ[..., :3, :3] @ self._centre[J][:, :, None])[..., 0] + TJ[..., :3, 3]
        centre = np.linalg.norm(ci - cj, axis=-1)  # (N, P)
        reach = self._radius[I] + self._radius[J]
        # a pair's distance lies between its spheres' gap and centre distance + radii: only
        # pairs whose lower bound is within the state's best upper bound can be the nearest,
        # and only those within the clearance can make a state not free
        watch = max(self.clearance, 0.0)
        near = centre - reach <= watch
        if nearest:
            upper = (centre + reach).min(axis=1)
            near |= centre - reach <= upper[:, None] + 1e-9
        state, pair = np.nonzero(near)
        res = distances(
            bodies,
            I[pair],
            J[pair],
            TI[state, pair],
            TJ[state, pair],
            within=np.inf if nearest else watch,
        )
        signed = np.where(res.overlap, -np.maximum(res.depth, 0.0), res.distance)
        distance = np.full(N, np.inf)
        np.minimum.at(distance, state, signed)
        best = np.flatnonzero(signed <= distance[state])
        nearest_pair = np.full((N, 2), -1)
        nearest_pair[state[best]] = self.pairs[pair[best]]
        bad = (signed < -self.tolerance) | res.buried
        if self.clearance > 0:
            bad |= signed < self.clearance
        free = np.ones(N, dtype=bool)
        free[state[bad]] = False
        buried = np.zeros(N, dtype=bool)
        buried[state[res.buried]] = True
        return ConfigurationReport(free, distance, nearest_pair, buried)

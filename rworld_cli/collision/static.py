"""Every pair's distance in one state of the world (``rworld clearance``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .allowed import allowed_pairs
from .bodies import CollisionModel, distances


@dataclass
class PairClearance:
    """Two bodies in the world's current state.

    ``distance`` [m] is 0 when they overlap (``depth`` then estimates the penetration);
    ``allowed`` gives why they may touch, or None.
    """

    a: str
    b: str
    distance: float
    depth: float
    point_a: list
    point_b: list
    buried: bool
    allowed: str | None

    def as_dict(self) -> dict:
        return dict(self.__dict__)


def pair_clearances(world, model: CollisionModel) -> list[PairClearance]:
    """All body pairs with their exact distances, nearest first."""
    bodies = model.bodies
    B = len(bodies)
    if B < 2:
        return []
    I, J = np.triu_indices(B, 1)
    T = {b.frame: world.T_world(b.frame) for b in bodies}
    TI = np.stack([T[bodies[i].frame] for i in I])
    TJ = np.stack([T[bodies[j].frame] for j in J])
    res = distances(bodies, I, J, TI, TJ)
    allowed = allowed_pairs(world, model)
    out = [
        PairClearance(
            bodies[i].label,
            bodies[j].label,
            float(res.distance[k]),
            float(res.depth[k]),
            res.point_a[k].tolist(),
            res.point_b[k].tolist(),
            bool(res.buried[k]),
            allowed.get((int(i), int(j))),
        )
        for k, (i, j) in enumerate(zip(I, J))
    ]
    out.sort(key=lambda p: (p.distance, -p.depth))
    return out

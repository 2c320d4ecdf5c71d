"""Whether a grasp or a placement is physically possible, in the world's current state.

* An object **rests on** its support when the gap between their solids is at most the
  tolerance and neither overlaps the other deeper than it (nor lies buried in it): a part set
  down 20 mm into a table, or left 300 mm above it, does not rest on it.
* A **grasp** takes an object that is at the TCP: the TCP point within the tolerance of the
  object's solid (or inside it), or of one of the object's frames (a grasp frame).

Bodies without geometry cannot be judged by their solids; an object or support without
geometry of its own (a part on a sensor pad, which has no solid) is not judged at all (the
collision report lists such bodies as unchecked).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .allowed import carrier
from .bodies import CollisionModel, ball_body, pair_distance


@dataclass
class Rest:
    """How an object sits on its support.

    Attributes
    ----------
    support : str
        The support's body label.
    gap : float
        Least distance between the object's solids and the support's [m]; 0 when they touch
        or overlap.
    depth : float
        Deepest overlap [m] (0 when apart); at least the distance to the surface when buried.
    buried : bool
        One lies wholly inside the other.
    """

    support: str
    gap: float
    depth: float
    buried: bool

    def problem(self, tolerance: float) -> str | None:
        """Why this is not resting within ``tolerance`` [m], or None."""
        if self.buried:
            return f"is buried in {self.support}, at least {1000 * self.depth:.1f} mm deep"
        if self.depth > tolerance:
            return f"is {1000 * self.depth:.1f} mm deep inside {self.support}"
        if self.gap > tolerance:
            return f"floats {1000 * self.gap:.1f} mm away from {self.support}"
        return None


def rest(world, model: CollisionModel, child: str, support_frame: str) -> Rest | None:
    """How primitive ``child`` sits on the body that carries ``support_frame``, at the world's
    current joint values; None when either has no geometry."""
    index = {b.frame: i for i, b in enumerate(model.bodies)}
    held = carrier(world, index, support_frame)
    mine = [i for i, b in enumerate(model.bodies) if b.owner == child]
    if (
        held is None
        or not mine
        or model.bodies[held].owner != world.cell.frames[support_frame].owner
    ):
        return None
    support = model.bodies[held]
    T_support = world.T_world(support.frame)[None]
    gap, depth, buried = np.inf, 0.0, False
    for i in mine:
        body = model.bodies[i]
        res = pair_distance(body, support, world.T_world(body.frame)[None], T_support)
        gap = min(gap, float(res.distance[0]))
        depth = max(depth, float(res.depth[0]))
        buried = buried or bool(res.buried[0])
    return Rest(support.label, gap, depth, buried)


def grasp_gap(world, model: CollisionModel, child: str, tcp: str) -> float:
    """Distance from the TCP's origin to the object [m]: to its solids (0 inside one) or to the
    nearest of its frames, whichever is less."""
    p = world.T_world(tcp)[:3, 3]
    frames = [f for f, decl in world.cell.frames.items() if decl.owner == child]
    gap = min((float(np.linalg.norm(world.T_world(f)[:3, 3] - p)) for f in frames), default=np.inf)
    point = ball_body("tcp", 0.0)
    T_point = np.eye(4)[None].copy()
    T_point[0, :3, 3] = p
    for body in (b for b in model.bodies if b.owner == child):
        res = pair_distance(point, body, T_point, world.T_world(body.frame)[None])
        gap = min(gap, 0.0 if res.buried[0] else float(res.distance[0]))
    return gap

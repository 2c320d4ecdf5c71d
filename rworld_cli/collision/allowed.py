"""Which bodies may touch, from the world state (it changes with every affixment event).

* adjacent links of a chain (the base and the first link with geometry, and each link with the
  next one that has geometry);
* an affixed primitive with the body that carries it: a grasped object with the link or hand
  that grasps it (a hand grasping from its base: its fingers too), an object with what it
  rests on, a tool with its flange, an assembled part with its assembly, an aggregated device's
  base with its mount;
* the cell's ``allowed_contacts`` groups.

A program step's ``touch:`` list adds pairs for that step's time only (see :mod:`.sweep`).
"""

from __future__ import annotations

from ..model.cell import WORLD
from .bodies import CollisionModel


def carrier(world, by_frame: dict[str, int], frame: str) -> int | None:
    """The body that carries ``frame``: the first body frame at or above it (None: world).

    ``by_frame`` maps each body's frame to its index in the collision model.
    """
    node = frame
    while node is not None and node != WORLD:
        if node in by_frame:
            return by_frame[node]
        node = world.parent(node)
    return None


def allowed_pairs(world, model: CollisionModel) -> dict[tuple[int, int], str]:
    """Allowed body pairs ``(i, j)`` with ``i < j`` -> the reason, for the world's current tree."""
    cell = world.cell
    bodies = model.bodies
    index = {b.frame: i for i, b in enumerate(bodies)}
    out: dict[tuple[int, int], str] = {}

    def allow(i: int | None, j: int | None, reason: str) -> None:
        if i is None or j is None or i == j:
            return
        out.setdefault((min(i, j), max(i, j)), reason)

    for name, dev in cell.devices.items():
        chain = [index.get(name)] + [index.get(f) for f in dev.link_frames]
        present = [i for i in chain if i is not None]
        for i, j in zip(present, present[1:]):
            allow(i, j, f"adjacent links of {name}")
    for aff in world.affixments:
        if aff.child in cell.sensors:
            continue
        holder = carrier(world, index, aff.parent)
        if holder is None:
            continue
        kind = aff.kind or ("rests_on" if aff.type == "non_rigid" else "rigid")
        reason = {
            "grasp": f"{aff.child} is grasped by {bodies[holder].label}",
            "rests_on": f"{aff.child} rests on {bodies[holder].label}",
            "tool": f"{aff.child} is the tool on {bodies[holder].label}",
            "aggregation": f"{aff.child} is mounted on {bodies[holder].label}",
            "assembly": f"{aff.child} is assembled into {bodies[holder].label}",
        }.get(kind, f"{aff.child} is affixed to {bodies[holder].label}")
        child_bodies = [i for i, b in enumerate(bodies) if b.owner == aff.child]
        if aff.child in cell.devices:  # an aggregated device touches its mount with its base
            child_bodies = [i for i in child_bodies if bodies[i].label == aff.child] or child_bodies
        holders = [holder]
        if kind == "grasp":  # the grasping body's distal bodies (a hand's fingers) too
            owner = bodies[holder].owner
            if owner in cell.devices:
                frames = [owner, *cell.devices[owner].link_frames]
                start = frames.index(bodies[holder].frame)
                holders = [index[f] for f in frames[start:] if f in index]
        for c in child_bodies:
            for h in holders:
                allow(c, h, reason)
    # the parts of one assembly touch each other wherever they are in it
    root: dict[str, str] = {}

    def find(x: str) -> str:
        while root.get(x, x) != x:
            x = root[x]
        return x

    for aff in world.affixments:
        if aff.kind == "assembly":
            root[find(aff.child)] = find(cell.frames[aff.parent].owner)
    groups: dict[str, set] = {}
    for part in list(root):
        groups.setdefault(find(part), {find(part)}).add(part)
    for top, parts in groups.items():
        members = [i for i, b in enumerate(bodies) if b.owner in parts]
        for x in members:
            for y in members:
                if x < y:
                    allow(x, y, f"parts of the {top} assembly")
    for group in cell.allowed_contacts:
        named = [_expand(model, cell, name) for name in group.names]
        for a in range(len(named)):
            for b in range(a + 1, len(named)):
                for i in named[a]:
                    for j in named[b]:
                        allow(i, j, group.reason)
    return out


def _expand(model: CollisionModel, cell, name: str) -> list[int]:
    """Bodies a name stands for: an object's body, all of a device's, or one link's."""
    if name in cell.devices:
        return [i for i, b in enumerate(model.bodies) if b.owner == name]
    return [i for i, b in enumerate(model.bodies) if b.label == name]


def touch_bodies(world, model: CollisionModel, device: str, names) -> tuple[list[int], list[int]]:
    """A ``touch:`` step: the device's bodies and what it carries, and the named bodies."""
    carried = set(world.subtree(device))
    mine = [i for i, b in enumerate(model.bodies) if b.frame in carried]
    named = sorted({i for n in names for i in _expand(model, world.cell, n)})
    return mine, named

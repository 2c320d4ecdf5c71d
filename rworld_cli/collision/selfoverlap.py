"""Link pairs of a device that overlap at every joint state sampled: meshes drawn into each other
at a joint (a ROS-Industrial wrist), which MoveIt's setup assistant disables and a collision
check would report at every instant.

The test is the exact intersection volume of the two solids (manifold3d's boolean, in double
precision), not the collision checker's distance: it needs no convex decomposition and no
triangle-by-triangle distance, so an import pays about a second for it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MIN_VOLUME = 1e-9  # [m^3] (1 mm^3): an intersection smaller is a touch, not an overlap


@dataclass
class Overlap:
    """Two bodies of the device that overlap at every sampled state."""

    a: str  # body labels: the device (its base) or "device.link"
    b: str
    volume: float  # the least intersection volume over the states [m^3]


@dataclass
class SelfOverlaps:
    overlaps: list[Overlap]
    unchecked: list[str]  # bodies whose mesh is no closed solid: not tested


def _solid(shape):
    """The shape as a manifold3d solid in its owner's frame, or None if it is not one."""
    import manifold3d as m3

    from ..geometry import shape_mesh

    mesh = shape_mesh(shape)
    m = m3.Mesh(
        vert_properties=np.asarray(mesh.vertices, np.float32),
        tri_verts=np.asarray(mesh.faces, np.uint32),
    )
    m.merge()  # an STL repeats each corner per triangle: join them into one solid
    solid = m3.Manifold(m)
    if solid.status() != m3.Error.NoError or solid.is_empty():
        return None
    return solid


def always_overlapping(cell, device: str, states: int = 8, seed: int = 0) -> SelfOverlaps:
    """The pairs of ``device``'s bodies (base and links), not adjacent in the chain and not in
    the cell's ``allowed_contacts``, whose solids intersect by more than ``MIN_VOLUME`` at the
    device's home and at ``states - 1`` seeded joint states within its limits.

    A pair clear at one state is dropped, so the intersections after the first state run on
    the overlapping few only.
    """
    from ..world.tree import World

    dev = cell.devices[device]
    chain = [(device, device, dev.shape)]
    chain += [(frame, frame, link.shape) for link, frame in zip(dev.links, dev.link_frames)]
    solids, unchecked = {}, []
    for label, frame, shape in chain:
        if shape is None:
            continue
        solid = _solid(shape)
        if solid is None:
            unchecked.append(label)
        else:
            solids[label] = (frame, solid)
    order = [label for label, _, _ in chain]
    allowed = {frozenset(p) for p in zip(order, order[1:])}  # adjacent in the chain
    for group in cell.allowed_contacts:
        named = [[x for x in order if x == n or n == device] for n in group.names]
        for i in range(len(named)):
            for j in range(i + 1, len(named)):
                allowed |= {frozenset((a, b)) for a in named[i] for b in named[j] if a != b}
    labels = list(solids)
    pairs = [
        (a, b)
        for k, a in enumerate(labels)
        for b in labels[k + 1 :]
        if frozenset((a, b)) not in allowed
    ]
    lower, upper = dev.limit_array("lower"), dev.limit_array("upper")
    lo = np.where(np.isfinite(lower), lower, -np.pi)
    hi = np.where(np.isfinite(upper), upper, np.pi)
    rng = np.random.default_rng(seed)
    Q = np.vstack([dev.home, rng.uniform(lo, hi, (max(states, 1) - 1, dev.dof))])
    world = World(cell)
    volume = dict.fromkeys(pairs, np.inf)
    for q in Q:
        if not pairs:
            break
        world.set_joints(device, q)
        placed = {}
        for label in {x for pair in pairs for x in pair}:
            frame, solid = solids[label]
            placed[label] = solid.transform(world.T_world(frame)[:3, :4])
        kept = []
        for a, b in pairs:
            v = (placed[a] ^ placed[b]).volume()
            if v > MIN_VOLUME:
                volume[(a, b)] = min(volume[(a, b)], v)
                kept.append((a, b))
        pairs = kept
    return SelfOverlaps([Overlap(a, b, volume[(a, b)]) for a, b in pairs], unchecked)

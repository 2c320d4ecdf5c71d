"""A probe program's run read as measurements (``rworld measure --simulate --program``): the
program runs on the nominal cell, its joint values move the truth cell's robot, each guarded
move's contact is found on the truth cell's parts, and what the controller would report - its
nominal forward kinematics at those joints, with encoder and probing noise - becomes the probe
points of each feature (:func:`probe_run`, :func:`measurement_features`).  Split from
:mod:`.probing` (the robot's side: poses, order, the program)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..model.cell import CellModel
from ..world.tree import World


@dataclass
class ProbedPoint:
    """One probe of a simulated probe program: nominal and true ball centres at contact."""

    feature: str
    step: int  # 1-based, the guarded move's step
    where: str  # its program file:line
    nominal: np.ndarray  # (3,) world [m]
    true: np.ndarray | None  # (3,) world [m]; None when the truth cell gave no contact
    objects: list[str] = field(default_factory=list)
    off_edge: bool = False  # a line's probe landed on a face, not on the edge (truth known)
    reported: np.ndarray | None = None  # (3,) world [m]: what the controller records


def probe_run(
    result, run, truth: CellModel, joint_sigma: float = 0.0, seed: int = 0
) -> list[ProbedPoint]:
    """The contacts of a probe program's guarded moves, as they would be on ``truth``, and what
    the robot's controller records for each.

    ``result`` is the program simulated on the nominal cell (``run``): it gives, per ``probe:``
    step, the guarded move before it, with the joint values it started from and planned to end
    at.  The controller drives those joint values - it knows only the nominal model - and on the
    truth cell they move the truth device (its own DH rows or joint frames, base and TCP), so
    the ball travels from the truth device's ball at the start to its ball at the planned end;
    the first contact on that line (:func:`~rworld_cli.sensing.sensors.ball_first_contact`,
    exact to 1e-10 m) is where the ball truly touches.  The controller records the contact
    as its nominal forward kinematics at the joint values of that instant: the same fraction
    of its own straight line (``reported``).  A robot that is not the nominal one thus puts
    its error into the measurement, as on a real cell.

    Parameters
    ----------
    joint_sigma : float
        Joint-encoder noise [rad], 1 sigma, added to the revolute joints' values at contact.
    """
    from ..sensing.sensors import ball_first_contact, sensable_bodies

    world = World(truth)
    believed = World(run.cell)  # the controller's model: the nominal cell
    rng = np.random.default_rng(seed)
    out = []
    for device, resolved in result.resolved.items():
        # what the robot carries (its links, a stylus or gripper on the flange) moves with the
        # ball: it is never what the ball touches
        carried = set(world.subtree(device)) | {device}
        probes = [
            e for e in result.events if e.device == device and e.kind == "probe" and e.reading
        ]
        for event in probes:
            item = resolved[event.reading["guard_move"]]  # the guarded move it recorded
            move, sensor = item.move, item.move.guard
            radius = float(truth.sensors[sensor].ball or 0.0)
            points, nominal_line = [], []
            for q in (move.q_start, move.q_planned):
                world.set_joints(device, q)
                points.append(world.T_world(sensor)[:3, 3].copy())
                believed.set_joints(device, q)
                nominal_line.append(believed.T_world(sensor)[:3, 3].copy())
            bodies = [b for b in sensable_bodies(world) if b.owner not in carried]
            hit = ball_first_contact(points[0], points[1], radius, bodies)
            true, objects, off_edge, reported = None, [], False, None
            if hit is not None:
                true = points[0] + hit[0] * (points[1] - points[0])
                reported = nominal_line[0] + hit[0] * (nominal_line[1] - nominal_line[0])
                if joint_sigma > 0:  # the encoders' noise, through the nominal kinematics
                    q_hit = move.q_start + hit[0] * (move.q_planned - move.q_start)
                    believed.set_joints(device, q_hit)
                    at = believed.T_world(sensor)[:3, 3].copy()
                    revolute = np.array(
                        [j.kind == "revolute" for j in run.cell.devices[device].joints]
                    )
                    noise = rng.normal(0.0, joint_sigma, q_hit.shape) * revolute
                    believed.set_joints(device, q_hit + noise)
                    reported = reported + believed.T_world(sensor)[:3, 3] - at
                objects = hit[1]
                f = truth.features[event.reading["feature"]]
                if f.kind == "line" and radius > 0:  # did the ball meet the edge itself?
                    T = world.T_world(f.owner)
                    v = (true - T[:3, 3]) @ T[:3, :3] - f.point
                    gap = np.linalg.norm(v - (v @ f.direction) * f.direction) - radius
                    off_edge = gap > 1e-7
            out.append(
                ProbedPoint(
                    event.reading["feature"],
                    item.step.index + 1,
                    item.step.where,
                    np.array(event.reading["point"]),
                    true,
                    objects,
                    off_edge,
                    reported,
                )
            )
    return out


def measurement_features(
    nominal: CellModel, probed: list[ProbedPoint], sigma: float, seed: int
) -> dict:
    """Measurement-file entries (SI, world) from the probed points, with Gaussian noise
    ``sigma`` [m] added to each contact as the controller recorded it.

    Planes and circles get an 'above' point 10 mm out along the nominal normal; lines are
    sorted first -> last along the nominal direction, their ``offset`` where the nominal ball
    centres lie from the edge (owner frame); a circle's ``depth`` is how far below the rim the
    nominal contacts are, and one probed from outside is a boss.
    """
    from ..model.measurements import FeatureProbes

    rng = np.random.default_rng(seed)
    world = World(nominal)
    by_feature: dict[str, list[ProbedPoint]] = {}
    for p in probed:
        by_feature.setdefault(p.feature, []).append(p)
    out = {}
    for name, points in by_feature.items():
        f = nominal.features[name]
        T = world.T_world(f.owner)
        R, t = T[:3, :3], T[:3, 3]
        recorded = np.array([p.reported if p.reported is not None else p.true for p in points])
        measured = recorded + rng.normal(0.0, sigma, recorded.shape)
        local = (np.array([p.nominal for p in points]) - t) @ R  # nominal centres, owner frame
        above, offset, boss, depth = None, None, False, None
        if f.kind == "line":
            order = np.argsort(measured @ (R @ f.direction))
            measured = measured[order]
            v = local - f.point
            offset = (v - np.outer(v @ f.direction, f.direction)).mean(axis=0)
        elif f.kind == "plane":
            above = measured.mean(axis=0) + ABOVE * (R @ f.direction)
        elif f.kind == "circle":
            v = local - f.point
            axial = v @ f.direction
            depth = float(-axial.mean())
            radial = np.linalg.norm(v - np.outer(axial, f.direction), axis=1)
            boss = bool(radial.mean() > f.radius)
            above = R @ f.point + t + ABOVE * (R @ f.direction)
        out[name] = FeatureProbes(
            measured, above, f.kind == "line", offset=offset, boss=boss, depth=depth
        )
    return out


ABOVE = 0.01  # [m]: a plane's or circle's 'above' point, this far out along the normal

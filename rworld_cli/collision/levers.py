"""How far a body can move while its joints turn: each body's lever arms about the joints that
carry it (the bound the continuous check bisects with), the chains' joint axes, and the pair
weights that turn a joint step into a bound on a pair's approach."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model.cell import WORLD
from .bodies import Body


@dataclass
class _Levers:
    """Which joints move each body, and by how much at most (module docstring).

    Attributes
    ----------
    joints : list of (device, joint index)
        The L joints that move any body.
    limits : ndarray, shape (L,)
        Their acceleration limits (inf: none).
    arm : ndarray, shape (B, L)
        Bound on the distance from each joint's axis to each body [m]; 1 for a prismatic joint
        (it moves the body by its own travel); 0 where the joint does not move the body.
    round : ndarray of bool, shape (B, L)
        The body is a sphere or cylinder on the link before or after the revolute joint, round
        about the joint's axis: turning the joint leaves the body where it is, relative to the
        link the joint turns against (:func:`_round_about_axes`).
    """

    joints: list[tuple[str, int]]
    limits: np.ndarray
    arm: np.ndarray
    round: np.ndarray

    @classmethod
    def of(cls, world, bodies: list[Body], joints: dict) -> _Levers:
        """The levers of ``bodies`` in the world's tree, for the joint samples ``joints``
        (device -> (q, qd, qdd), each (K, n)) of one stretch."""
        cell = world.cell
        link_of = {
            f: (d, i) for d, dev in cell.devices.items() for i, f in enumerate(dev.link_frames)
        }
        # each link frame's offset from its parent frame, at its longest over the samples; a
        # prismatic joint may extend further between samples: add its largest step
        length = {}
        for d, dev in cell.devices.items():
            q = joints[d][0]
            # a revolute joint turns its link frame's offset about the joint axis, so the
            # offset's length is the same at every sample - unless a prismatic joint or a
            # calibration's correction (a turn before the joint's own) makes it vary
            varying = any(j.kind == "prismatic" or j.correction is not None for j in dev.joints)
            sampled = q if varying else q[:1]
            norms = np.linalg.norm(dev.joint_transforms(sampled)[..., :3, 3], axis=-1).max(axis=0)
            steps = np.abs(np.diff(q, axis=0)).max(axis=0, initial=0.0)
            prismatic = np.array([j.kind == "prismatic" for j in dev.joints])
            for i, f in enumerate(dev.link_frames):
                length[f] = float(norms[i] + (steps[i] if prismatic[i] else 0.0))
        columns: dict[tuple[str, int], int] = {}
        arms: list[dict[int, float]] = []
        offset: dict[str, float] = {}  # a fixed frame's distance from its parent [m]
        for body in bodies:
            reach = math.hypot(*body.center) + body.radius  # from the body's frame
            arm: dict[int, float] = {}
            node = body.frame
            while node is not None and node != WORLD:
                if node in link_of:
                    d, i = link_of[node]
                    joint = cell.devices[d].joints[i]
                    column = columns.setdefault((d, i), len(columns))
                    arm[column] = 1.0 if joint.kind == "prismatic" else reach + abs(joint.a)
                    reach += length[node]
                else:
                    if node not in offset:
                        offset[node] = math.hypot(*world.T_parent(node)[:3, 3])
                    reach += offset[node]
                node = world.parent(node)
            arms.append(arm)
        table = np.zeros((len(bodies), len(columns)))
        for b, arm in enumerate(arms):
            for column, r in arm.items():
                table[b, column] = r
        keys = list(columns)
        limits = np.array([cell.devices[d].joints[i].limits.acceleration for d, i in keys])
        return cls(keys, limits, table, _round_about_axes(world, bodies, keys))

    def travel(self, lo: dict, hi: dict, h: np.ndarray, columns=None) -> np.ndarray:
        """Bound on each joint's travel over N intervals of length ``h`` (N,), from the states
        at their ends (device -> (q, qd, qdd), each (N, n)): shape (N, L) [rad or m], or
        (N, len(columns)) for those joints only.

        ``h (|qd_a| + |qd_b|) / 2 + A h^2 / 4``, A the acceleration limit or, when larger, the
        acceleration at either end.
        """
        h = np.asarray(h, dtype=float)
        columns = range(len(self.joints)) if columns is None else columns
        out = np.zeros((len(h), len(columns)))
        for k, column in enumerate(columns):
            d, j = self.joints[column]
            qd_a, qd_b = lo[d][1][:, j], hi[d][1][:, j]
            A = np.maximum(np.abs(lo[d][2][:, j]), np.abs(hi[d][2][:, j]))
            if np.isfinite(self.limits[column]):
                A = np.maximum(A, self.limits[column])
            out[:, k] = h * (np.abs(qd_a) + np.abs(qd_b)) / 2 + A * h * h / 4
        return out

    def pair_weights(self, I: np.ndarray, J: np.ndarray) -> PairWeights:
        """Per pair (I[p], J[p]) and joint, the lever that counts for their distance: a joint
        that moves both bodies moves them as one rigid body and leaves their distance alone.
        The pairs' motion bound is this times the joints' travel."""
        moved = self.arm > 0
        C = max(int(moved.sum(axis=1).max(initial=0)), 1)
        # each body's joints, padded with column 0 at weight 0
        order = np.argsort(~moved, axis=1, kind="stable")[:, :C]
        cols_of = np.where(np.take_along_axis(moved, order, axis=1), order, 0)
        arm_of = np.take_along_axis(self.arm, cols_of, axis=1) * np.take_along_axis(
            moved, order, axis=1
        )
        ci, cj = cols_of[I], cols_of[J]
        wi = np.where(self.arm[J[:, None], ci] > 0, 0.0, arm_of[I])
        wj = np.where(self.arm[I[:, None], cj] > 0, 0.0, arm_of[J])
        vals = np.hstack([wi, wj])
        cols = np.hstack([ci, cj])
        # a joint turning one body of the pair about an axis the other (or the body itself)
        # is round about leaves their distance alone: it counts for whether the pair moves,
        # not for how fast its distance can change
        rows = np.arange(len(I))[:, None]
        round_ = self.round[I[rows], cols] | self.round[J[rows], cols]
        return PairWeights(cols, np.where(round_, 0.0, vals), vals > 0)


def _round_about_axes(world, bodies: list[Body], joints: list[tuple[str, int]]) -> np.ndarray:
    """(B, L): body b is a sphere or a cylinder fixed to the link before or after revolute joint
    l (the device's base frame before the first joint) and round about the joint's axis - the
    sphere's centre on it, or the cylinder's axis along it.

    Then the joint's turn moves nothing of b relative to the link on its other side, at any
    state: a pair with b gains no speed of approach from it (the distance's derivative by that
    joint is zero).  A base cylinder coaxial with the first joint, a wrist sphere centred on the
    wrist axes, a flange disc on the last axis are the common cases.
    """
    cell = world.cell
    out = np.zeros((len(bodies), len(joints)), dtype=bool)
    column = {key: c for c, key in enumerate(joints)}
    # each frame a joint's axis is fixed in -> (column, point, direction) in that frame
    axes: dict[str, list[tuple[int, np.ndarray, np.ndarray]]] = {}
    known: dict[tuple, list] = {}  # identical robots of a line: their axes worked out once
    lines = {}
    for d in {d for d, _ in joints}:
        key = _chain_key(cell.devices[d])
        if key not in known:
            known[key] = _joint_axis_lines(cell.devices[d])
        lines[d] = known[key]
    for (d, i), c in column.items():
        dev = cell.devices[d]
        if dev.joints[i].kind != "revolute" or lines[d][i] is None:
            continue
        (p_before, u_before), (p_after, u_after) = lines[d][i]
        axes.setdefault(d if i == 0 else dev.link_frames[i - 1], []).append((c, p_before, u_before))
        axes.setdefault(dev.link_frames[i], []).append((c, p_after, u_after))
    if not axes:
        return out
    links = {f for dev in cell.devices.values() for f in dev.link_frames} | set(cell.devices)
    for b, body in enumerate(bodies):
        if body.parts is not None or body.shape.kind not in ("sphere", "cylinder"):
            continue
        node = body.frame  # up to the first link (or device base) frame, through fixed frames
        while node is not None and node != WORLD and node not in links:
            node = world.parent(node)
        if node is None or node not in axes:
            continue
        T = world.T(node, body.frame) @ body.shape.T_owner_shape
        centre, along = T[:3, 3], T[:3, 2]
        for c, point, direction in axes[node]:
            if np.linalg.norm(_cross(centre - point, direction)) > 1e-9:
                continue  # the centre is off the axis
            if body.shape.kind == "cylinder" and np.linalg.norm(_cross(along, direction)) > 1e-9:
                continue  # the cylinder's axis is not the joint's
            out[b, c] = True
    return out


_TURN = 0.5  # [rad]: the test turn that shows a joint's axis


def _chain_key(dev) -> tuple:
    """What fixes a device's joint axes in its link frames: equal keys, equal axes."""

    def array(x) -> bytes | None:
        return None if x is None else np.asarray(x, dtype=float).tobytes()

    return (
        dev.convention,
        array(dev.home),
        tuple(
            (
                j.kind,
                j.a,
                j.alpha,
                j.d,
                j.theta,
                array(j.origin),
                array(j.axis),
                array(j.correction),
            )
            for j in dev.joints
        ),
    )


def _joint_axis_lines(dev) -> list:
    """Each joint's axis as a line (point, unit direction) in the frame before it and in the
    link frame after it, whatever the convention, from its link transform at two values: per
    joint ``((point, direction), (point, direction))``, or None when the motion is not a turn
    about a fixed line (a prismatic joint)."""
    q = np.array(dev.home, dtype=float)
    A0 = dev.joint_transforms(q)
    A1 = dev.joint_transforms(q + _TURN)  # each link transform depends on its own joint only
    out = []
    for a0, a1 in zip(A0, A1):
        inverse = np.eye(4)
        inverse[:3, :3], inverse[:3, 3] = a0[:3, :3].T, -a0[:3, :3].T @ a0[:3, 3]
        lines = []
        for M in (a1 @ inverse, inverse @ a1):  # the turn seen from before; from after
            R, t = M[:3, :3], M[:3, 3]
            u = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
            u /= 2 * np.sin(_TURN)
            if abs(np.linalg.norm(u) - 1) > 1e-9 or abs(u @ t) > 1e-12:
                break
            # the axis point nearest the frame's origin: R turns about it, t = (I - R) p
            point = (t + _cross(u, t) / np.tan(_TURN / 2)) / 2
            lines.append((point, u))
        out.append(tuple(lines) if len(lines) == 2 else None)
    return out


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b of two 3-vectors (np.cross costs 40x this for one pair)."""
    return np.array(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


@dataclass
class PairWeights:
    """Sparse per-pair joint weights: ``vals[p, c]`` on joint column ``cols[p, c]`` (P, 2C),
    zero-padded; at most the joints above the pair's two bodies, however many devices."""

    cols: np.ndarray
    vals: np.ndarray
    moves: np.ndarray  # (P, 2C) bool: the joint moves one body of the pair against the other

    def take(self, rows) -> PairWeights:
        return PairWeights(self.cols[rows], self.vals[rows], self.moves[rows])

    def static(self, moving: np.ndarray) -> np.ndarray:
        """(P,) pairs that no moving joint (``moving``, (L,) bool) moves against each other: one
        rigid body, settled at a stretch's first sample."""
        return ~np.any(self.moves & moving[self.cols], axis=1)

    def bound(self, travel: np.ndarray) -> np.ndarray:
        """(P, K) motion bounds from joint travel bounds ``travel`` (K, L)."""
        return np.einsum("pc,kpc->pk", self.vals, travel[:, self.cols])

    def dense(self, columns: np.ndarray) -> np.ndarray:
        """(P, len(columns)) weights on the sorted joint ``columns`` (every pair's joints)."""
        out = np.zeros((len(self.cols), len(columns)))
        where = np.minimum(np.searchsorted(columns, self.cols), len(columns) - 1)  # pads: 0
        rows = np.repeat(np.arange(len(self.cols)), self.cols.shape[1])
        np.add.at(out, (rows, where.ravel()), self.vals.ravel())
        return out

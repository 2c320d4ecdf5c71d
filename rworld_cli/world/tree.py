"""The runtime world: a tree of frames whose shape programs change as they run.

Nodes are frames.  Owned frames (auxiliary, link, TCP) hang on their owner
for good; a primitive's natural frame hangs on its affixment parent (or on
world).  Every node's pose is stored relative to its parent, so moving a node
moves everything subordinate to it (the report's section 4: "the location of
all nodes of the tree subordinate to the node whose location ... is changed").

Affixments (report, section 4, "relational representation"):

* rigid - grasp, assembly, device aggregation, tool change, fixture: the child
  follows the parent; it cannot be moved on its own while affixed.
* non-rigid - "B rests on A": B follows A, never the converse; B may be moved
  (it slides or is lifted) without moving A.

Detaching puts the child (with its subtree) on world at the same world pose:
the tree splits.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import spatial
from ..errors import UserError
from ..model import rules
from ..model.cell import WORLD, CellModel


class AffixmentError(UserError):
    """An attach, detach or move that the affixment rules forbid."""


@dataclass(frozen=True)
class Affixment:
    """``child`` (a primitive) is affixed to frame ``parent``."""

    parent: str
    child: str
    type: str  # "rigid" | "non_rigid"
    kind: str | None = None


class World:
    """Mutable state of a cell: joint values, affixment tree, world poses.

    Parameters
    ----------
    cell : CellModel
        The static description (from :func:`rworld_cli.schema.loader.load_cell`).

    Examples
    --------
    >>> world = World(load_cell("workcells/paper_fig9").cell)   # doctest: +SKIP
    >>> world.set_joints("robot", q)                           # doctest: +SKIP
    >>> T_world_part = world.T_world("part")                   # doctest: +SKIP
    >>> world.attach("part", "hand_a.tcp", kind="grasp")        # doctest: +SKIP
    """

    def __init__(self, cell: CellModel):
        self.cell = cell
        self._parent: dict[str, str | None] = {}
        self._T_parent: dict[str, np.ndarray] = {}
        self._affix: dict[str, Affixment] = {}
        self._q: dict[str, np.ndarray] = {
            name: dev.home.copy() for name, dev in cell.devices.items()
        }
        self._active_tcp: dict[str, str] = {
            name: dev.tcps[0] for name, dev in cell.devices.items() if dev.tcps
        }
        self._cache: dict[str, np.ndarray] | None = None  # every frame (parents first)
        self._poses: dict[str, np.ndarray] = {}  # frames computed on demand since the last change
        self._stale: set[str] = set()  # devices whose joints come from _source when first needed
        self._source = None
        self._links: dict[str, np.ndarray] = {}  # device -> its link transforms at its joints
        self._children_cache: dict[str, list[str]] | None = None
        self._link_index: dict[str, tuple[str, int]] | None = None
        for name, decl in cell.frames.items():
            if decl.kind == "world":
                self._parent[name] = None
            elif decl.kind == "natural":
                self._parent[name] = WORLD
            else:
                self._parent[name] = decl.parent
            if decl.kind not in ("world", "link"):
                self._T_parent[name] = np.array(cell.poses.get(name, np.eye(4)), dtype=float)
        for a in cell.affixments:
            self._parent[a.child] = a.parent
            self._affix[a.child] = Affixment(a.parent, a.child, a.type, a.kind)

    # ------------------------------------------------------------------ queries
    @property
    def frames(self) -> list[str]:
        """All frame names, parents before children (depth first)."""
        kids = self._children()
        out, stack = [WORLD], list(reversed(kids.get(WORLD, [])))
        while stack:
            node = stack.pop()
            out.append(node)
            stack.extend(reversed(kids.get(node, [])))
        return out

    def parent(self, frame: str) -> str | None:
        self._check_frame(frame)
        return self._parent[frame]

    def ancestors(self, frame: str) -> list[str]:
        """``frame`` and its parents up to the world (not included), nearest first: what
        carries it as the affixments are now."""
        self._check_frame(frame)
        out = []
        node: str | None = frame
        while node is not None and node != WORLD:
            out.append(node)
            node = self._parent[node]
        return out

    def children(self, frame: str) -> list[str]:
        self._check_frame(frame)
        return list(self._children().get(frame, []))

    def affixment(self, child: str) -> Affixment | None:
        """The affixment that holds primitive ``child``, or None (it sits in world)."""
        return self._affix.get(child)

    @property
    def affixments(self) -> list[Affixment]:
        return list(self._affix.values())

    def subtree(self, frame: str) -> list[str]:
        """``frame`` and every frame subordinate to it, depth first."""
        self._check_frame(frame)
        kids = self._children()
        out, stack = [], [frame]
        while stack:
            node = stack.pop()
            out.append(node)
            stack.extend(reversed(kids.get(node, [])))
        return out

    def joints(self, device: str) -> np.ndarray:
        """Current joint values of ``device`` (copy), shape (n,)."""
        self._check_device(device)
        return self._joints_of(device).copy()

    def active_tcp(self, device: str) -> str:
        """The TCP frame the device's motions refer to (a tool's TCP after a tool change)."""
        self._check_device(device)
        return self._active_tcp[device]

    def T_world(self, frame: str) -> np.ndarray:
        """``T_world_frame``, shape (4, 4) (a copy)."""
        self._check_frame(frame)
        return self._pose(frame).copy()

    def T(self, a: str, b: str) -> np.ndarray:
        """``T_a_b``: pose of frame ``b`` expressed in frame ``a``, shape (4, 4)."""
        self._check_frame(a)
        self._check_frame(b)
        return spatial.invert_transform(self._pose(a)) @ self._pose(b)

    def T_parent(self, frame: str) -> np.ndarray:
        """Pose of ``frame`` relative to its current parent, shape (4, 4)."""
        self._check_frame(frame)
        if self._parent[frame] is None:
            return np.eye(4)
        return self.T(self._parent[frame], frame)

    def world_poses(self) -> dict[str, np.ndarray]:
        """Every frame's ``T_world_frame`` (copies), parents first."""
        return {k: v.copy() for k, v in self._world_poses().items()}

    # ------------------------------------------------------------------ changes
    def set_joints(self, device: str, q) -> None:
        """Set the joint values of ``device`` (SI); everything it carries follows.

        Values outside the joint limits are accepted (analysis may want them);
        callers that must refuse them check :meth:`joint_limit_violations`.
        """
        self._check_device(device)
        q = np.asarray(q, dtype=float)
        n = self.cell.devices[device].dof
        if q.shape != (n,):
            raise UserError(
                f"device '{device}' has {n} joint(s); got "
                f"{q.shape[0] if q.ndim == 1 else q.shape} value(s)"
            )
        if not np.all(np.isfinite(q)):
            raise UserError(f"joint values of '{device}' must be finite, got {q.tolist()}")
        self._q[device] = q.copy()
        self._stale.discard(device)
        self._cache = None
        self._poses.clear()  # only what hangs below the device moved; recomputed on demand
        self._links.pop(device, None)

    def defer_joints(self, devices, source) -> None:
        """Set the joints of ``devices`` to ``source(device)`` (shape (n,), SI) when each is
        first needed, not now: a simulation moves every device to each step's instant, and a
        line of many robots needs one device's joints there, not all of them."""
        self._stale = set(devices)
        self._source = source
        self._cache = None
        self._poses.clear()
        self._links.clear()

    def _joints_of(self, device: str) -> np.ndarray:
        """The device's joint values, taken from the deferred source first if it is stale (no
        cached pose can depend on a stale device: :meth:`defer_joints` cleared them)."""
        if device in self._stale:
            self._stale.discard(device)
            self._q[device] = np.array(self._source(device), dtype=float)
        return self._q[device]

    def joint_limit_violations(self, device: str) -> list[tuple[int, float, float, float]]:
        """(joint index, value, lower, upper) for each joint of ``device`` outside its limits."""
        dev = self.cell.devices[device]
        q = self._joints_of(device)
        lo, hi = dev.limit_array("lower"), dev.limit_array("upper")
        return [
            (int(i), float(q[i]), float(lo[i]), float(hi[i]))
            for i in np.nonzero((q < lo) | (q > hi))[0]
        ]

    def attach(
        self,
        child: str,
        parent: str,
        type: str = "rigid",
        kind: str | None = None,
        T_parent_child=None,
    ) -> Affixment:
        """Affix primitive ``child`` to frame ``parent``.

        An existing affixment of ``child`` is replaced (a grasp lifts a part
        off the table it rested on).  The child keeps its world pose unless
        ``T_parent_child`` is given.  Attaching a device with ``kind="tool"``
        makes its TCP the active TCP of the device that now carries it.

        Raises
        ------
        AffixmentError
            Unknown names, a non-primitive child, the report's hierarchy rules,
            or a cycle (``parent`` lies in ``child``'s subtree).
        """
        child_kind = self._primitive_kind(child)
        self._check_frame(parent)
        if type not in ("rigid", "non_rigid"):
            raise AffixmentError(f"affixment type must be 'rigid' or 'non_rigid', got '{type}'")
        owner = self.cell.frames[parent].owner
        owner_kind = self._owner_kind(parent)
        problem = rules.hierarchy_problem(child, child_kind, parent, owner, owner_kind)
        if problem is None:
            kp = rules.kind_problem(type, kind, child_kind, owner_kind)
            problem = ("kind", kp) if kp else None
        if problem:
            raise AffixmentError(problem[1])
        if parent in self.subtree(child):
            raise AffixmentError(
                f"affixing '{child}' to '{parent}' would form a cycle: '{parent}' is carried by "
                f"'{child}'"
            )
        T = (
            self.T(parent, child)
            if T_parent_child is None
            else np.asarray(T_parent_child, dtype=float)
        )
        if child in self._affix:
            self.detach(child)
        self._parent[child] = parent
        self._T_parent[child] = T
        aff = Affixment(parent, child, type, kind)
        self._affix[child] = aff
        self._invalidate()
        if kind == "tool" and child_kind == "device" and owner_kind == "device":
            self._active_tcp[owner] = self._active_tcp[child]
        return aff

    def detach(self, child: str) -> Affixment:
        """Remove ``child``'s affixment; it stays where it is, now on world (the tree splits).

        Raises
        ------
        AffixmentError
            ``child`` is not affixed to anything.
        """
        self._primitive_kind(child)
        aff = self._affix.get(child)
        if aff is None:
            raise AffixmentError(f"'{child}' is not affixed to anything (it sits in world)")
        T = self.T_world(child)
        del self._affix[child]
        self._parent[child] = WORLD
        self._T_parent[child] = T
        self._invalidate()
        owner = self.cell.frames[aff.parent].owner
        if owner in self._active_tcp and self._active_tcp[owner].split(".", 1)[0] == child:
            self._active_tcp[owner] = self.cell.devices[owner].tcps[0]
        return aff

    def move(self, frame: str, T_world_frame) -> None:
        """Place a primitive or free frame at ``T_world_frame``; its subtree follows.

        A primitive resting on another (non-rigid) slides or lifts off without
        moving its support.  A rigidly affixed one cannot move by itself.

        Raises
        ------
        AffixmentError
            ``frame`` is owned (auxiliary, link, TCP), is world, or is rigidly affixed.
        """
        self._check_frame(frame)
        decl = self.cell.frames[frame]
        if decl.kind not in ("natural", "free"):
            raise AffixmentError(
                f"'{frame}' is {decl.kind} frame owned by '{decl.owner}'; move '{decl.owner}' "
                "instead"
            )
        aff = self._affix.get(frame)
        if aff is not None and aff.type == "rigid":
            raise AffixmentError(
                f"'{frame}' is rigidly affixed to '{aff.parent}'; detach it first, or move what "
                "holds it"
            )
        T = np.asarray(T_world_frame, dtype=float)
        self._T_parent[frame] = (
            spatial.invert_transform(self._world_poses()[self._parent[frame]]) @ T
        )
        self._cache = None
        self._poses.clear()

    def place(self, frame: str, T_world_frame) -> None:
        """Correct the numbers of ``frame``: store the relative pose that puts it at
        ``T_world_frame``.

        Unlike :meth:`move` this ignores affixment semantics: it is what
        calibration does to a nominal pose (any frame with a stored pose -
        natural, auxiliary, free, TCP; not world or link frames).  Its subtree follows.
        """
        self._check_frame(frame)
        decl = self.cell.frames[frame]
        if decl.kind in ("world", "link"):
            raise UserError(f"'{frame}' is a {decl.kind} frame: it has no pose to correct")
        self._T_parent[frame] = spatial.invert_transform(
            self._world_poses()[self._parent[frame]]
        ) @ np.asarray(T_world_frame, dtype=float)
        self._cache = None
        self._poses.clear()

    def set_active_tcp(self, device: str, tcp: str) -> None:
        """Make ``tcp`` (a TCP of ``device`` or of a device it carries) the active TCP."""
        self._check_device(device)
        self._check_frame(tcp)
        decl = self.cell.frames[tcp]
        if decl.kind != "tcp" or tcp not in self.subtree(device):
            raise UserError(f"'{tcp}' is not a TCP carried by '{device}'")
        self._active_tcp[device] = tcp

    def mount_of(self, device: str, frame: str) -> tuple[int, np.ndarray]:
        """Where ``frame`` rides on ``device``: (link index 1..n, or 0 for the base;
        ``T_link_frame``).

        Raises
        ------
        UserError
            ``frame`` is not carried by the device.
        """
        self._check_device(device)
        self._check_frame(frame)
        links = list(self.cell.devices[device].link_frames)
        node = frame
        while node is not None:
            if node in links:
                return links.index(node) + 1, self.T(node, frame)
            if node == device:
                return 0, self.T(node, frame)
            node = self._parent[node]
        tcps = ", ".join(self.cell.devices[device].tcps)
        raise UserError(
            f"'{frame}' is not carried by device '{device}'; choose one of its TCPs ({tcps}) or a "
            "frame of a tool it holds"
        )

    def carried(self, device: str, exclude=()) -> list[tuple[str, int, list]]:
        """What rides on the links of ``device``: [(primitive name, link index, [(Inertial,
        T_link_body)])].

        Everything rigidly or non-rigidly below a link - grasped objects,
        aggregated devices (their links at the current joint values) - except
        the device's own links, sensors, and the primitives named in ``exclude``.
        """
        dev = self.cell.devices[device]
        links = list(dev.link_frames)
        out = []
        for name in self.subtree(device):  # what rides on it hangs below it
            kind = self.cell.primitive_kind(name)
            if kind is None or name == device or kind == "sensor" or name in exclude:
                continue
            node = self._parent[name]
            while node is not None and node not in links and node != device:
                node = self._parent[node]
            if node is None or node == device:
                continue
            k = links.index(node) + 1
            if kind == "object":
                out.append((name, k, [(self.cell.objects[name].inertial, self.T(node, name))]))
            else:
                other = self.cell.devices[name]
                out.append(
                    (
                        name,
                        k,
                        [
                            (link.inertial, self.T(node, frame))
                            for link, frame in zip(other.links, other.link_frames)
                        ],
                    )
                )
        return out

    def carried_loads(self, device: str, exclude=()) -> dict[int, list]:
        """Mass properties riding on each link of ``device``: link index -> [(Inertial,
        T_link_body)] (see :meth:`carried`).
        """
        loads: dict[int, list] = {}
        for _, k, bodies in self.carried(device, exclude):
            loads.setdefault(k, []).extend(bodies)
        return loads

    def snapshot(self) -> dict:
        """The mutable state (tree, relative poses, joints, active TCPs), for :meth:`restore`."""
        return {
            "parent": dict(self._parent),
            "T_parent": {k: v.copy() for k, v in self._T_parent.items()},
            "affix": dict(self._affix),
            "q": {k: self._joints_of(k).copy() for k in self._q},
            "active_tcp": dict(self._active_tcp),
        }

    def restore(self, snap: dict) -> None:
        self._parent = dict(snap["parent"])
        self._T_parent = {k: v.copy() for k, v in snap["T_parent"].items()}
        self._affix = dict(snap["affix"])
        self._q = {k: v.copy() for k, v in snap["q"].items()}
        self._stale.clear()
        self._active_tcp = dict(snap["active_tcp"])
        self._invalidate()

    def T_world_batch(self, frame: str, joints: dict[str, np.ndarray]) -> np.ndarray:
        """``T_world_frame`` for N joint states of the devices on its path to world, shape (N, 4,
        4).

        Parameters
        ----------
        joints : dict
            Device name -> joint values (N, n) for every device whose links
            lie between ``frame`` and world; others keep their current values.

        The tree is the current one (a batch spans no affixment change).
        """
        return self.T_world_frames([frame], joints)[frame].copy()

    def T_world_frames(
        self, frames: list[str], joints: dict[str, np.ndarray]
    ) -> dict[str, np.ndarray]:
        """``T_world_frame`` of several frames at N joint states, each (N, 4, 4).

        Parameters
        ----------
        frames : list of str
        joints : dict
            Device name -> joint values (N, n) for the devices whose links lie between the
            frames and world; others keep their current values.

        The devices' link transforms and the shared part of the frames' paths to world are
        computed once.  The tree is the current one (a batch spans no affixment change).
        """
        N = len(next(iter(joints.values()))) if joints else 1
        link_index = self._link_frames()
        links: dict[str, np.ndarray] = {}
        memo: dict[str, np.ndarray] = {WORLD: np.broadcast_to(np.eye(4), (N, 4, 4))}

        def pose(frame: str) -> np.ndarray:
            # up to the first frame already known, then down (no recursion on the tree's
            # depth: a hand-written chain of frames may be thousands deep)
            path = []
            node: str | None = frame
            while node is not None and node not in memo:
                path.append(node)
                node = self._parent[node]
            above = memo[node] if node is not None else memo[WORLD]
            for node in reversed(path):
                if node in link_index:
                    dev, i = link_index[node]
                    if dev not in links:
                        q = joints.get(dev)
                        q = (
                            np.broadcast_to(self._joints_of(dev), (N, self.cell.devices[dev].dof))
                            if q is None
                            else np.asarray(q, dtype=float)
                        )
                        links[dev] = self.cell.devices[dev].joint_transforms(q)
                    above = above @ links[dev][:, i]
                else:
                    above = above @ self._T_parent[node]
                memo[node] = above
            return above

        out = {}
        for frame in frames:
            self._check_frame(frame)
            out[frame] = pose(frame)
        links.clear()  # the batch's arrays go now, not with the closure
        memo.clear()
        return out

    # ------------------------------------------------------------------ internals
    def _invalidate(self):
        self._cache = None
        self._children_cache = None
        self._poses.clear()
        self._links.clear()

    def _pose(self, frame: str) -> np.ndarray:
        """``T_world_frame`` of one frame, computed along its path only: a line of many robots
        asks for one device's frames after every change of another's joints."""
        if self._cache is not None:
            return self._cache[frame]
        path = []
        node: str | None = frame
        while node is not None and node != WORLD and node not in self._poses:
            path.append(node)
            node = self._parent[node]
        T = np.eye(4) if node is None or node == WORLD else self._poses[node]
        for node in reversed(path):
            link = self._link_frames().get(node)
            if link is not None:
                device, i = link
                if device not in self._links:
                    self._links[device] = self.cell.devices[device].joint_transforms(
                        self._joints_of(device)
                    )
                T = T @ self._links[device][i]
            else:
                T = T @ self._T_parent[node]
            self._poses[node] = T
        return T

    def _link_frames(self) -> dict[str, tuple[str, int]]:
        if self._link_index is None:
            self._link_index = {
                f: (d, i)
                for d, dev in self.cell.devices.items()
                for i, f in enumerate(dev.link_frames)
            }
        return self._link_index

    def _check_frame(self, frame: str):
        if frame not in self._parent:
            from ..errors import did_you_mean

            raise UserError(f"unknown frame '{frame}'{did_you_mean(frame, self._parent)}")

    def _check_device(self, device: str):
        if device not in self.cell.devices:
            from ..errors import did_you_mean

            raise UserError(f"unknown device '{device}'{did_you_mean(device, self.cell.devices)}")

    def _primitive_kind(self, name: str) -> str:
        kind = self.cell.primitive_kind(name)
        if kind is None:
            self._check_frame(name)
            raise AffixmentError(
                f"'{name}' is not an object, sensor or device; only primitives are affixed"
            )
        return kind

    def _owner_kind(self, frame: str) -> str:
        decl = self.cell.frames[frame]
        if decl.kind in ("world", "free"):
            return decl.kind
        return self.cell.primitive_kind(decl.owner) or "world"

    def _children(self) -> dict[str, list[str]]:
        if self._children_cache is None:
            kids: dict[str, list[str]] = {}
            for name, parent in self._parent.items():  # dict order: declaration order
                if parent is not None:
                    kids.setdefault(parent, []).append(name)
            self._children_cache = kids
        return self._children_cache

    def _world_poses(self) -> dict[str, np.ndarray]:
        if self._cache is not None:
            return self._cache
        link_T = {}
        for name, dev in self.cell.devices.items():
            A = dev.joint_transforms(self._joints_of(name))
            for frame, Ai in zip(dev.link_frames, A):
                link_T[frame] = Ai
        kids = self._children()
        poses: dict[str, np.ndarray] = {WORLD: np.eye(4)}
        stack = list(reversed(kids.get(WORLD, [])))
        while stack:
            node = stack.pop()
            rel = link_T[node] if node in link_T else self._T_parent[node]
            poses[node] = poses[self._parent[node]] @ rel
            stack.extend(reversed(kids.get(node, [])))
        self._cache = poses
        return poses

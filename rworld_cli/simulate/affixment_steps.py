"""Affixment steps: grasp, release, place, attach and detach a tool - each a change of the
frame tree at its instant - as the scheduler's methods (a mixin: ``self`` is an
``engine._Scheduler``)."""

from __future__ import annotations

from ..model.program import ResolvedStep, Step
from ..world.tree import AffixmentError
from .timeline import Event, Track


class AffixmentSteps:
    """The affixment steps of the scheduler."""

    def _tree_change(
        self, device: str, tr: Track, step: Step, kind: str, child: str, action
    ) -> bool:
        try:
            aff = action()
        except AffixmentError as exc:
            self.fail(device, step, exc.message)
        tree = {
            "child": child,
            "parent": aff.parent if aff else None,
            "type": aff.type if aff else None,
            "kind": aff.kind if aff else None,
            "T_world_child": self.world.T_world(child).tolist(),
            "T_world_parent": self.world.T_world(aff.parent).tolist() if aff else None,
        }
        self.events.append(Event(tr.t, device, step.index, kind, step.describe(), tree))
        self.snapshots.append((tr.t, self.world.snapshot()))
        self._actions.append(ResolvedStep(step, tr.t, None, kind))
        return True

    def _held_by(self, device: str, child: str) -> bool:
        return child in self.world.subtree(device) and self.world.affixment(child) is not None

    def _grasp(self, device, tr, step):
        spec = step.spec
        tcp = self._resolve_tcp(device, spec.tcp)
        if tcp not in self.world.subtree(device):
            self.fail(device, step, f"'{tcp}' is not carried by {device}")
        aff = self.world.affixment(spec.object)
        if aff is not None and aff.type == "rigid" and aff.kind == "grasp":
            self.fail(
                device,
                step,
                f"'{spec.object}' is already held by '{aff.parent}'; release it there first",
            )
        return self._tree_change(
            device,
            tr,
            step,
            "grasp",
            spec.object,
            lambda: self.world.attach(spec.object, tcp, "rigid", "grasp"),
        )

    def _release(self, device, tr, step):
        obj = step.spec.object
        if not self._held_by(device, obj):
            self.fail(device, step, f"{device} does not hold '{obj}'")

        def act():
            self.world.detach(obj)
            return None

        return self._tree_change(device, tr, step, "release", obj, act)

    def _place(self, device, tr, step):
        spec = step.spec
        if step.goal is not None:  # a face set down on a plane feature
            return self._place_face(device, tr, step)
        if not self._held_by(device, spec.object):
            self.fail(device, step, f"{device} does not hold '{spec.object}'")
        return self._tree_change(
            device,
            tr,
            step,
            "place",
            spec.object,
            lambda: self.world.attach(spec.object, spec.on, "non_rigid", "rests_on"),
        )

    def _attach_tool(self, device, tr, step):
        spec = step.spec
        at = self._resolve_tcp(device, spec.at)
        if at not in self.world.subtree(device):
            self.fail(device, step, f"'{at}' is not carried by {device}")
        return self._tree_change(
            device,
            tr,
            step,
            "attach_tool",
            spec.tool,
            lambda: self.world.attach(spec.tool, at, "rigid", "tool"),
        )

    def _detach_tool(self, device, tr, step):
        spec = step.spec
        if spec.tool not in self.world.subtree(device) or spec.tool == device:
            self.fail(device, step, f"{device} does not carry '{spec.tool}'")
        if spec.on is not None:
            action = lambda: self.world.attach(spec.tool, spec.on, "non_rigid", "rests_on")  # noqa: E731
        else:

            def action():
                self.world.detach(spec.tool)
                return None

        return self._tree_change(device, tr, step, "detach_tool", spec.tool, action)

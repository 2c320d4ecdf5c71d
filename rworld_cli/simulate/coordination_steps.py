"""Coordination steps: ``wait`` (a time, or another device's end) and ``sync`` barriers, as the
scheduler's methods (a mixin: ``self`` is an ``engine._Scheduler``)."""

from __future__ import annotations

from .timeline import Event


class CoordinationSteps:
    """The coordination steps of the scheduler."""

    def _wait(self, device, tr, step):
        spec = step.spec
        if spec.time is not None:
            self.events.append(Event(tr.t, device, step.index, "wait", step.describe()))
            tr.t += spec.time
            return True
        other = self.tracks[spec.for_]
        if other.status == "done":
            tr.t = max(tr.t, other.end)
            self.events.append(Event(tr.t, device, step.index, "wait", f"{spec.for_} has finished"))
            return True
        tr.status, tr.waiting_on = "waiting", ("device", spec.for_)
        self.events.append(
            Event(tr.t, device, step.index, "wait", f"waiting for {spec.for_} to finish")
        )
        return False

    def _sync(self, device, tr, step):
        name = step.spec
        k = tr.sync_counts.get(name, 0)
        tr.sync_counts[name] = k + 1
        arrivals = self.barriers.setdefault((name, k), {})
        arrivals[device] = tr.t
        participants = [d for d in self.order if self.sync_totals[d].get(name, 0) > k]
        if len(arrivals) < len(participants):
            tr.status, tr.waiting_on = "waiting", ("sync", name, k)
            return False
        t_meet = max(arrivals.values())
        for d in participants:
            o = self.tracks[d]
            o.t = t_meet
            self.events.append(
                Event(
                    t_meet,
                    d,
                    o.program.steps[o.pc].index,
                    "sync",
                    f"sync {name} ({', '.join(participants)})",
                )
            )
            if d != device:
                o.status, o.waiting_on = "running", None
                o.pc += 1
                if o.pc >= len(o.program.steps):
                    self.finish(d)
        return True

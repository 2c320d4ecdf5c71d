"""Contact steps: guarded moves cut where their sensor first senses, ``probe:`` records,
``sense:`` readings and ``capture:`` images, as the scheduler's methods (a mixin: ``self`` is
an ``engine._Scheduler``)."""

from __future__ import annotations

import numpy as np

from ..model.program import ResolvedStep, Step
from ..motion.trajectory import StoppedMove
from .timeline import Event, Track

LATCH_TIME = 1e-9  # [s]: a guarded move's contact instant is found to this (a probe's latch)


class ContactSteps:
    """The contact steps of the scheduler."""

    def _guard(self, device: str, tr: Track, step: Step, seg, sensor: str):
        """Cut a guarded move where its sensor first senses something: the first clock sample
        that senses, then bisection between it and the sample before down to ``LATCH_TIME``, as
        a touch-trigger probe latches the position at contact."""
        from ..sensing.sensors import ball_may_touch, read_sensors

        times = np.append(np.arange(seg.t0, seg.t1, self.run.dt), seg.t1)
        q_move = seg.sample(times)[0]

        def senses(t: float, q=None):
            self.set_time(t)
            self.world.set_joints(device, seg.sample(np.array([t]))[0][0] if q is None else q)
            return read_sensors(self.world, [sensor])[0]

        samples = range(len(times))
        if self.world.cell.sensors[sensor].ball is not None:
            # a ball reads nothing where it reaches no shape's box: only the other samples
            # are read, one state at a time (sensing needs the whole world at each instant)
            joints = {d: self.q_over(d, times) for d in self.tracks if d != device}
            samples = np.flatnonzero(ball_may_touch(self.world, sensor, joints | {device: q_move}))
        self._latched[device] = None
        for k in samples:
            t, q = times[k], q_move[k]
            reading = senses(t, q)
            if not reading.active:
                continue
            lo, hi = (float(times[k - 1]), float(t)) if k else (float(t), float(t))
            while hi - lo > LATCH_TIME:
                mid = 0.5 * (lo + hi)
                if senses(mid).active:
                    hi = mid
                else:
                    lo = mid
            reading = senses(hi)
            q_stop = self.world.joints(device)
            contact = self.world.T_world(sensor)[:3, 3].copy()
            record = reading.as_dict() | {
                "q": q_stop.tolist(),  # where the device stopped
                "point": contact.tolist(),  # the sensor origin (a ball tip's centre) at contact
            }
            self._latched[device] = {
                # the guarded move's place among the device's resolved moves (a feature step
                # makes several moves on one program line)
                "move": len(self.resolved[device]) + len(self._actions),
                "sensor": sensor,
                "point": contact,
                "objects": list(reading.objects),
                "step": step.index,
                "t": hi,
            }
            self.events.append(
                Event(
                    hi, device, step.index, "guard", f"{sensor} triggered: stopped", reading=record
                )
            )
            return StoppedMove(seg, hi)
        self.events.append(
            Event(
                seg.t1,
                device,
                step.index,
                "guard",
                f"{sensor} did not trigger: the move ran to its end",
            )
        )
        return seg

    def _probe(self, device, tr, step):
        """Record where the last guarded move's sensor touched, as a probe point of a feature;
        or, for a probe step on its own, the probing moves of the feature."""
        if step.goal is not None:
            return self._probe_moves(device, tr, step)
        return self._record_probe(device, tr, step, step.spec.feature)

    def _record_probe(self, device, tr, step, feature: str) -> bool:
        latched = self._latched.get(device)
        if latched is None:
            self.fail(
                device,
                step,
                f"nothing to record for {feature}: the guarded move before this step "
                "ended without contact (or there was none)",
            )
        self._latched[device] = None  # one point per contact
        self._actions.append(ResolvedStep(step, tr.t, None, "probe", feature))
        self.events.append(
            Event(
                tr.t,
                device,
                step.index,
                "probe",
                f"probe {feature}: {latched['sensor']} touched {', '.join(latched['objects'])}",
                reading={
                    "feature": feature,
                    "point": latched["point"].tolist(),
                    "sensor": latched["sensor"],
                    "objects": latched["objects"],
                    "guard_step": latched["step"] + 1,
                    "guard_move": latched["move"],
                },
            )
        )
        return True

    def _sense(self, device, tr, step):
        from ..sensing.sensors import read_sensors

        reading = read_sensors(self.world, [step.spec])[0]
        what = ", ".join(reading.objects) if reading.objects else "nothing"
        self.events.append(
            Event(
                tr.t,
                device,
                step.index,
                "sense",
                f"{step.spec}: {'active' if reading.active else 'inactive'} ({what})",
                reading=reading.as_dict(),
            )
        )
        return True

    def _capture(self, device, tr, step):
        """Stand still ``settle`` seconds, take the image (the camera's reading at that
        instant, recorded as a ``capture`` event; an action the exporters write as the
        trigger and the pose report), hold still while the trigger is on (``exposure``)."""
        from ..sensing.sensors import read_sensors

        spec = step.spec
        tr.t += spec.settle
        self.set_time(tr.t)
        reading = read_sensors(self.world, [spec.camera])[0].as_dict()
        self._actions.append(ResolvedStep(step, tr.t, None, "capture"))
        image = (reading.get("image") or {}).get("boards", {})
        seen = ", ".join(f"{b['seen']}/{b['total']} corners of {n}" for n, b in image.items())
        self.events.append(
            Event(
                tr.t,
                device,
                step.index,
                "capture",
                f"capture {spec.camera}: {seen or 'no board in the cell'}",
                reading=reading,
            )
        )
        tr.t += spec.exposure
        return True

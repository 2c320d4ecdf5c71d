"""``rworld plan-robot-calibration``: the joint states a robot calibration measures at (an
instrument's poses, or touches of the cell's features), chosen for the identification, and the
program that visits them (the choice itself: :mod:`rworld_cli.calibration.robotplan`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import UserError

if TYPE_CHECKING:  # imported where used: the api package is read by every command
    from ..calibration.robotplan import CandidatePool


@dataclass
class RobotPosePlanRun:
    """What ``plan-robot-calibration`` chose and wrote."""

    device: str
    target: str
    instrument: str  # "tracker" or "probe"
    poses: int
    candidates: int
    rejected: int  # unreachable, or colliding on the way
    identifiable: int
    predicted: float  # [m] rms error of the calibrated model, the estimate's own
    random_same: float
    random_double: float
    best_possible: float  # [m] no choice of as many candidates predicts less
    q: np.ndarray  # (N, n) SI, in visiting order (touches: at the contact)
    features: list[str]  # touches: the feature of each; a tracker: empty
    program: str | None
    template: str | None
    dropped: int = 0  # poses replaced because the program collided on the way to them
    seconds: float = 0.0
    constraints: dict = field(default_factory=dict)  # tracker: candidates lost, by reason

    def as_dict(self) -> dict:
        return {
            "constraints_lost": self.constraints,
            "device": self.device,
            "target": self.target,
            "instrument": self.instrument,
            "poses": self.poses,
            "candidates": self.candidates,
            "rejected": self.rejected,
            "identifiable": self.identifiable,
            "predicted_rms_mm": self.predicted * 1000,
            "random_same_count_rms_mm": self.random_same * 1000,
            "random_double_count_rms_mm": self.random_double * 1000,
            "best_possible_rms_mm": self.best_possible * 1000,
            "joints": self.q.tolist(),
            "features": self.features,
            "program": self.program,
            "template": self.template,
            "dropped_on_the_way": self.dropped,
            "seconds": self.seconds,
        }


def _visit_steps(pool: CandidatePool, k: int, label: int, cell, device: str, target: str, sensor):
    """The steps that visit candidate ``k`` from home and back (mm, deg)."""
    from ..calibration.probing import _offset
    from ..schema.robotobs import file_scale

    values = [float(f"{v:.6f}") for v in pool.q_path[k] * file_scale(cell.devices[device])]
    if pool.touches is None:
        return [
            ({"move": {"joints": values}}, f"pose {label}"),
            ({"wait": {"time": 1.0}}, "the instrument's reading"),
            ({"move": {"to": "home"}}, None),
        ]
    t = pool.touches
    feature = t.features[k]
    owner = cell.features[feature].owner
    tcp = target.split(".", 1)[1] if target.startswith(device + ".") else target
    guarded = {"to": owner, "tcp": tcp, "offset": _offset(t.T_owner_end[k])}
    guarded.update(motion="linear", speed=0.04, until=sensor)
    back = {"to": owner, "tcp": tcp, "offset": _offset(t.T_owner_approach[k]), "motion": "linear"}
    return [
        ({"move": {"joints": values}}, f"touch {label}: {feature}"),
        ({"move": guarded}, "record the joint values at the trigger"),
        ({"probe": feature}, None),
        ({"move": back}, None),
        ({"move": {"to": "home"}}, None),
    ]


def plan_robot_calibration(
    cell_path: str,
    device: str,
    count: int,
    target: str | None = None,
    sigma: float = 2e-5,
    candidates: int = 2000,
    seed: int = 0,
    program: str | None = None,
    template: str | None = None,
    instrument: str = "tracker",
    features: list[str] | None = None,
    floor: float | None = None,
    instrument_at: np.ndarray | None = None,
    acceptance: float | None = None,
) -> RobotPosePlanRun:
    """Choose ``count`` joint states to measure for ``calibrate-robot``, then the choice that
    predicts the smallest error of the calibrated model
    (:func:`rworld_cli.calibration.robotplan.select_poses`), visited in a short order.

    ``instrument``: ``"tracker"`` (an instrument measures ``target``'s point; candidates are
    random joint states within the limits) or ``"probe"`` (self-calibration: the robot's own
    ball-tip touch probe, centred on ``target``, touches ``features`` of known geometry -
    planes and edges; candidates are touches on material with the stylus within 40 deg of the
    normal, :func:`rworld_cli.calibration.robotplan.touch_candidates`).  A candidate is kept
    when the robot touches nothing there (touches: at the approach) and on the joint path from
    home.  ``program``: a program that visits them - a pause at each for the instrument, or a
    guarded move to each touch - checked in simulation (a pose the robot collides on the way to
    is replaced).  ``template``: an observation or contacts file of the poses, to fill in.

    A tracker's candidates must also keep the target above the floor - ``floor`` [m, world z],
    else the robot's mounting plane (its base frame's xy plane) - and, with the instrument at
    ``instrument_at`` (3,) [m, world], face it within ``acceptance`` [rad] of the target's z
    axis (a reflector's acceptance cone) with the line of sight clear of the robot
    (:func:`~rworld_cli.calibration.robotplan.tracker_visible`).

    Raises
    ------
    UserError
        Unknown device, target or feature, no touch probe, too few usable candidates, bad
        numbers.
    CheckFailed
        The program still collides after the replacements.
    """
    import time

    from ..calibration.robot import RobotModel
    from ..calibration.robotplan import (
        CandidatePool,
        collision_free_states,
        select_poses,
        touch_candidates,
        tracker_pool,
        tracker_visible,
    )
    from ..errors import CheckFailed, did_you_mean
    from ..fileio import atomic_write_text, output_set
    from ..schema.loader import load_cell
    from ..schema.programs import load_run, program_text
    from ..simulate.engine import simulate
    from ..world.tree import World

    started = time.perf_counter()
    cell = load_cell(cell_path).cell
    if device not in cell.devices:
        raise UserError(f"unknown device '{device}'{did_you_mean(device, cell.devices)}")
    if not (count >= 1 and candidates >= count and sigma > 0 and np.isfinite(sigma)):
        raise UserError("give --poses >= 1, --candidates >= --poses and a sigma above 0")
    dev = cell.devices[device]
    if program is not None and not np.isfinite(dev.limit_array("acceleration")).any():
        # said once, before minutes of planning, not per move of the program checked at the end
        raise UserError(
            f"--program: no joint of '{device}' has an acceleration limit, so nothing times the "
            "program's moves: add 'acceleration' to its joints' limits in the cell (an imported "
            "robot: import it with --joint-limits joint_limits.yaml); nothing written"
        )
    sensor: str | None = None
    radius = 0.0
    if instrument == "probe":
        from ..calibration.probing import find_probe

        if features is None or not features:
            raise UserError(
                "--instrument probe touches features of known geometry: name them with "
                "--feature (planes and edges of a calibrated artefact or part)"
            )
        target, sensor = find_probe(cell, device, target, None)
        radius = float(cell.sensors[sensor].ball or 0.0)  # find_probe: a ball-tip probe
    elif instrument != "tracker":
        raise UserError(f"unknown instrument '{instrument}': tracker or probe")
    target = target or dev.tcps[0]
    if target not in cell.frames and f"{device}.{target}" in cell.frames:
        target = f"{device}.{target}"
    if target not in cell.frames:
        raise UserError(f"unknown frame '{target}'{did_you_mean(target, cell.frames)}")
    world = World(cell)
    link, T_link_target = world.mount_of(device, target)
    model = RobotModel(
        dev, np.linalg.inv(world.T_world(device)), link, T_link_target[:3, 3].copy(), False
    )
    rng = np.random.default_rng(seed)
    constraints: dict[str, int] = {}
    if features and instrument == "probe":
        touches, tried = touch_candidates(cell, device, target, radius, features, candidates, seed)
        pool = CandidatePool(touches.q, touches.q_approach, touches.normals, touches)
    else:
        pool, tried = tracker_pool(dev, rng, candidates), candidates
        seen, lost = tracker_visible(
            cell, device, target, pool.q, floor, instrument_at, acceptance, world
        )
        pool = CandidatePool(pool.q[seen], pool.q_path[seen])
        constraints = lost
    # each pose is visited from home and back: the pose and the joint path to it must be free
    fractions = np.linspace(0.125, 1.0, 8)
    path = dev.home + fractions[:, None, None] * (pool.q_path - dev.home)[None]  # (8, M, n)
    free = collision_free_states(cell, device, path.reshape(-1, dev.dof)).reshape(8, -1).all(axis=0)
    usable_count = int(free.sum())
    if usable_count < count:
        lost_said = "".join(f"; {n} {why}" for why, n in constraints.items() if n)
        raise UserError(
            f"only {usable_count} of {tried} candidates are reachable and free of "
            f"collisions{lost_said}; ask for fewer poses or more candidates"
        )
    banned = np.logical_not(free)
    dropped = 0
    text = ""
    for _ in range(6):  # a pose the robot collides on the way to is replaced
        usable = np.nonzero(~banned)[0]
        chosen, figures = select_poses(
            model,
            pool.q[usable],
            count,
            sigma,
            seed,
            normals=None if pool.normals is None else pool.normals[usable],
        )
        picked = usable[chosen]
        picked = picked[np.argsort(np.abs(pool.q_path[picked] - dev.home).max(axis=1))]
        if program is None:
            break
        steps: list[tuple[dict, str | None]] = []
        per = 3 if pool.touches is None else 5
        for k, index in enumerate(picked):  # from home to each pose and back
            steps += _visit_steps(pool, int(index), k + 1, cell, device, target, sensor)
        what = f"measure {target} at each" if sensor is None else f"touch with {sensor}"
        from .cells import installed_schemas

        schemas = installed_schemas()
        text = program_text(
            {
                "header": [
                    f"Robot calibration poses for '{device}' (rworld plan-robot-calibration): "
                    f"{count} of {usable_count} usable candidates, {what}",
                ],
                "device": device,
                "units": {"length": "mm", "angle": "deg"},
                "steps": steps,
            },
            None if schemas is None else str(schemas),
        )
        trial = Path(program).with_name(f".{Path(program).name}.trial")
        trial.write_text(text)  # checked before it is written: the real file appears whole
        try:
            result = simulate(load_run(cell_path, str(trial)), report=False)
        finally:
            trial.unlink(missing_ok=True)
        bad = set()
        if result.collisions is not None:
            for contact in result.collisions.contacts:
                if contact.contact.collision:
                    bad |= {s.step // per for s in contact.steps if s.device == device}
        if result.ok and not bad:
            break
        if not bad:  # a limit broken, not a collision: the program says which
            raise CheckFailed(f"the calibration program breaks a limit: {result.violations[0]}")
        dropped += len(bad)
        banned[picked[[k for k in sorted(bad) if k < len(picked)]]] = True
        if int((~banned).sum()) < count:
            break
    else:
        raise CheckFailed(
            "the calibration program still collides on the way between poses after replacing "
            f"{dropped}: check {program}"
        )
    if program is not None and not (result.ok and not bad):
        raise CheckFailed(
            f"the calibration program collides on the way to {len(bad)} poses and too few "
            f"candidates are left to replace them: check {program}"
        )
    chosen_features = [] if pool.touches is None else [pool.touches.features[k] for k in picked]
    with output_set():  # the program and the template appear together or not at all
        if program is not None:
            atomic_write_text(program, text)
        if template is not None:
            from ..schema.robotobs import contacts_template, observation_template

            if pool.touches is None:
                nominal = model.points(np.zeros(len(model.names)), pool.q[picked])
                filled = observation_template(dev, target, pool.q[picked], nominal, sigma)
            else:
                filled = contacts_template(
                    dev, target, pool.q[picked], chosen_features, sigma, radius
                )
            atomic_write_text(template, filled)
    return RobotPosePlanRun(
        device,
        target,
        instrument,
        count,
        tried,
        tried - usable_count,
        int(figures["identifiable"]),
        float(figures["predicted"]),
        float(figures["random_same"]),
        float(figures["random_double"]),
        float(figures["best_possible"]),
        pool.q[picked],
        chosen_features,
        program,
        template,
        dropped,
        time.perf_counter() - started,
        constraints,
    )

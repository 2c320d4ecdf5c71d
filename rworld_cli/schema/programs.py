"""Program and run files: read and checked against the cell, with located errors, into
``model.program``.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from ..errors import Issue, UserError, did_you_mean
from ..model.cell import CellModel
from ..model.program import Program, Run, Step
from ..units import ANGLE, COLLISION_TOLERANCE, LENGTH, parse_length
from . import program as sp
from .loader import body_names, joint_values, load_cell, pose_to_matrix, validate_document
from .yamlio import Marked, comment_text, parse_yaml_text, read_yaml, yaml_value


def _step_spec(step: sp.Step):
    return getattr(step, step.kind)


def _check_joint_goal(doc, path, spec, step, device, L, A, issues) -> None:
    """``move: {joints: [...]}``: one value per joint, the file's units, within the limits."""
    if device is None:
        return
    q, why = joint_values(device, spec.joints, L, A)
    if why is not None:
        issues.append(doc.issue(path, why))
        return
    step.joints = q
    if not np.isfinite(device.limit_array("acceleration")).any():
        issues.append(
            doc.issue(
                path,
                f"no joint of '{device.name}' has an acceleration limit, so nothing times its "
                "moves; add them to the cell",
            )
        )


def _check_config(doc, path, spec, step, device, named, L, A, issues) -> None:
    """A move's ``config:``: an arm's configuration, joint values to be near (SI)."""
    config = spec.config
    wanted = {k: getattr(config, k) for k in ("shoulder", "elbow", "wrist")}
    step.configuration = {k: v for k, v in wanted.items() if v is not None}
    if named:
        issues.append(
            doc.issue(path, f"'{spec.to}' is a joint position: it has no other configuration")
        )
        return
    if device is None:
        return
    arm = device.dof == 6 and all(j.kind == "revolute" for j in device.joints)
    if step.configuration and not arm:
        issues.append(
            doc.issue(
                path,
                f"shoulder, elbow and wrist name the configurations of 6-axis arms; "
                f"'{device.name}' has {device.dof} joint(s): give 'near:' joint values instead",
            )
        )
    if config.near is None:
        return
    if spec.motion == "linear":
        issues.append(
            doc.issue(
                path + ("near",),
                "a linear move follows its line from where the joints are: 'near' is for joint "
                "moves",
            )
        )
        return
    near, why = joint_values(device, config.near, L, A, limits=False)
    if why is not None:
        issues.append(doc.issue(path + ("near",), why))
        return
    step.near = near


def _check_program(
    doc: Marked, pf: sp.ProgramFile, cell: CellModel, run_devices: set[str], issues: list[Issue]
) -> Program:
    units = pf.units
    L = LENGTH[units.length] if units and units.length else None
    A = ANGLE[units.angle] if units and units.angle else None
    device = cell.devices.get(pf.device)
    if device is None:
        issues.append(
            doc.issue(
                ("device",), f"unknown device '{pf.device}'{did_you_mean(pf.device, cell.devices)}"
            )
        )
    primitives = set(cell.objects) | set(cell.devices) | set(cell.sensors)

    def frame(path, name, what="frame"):
        if name not in cell.frames and f"{pf.device}.{name}" not in cell.frames:
            issues.append(
                doc.issue(path, f"unknown {what} '{name}'{did_you_mean(name, cell.frames)}")
            )

    def obj(path, name, kinds=("object",)):
        pool = {n for n in primitives if cell.primitive_kind(n) in kinds}
        if name not in pool:
            issues.append(
                doc.issue(path, f"unknown {' or '.join(kinds)} '{name}'{did_you_mean(name, pool)}")
            )

    steps = []
    for i, raw in enumerate(pf.steps):
        spec = _step_spec(raw)
        path = ("steps", i, raw.kind)
        line = doc.position(("steps", i))[0]
        step = Step(i, raw.kind, spec, f"{doc.file}:{line}")
        if raw.kind == "move" and spec.joints is not None:
            _check_joint_goal(doc, path + ("joints",), spec, step, device, L, A, issues)
        elif raw.kind == "move":
            target = spec.to
            named = device is not None and (target == "home" or target in device.positions)
            if not named:
                if target not in cell.frames:
                    choices = list(cell.frames) + (
                        list(device.positions) + ["home"] if device else []
                    )
                    where = f" or a position of '{device.name}'" if device else ""
                    issues.append(
                        doc.issue(
                            path + ("to",),
                            f"'{target}' is not a frame{where}{did_you_mean(target, choices)}",
                        )
                    )
            elif spec.offset is not None or spec.motion == "linear":
                issues.append(
                    doc.issue(
                        path + ("to",),
                        f"'{target}' is a joint position of '{device.name}': it takes a joint "
                        "move without offset",
                    )
                )
            if spec.tcp is not None:
                frame(path + ("tcp",), spec.tcp)
            if spec.until is not None and spec.until not in cell.sensors:
                issues.append(
                    doc.issue(
                        path + ("until",),
                        f"unknown sensor '{spec.until}'{did_you_mean(spec.until, cell.sensors)}",
                    )
                )
            if spec.touch:
                bodies = body_names(cell.objects, cell.devices)
                depths = spec.touch if isinstance(spec.touch, dict) else dict.fromkeys(spec.touch)
                for k, (name, depth) in enumerate(depths.items()):
                    at = path + ("touch", name if isinstance(spec.touch, dict) else k)
                    if name not in bodies:
                        issues.append(
                            doc.issue(
                                at,
                                f"unknown object, device or link '{name}'"
                                f"{did_you_mean(name, bodies)}",
                            )
                        )
                    if depth is None:
                        continue
                    if not isinstance(depth, str) and L is None:
                        issues.append(
                            doc.issue(
                                at,
                                f"a bare depth ({depth}) needs the file's units.length, and "
                                "rworld never guesses it: write it with its unit (2mm) or add "
                                "'units: {length: mm, angle: deg}'",
                            )
                        )
                        continue
                    try:
                        step.touch[name] = parse_length(
                            depth,
                            f"the depth '{name}' may be touched to",
                            units.length if units and units.length else "",
                        )
                    except ValueError as exc:
                        issues.append(doc.issue(at, str(exc)))
                for name in depths:
                    step.touch.setdefault(name, None)
            if spec.config is not None:
                _check_config(doc, path + ("config",), spec, step, device, named, L, A, issues)
            if spec.offset is not None and (L is None or A is None):
                issues.append(
                    doc.issue(
                        path + ("offset",),
                        "an offset needs the file's units, and rworld never guesses them: add "
                        "'units: {length: mm, angle: deg}' at the top of the program",
                    )
                )
            elif spec.offset is not None:
                T, error, warning = pose_to_matrix(spec.offset, L, A)
                if error:
                    issues.append(doc.issue(path + ("offset",), error))
                step.T_offset = T
            if device is not None and not np.isfinite(device.limit_array("acceleration")).any():
                issues.append(
                    doc.issue(
                        path,
                        f"no joint of '{device.name}' has an acceleration limit, so nothing times "
                        "its moves; "
                        "add them to the cell",
                    )
                )
        elif raw.kind in ("grasp", "release"):
            obj(path + ("object",), spec.object, ("object", "sensor"))
            if raw.kind == "grasp" and spec.tcp is not None:
                frame(path + ("tcp",), spec.tcp)
        elif raw.kind == "place":
            obj(path + ("object",), spec.object, ("object", "sensor"))
            frame(path + ("on",), spec.on)
        elif raw.kind in ("attach_tool", "detach_tool"):
            obj(path + ("tool",), spec.tool, ("device", "object"))
            if spec.at is not None:
                frame(path + ("at",), spec.at)
            if spec.on is not None:
                frame(path + ("on",), spec.on)
        elif raw.kind == "sense":
            if spec not in cell.sensors:
                issues.append(
                    doc.issue(
                        ("steps", i, "sense"),
                        f"unknown sensor '{spec}'{did_you_mean(spec, cell.sensors)}",
                    )
                )
        elif raw.kind == "probe":
            if spec.feature not in cell.features:
                issues.append(
                    doc.issue(
                        path + ("feature",),
                        f"unknown feature '{spec.feature}'"
                        f"{did_you_mean(spec.feature, cell.features)}",
                    )
                )
        elif raw.kind == "wait" and spec.for_ is not None:
            if spec.for_ not in run_devices:
                issues.append(
                    doc.issue(
                        path + ("for",),
                        f"no program of this run drives '{spec.for_}': waiting for it would never "
                        "end" + did_you_mean(spec.for_, run_devices),
                    )
                )
            elif spec.for_ == pf.device:
                issues.append(
                    doc.issue(path + ("for",), "a device cannot wait for its own program to end")
                )
        steps.append(step)
    return Program(pf.device, doc.file, steps)


def load_run(
    cell_path: str, run_path: str, dt: float | None = None, pose_files: list[str] | None = None
) -> Run:
    """Load a cell and a run file (and its programs); every problem at once.

    A program file given as ``run_path`` runs alone (``dt`` default 0.01 s).

    Raises
    ------
    UserError
        Located issues in the cell, run or program files (exit 2).
    """
    cell = load_cell(cell_path, pose_files=pose_files).cell
    run_doc = read_yaml(run_path)
    if isinstance(run_doc.data, dict) and "device" in run_doc.data and "steps" in run_doc.data:
        run_doc = parse_yaml_text(
            f"programs: [{json.dumps(Path(run_path).name)}]\ndt: {dt or 0.01!r}\n",
            str(Path(run_path).parent / "(program run)"),
        )
    rf = validate_document(run_doc, sp.RunFile)
    issues: list[Issue] = []
    base = Path(run_path).parent
    docs = []
    for i, rel in enumerate(rf.programs):
        path = Path(os.path.normpath(base / rel))
        if not path.is_file():
            issues.append(run_doc.issue(("programs", i), f"no such program file: {path}"))
            continue
        try:
            doc = read_yaml(path)
            docs.append((i, doc, validate_document(doc, sp.ProgramFile)))
        except UserError as exc:
            issues.extend(exc.issues)
    devices_seen: dict[str, int] = {}
    for i, doc, pf in docs:
        if pf.device in devices_seen:
            issues.append(
                run_doc.issue(
                    ("programs", i),
                    f"'{pf.device}' already has a program in this run (entry "
                    f"{devices_seen[pf.device] + 1}); a device runs one program",
                )
            )
        devices_seen.setdefault(pf.device, i)
    run_devices = set(devices_seen)
    programs = [_check_program(doc, pf, cell, run_devices, issues) for _, doc, pf in docs]
    warnings = []
    sync_users: dict[str, set[str]] = {}
    for prog in programs:
        for st in prog.steps:
            if st.kind == "sync":
                sync_users.setdefault(st.spec, set()).add(prog.device)
    for prog in programs:
        for st in prog.steps:
            if st.kind == "sync" and len(sync_users[st.spec]) < 2:
                warnings.append(
                    Issue(
                        st.where.rsplit(":", 1)[0],
                        int(st.where.rsplit(":", 1)[1]),
                        1,
                        f"steps[{st.index}].sync",
                        f"sync '{st.spec}' appears in no other program of the run; it passes at "
                        "once",
                        "warning",
                    )
                )
    # the model checked them already (located); here they become metres
    lengths = {
        key: parse_length(getattr(rf, key), key)
        for key in ("clearance", "collision_tolerance")
        if getattr(rf, key) is not None
    }
    if issues:
        raise UserError(
            f"{run_path}: {len(issues)} error(s)",
            sorted(issues, key=lambda i: (i.file, i.line, i.column)),
        )
    return Run(
        cell,
        programs,
        dt if dt is not None else rf.dt,
        run_path,
        warnings,
        clearance=lengths.get("clearance", 0.0),
        collision_tolerance=lengths.get("collision_tolerance", COLLISION_TOLERANCE),
    )


def flow(value) -> str:
    """A program's value as one line of YAML flow text: mappings and lists by structure, their
    keys the format's own words, every name or text a quoted scalar (:func:`yaml_value`)."""
    if isinstance(value, dict):
        return "{" + ", ".join(f"{key}: {flow(v)}" for key, v in value.items()) + "}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(flow(v) for v in value) + "]"
    if isinstance(value, float):
        return repr(value)
    return yaml_value(value)


def program_text(doc: dict) -> str:
    """A program file from data: ``header`` (comment lines), ``device``, ``description``,
    ``units``, ``steps`` as (step mapping, trailing comment or None).  Written through the YAML
    library, so reading it back gives the same data whatever the names hold."""
    lines = ["# yaml-language-server: $schema=../../../schemas/program.schema.json"]
    lines += [f"# {comment_text(line)}" for line in doc.get("header", [])]
    lines.append(f"device: {yaml_value(doc['device'])}")
    if doc.get("description") is not None:
        lines.append(f"description: {yaml_value(doc['description'])}")
    if doc.get("units") is not None:
        lines.append(f"units: {flow(doc['units'])}")
    lines.append("steps:")
    for step, comment in doc["steps"]:
        [(kind, spec)] = step.items()  # one step, one kind
        line = f"  - {kind}: {flow(spec)}"
        lines.append(line + (f"   # {comment_text(comment)}" if comment else ""))
    return "\n".join(lines) + "\n"

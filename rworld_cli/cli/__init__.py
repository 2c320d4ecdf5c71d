"""The ``rworld`` command line.

Commands live in their own modules and are imported only when run, so
``rworld --help`` stays fast (numpy, pydantic, scipy, trimesh load lazily).
"""

from __future__ import annotations

import importlib
import os
import sys
import warnings

# One BLAS thread unless the caller sets another count (before numpy loads OpenBLAS): rworld's
# matrices are small (a few hundred rows at most), and OpenBLAS's threads cost more than they
# give there - on a core another process keeps busy (a CI runner, a Dask worker, two commands
# at once) far more (a 417 x 417 solve 170 ms against 6 ms on one thread; docs/performance.md)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import click

from .. import __version__

# name -> (module, function, one-line help shown by `rworld --help` without importing it)
COMMANDS = {
    "validate": (
        "validate",
        "validate",
        "Check cell, pose, program and run files; exit 2 with file:line:col lines.",
    ),
    "show": ("show", "show", "Print a cell's frame tree with world poses, affixments and masses."),
    "schema": ("schema_cmd", "schema", "Write (or --check) the JSON Schemas of the file formats."),
    "kinematics": (
        "kinematics",
        "kinematics",
        "Forward kinematics, Jacobians, inverse kinematics (fk | jacobian | ik).",
    ),
    "dynamics": (
        "dynamics",
        "dynamics",
        "Inverse and forward dynamics, static torques (inverse | forward | static).",
    ),
    "simulate": (
        "simulate",
        "simulate",
        "Run programs of several devices on one clock; timelines, events, limits, plots, an "
        "animated glTF and an HTML viewer.",
    ),
    "view": (
        "simulate",
        "view",
        "A self-contained HTML page that plays a run written by 'simulate -o DIR'.",
    ),
    "check": (
        "simulate",
        "check",
        "For CI: exit 1 when a run's programs break a joint limit, collide or come too close.",
    ),
    "sweep": (
        "sweep",
        "sweep",
        "Check a run over a grid of payload mass x speed override x pose files; table, CSV, plot.",
    ),
    "clearance": (
        "clearance",
        "clearance",
        "Distances between all bodies of a cell in one state; exit 1 on a collision.",
    ),
    "sense": (
        "sense",
        "sense",
        "Read sensors by interference checking: touch, tactile maps, proximity, presence, force.",
    ),
    "render": (
        "render",
        "render",
        "Draw a cell (PNG) or export it as glTF (.glb), sensors colour-coded; or a run's first "
        "contact.",
    ),
    "calibrate": (
        "calibrate",
        "calibrate",
        "Calibrate frames from probe points on features; write an overlay pose file.",
    ),
    "calibrate-camera": (
        "vision",
        "calibrate_camera",
        "Calibrate a camera from board images and robot poses: intrinsics, hand-eye, the board.",
    ),
    "captures": (
        "vision",
        "captures",
        "A capture file from a controller's log of an exported capture program and its images.",
    ),
    "plan-views": (
        "vision",
        "plan_views",
        "Choose robot poses to calibrate a camera from: the board seen whole, D-optimal.",
    ),
    "calibrate-robot": (
        "robotcal",
        "calibrate_robot",
        "The robot's own kinematic errors from tracker / CMM points; write an overlay pose file.",
    ),
    "plan-robot-calibration": (
        "robotcal",
        "plan_robot_calibration",
        "Which joint states to measure for calibrate-robot, and a program that visits them.",
    ),
    "measure": (
        "calibrate",
        "measure",
        "Probe points from a controller's contact log (--from-log), or synthetic (--simulate).",
    ),
    "plan-measurements": (
        "plan_measurements",
        "plan_measurements",
        "Which features to probe, how many points, where, and the predicted error.",
    ),
    "plan": (
        "plan",
        "plan",
        "Time-optimal timing, payload capacity, load-optimal timing, maximum impulse "
        "(time-optimal | payload | load-optimal | impulse).",
    ),
    "import": (
        "robots",
        "import_group",
        "Import a robot from URDF into a new cell (import urdf).",
    ),
    "export": (
        "robots",
        "export_group",
        "Robot programs out with calibrated numbers (export program: URScript, KRL, RAPID, "
        "FANUC TP, CSV), and devices as URDF (export urdf).",
    ),
    "analyze": (
        "analyze",
        "analyze",
        "The report's accuracy / sensitivity comparison of computing T with or without "
        "orthogonality.",
    ),
}


class LazyGroup(click.Group):
    """A group whose subcommands are imported on first use."""

    def list_commands(self, ctx):
        return list(COMMANDS)

    def get_command(self, ctx, name):
        if name not in COMMANDS:
            return None
        module, attr, _ = COMMANDS[name]
        return getattr(importlib.import_module(f"{__name__}.{module}"), attr)

    def format_commands(self, ctx, formatter):
        rows = [(name, help_) for name, (_, _, help_) in COMMANDS.items()]
        with formatter.section("Commands"):
            formatter.write_dl(rows)

    def resolve_command(self, ctx, args):
        try:
            return super().resolve_command(ctx, args)
        except click.UsageError:
            import difflib

            close = difflib.get_close_matches(args[0], list(COMMANDS), n=1) if args else []
            if close:
                ctx.fail(f"no such command '{args[0]}' (did you mean '{close[0]}'?)")
            raise


def _warning_line(message, category, filename, lineno, file=None, line=None) -> None:
    """A warning from the library (a refused cache folder, a kernel that failed to compile) as
    one line on standard error, without Python's source line."""
    print(f"warning: {message}", file=file or sys.stderr)


@click.group(
    cls=LazyGroup,
    context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100},
)
@click.version_option(__version__, prog_name="rworld")
@click.option(
    "--json",
    "json_output",
    is_flag=True,
    help="Machine-readable JSON on stdout (same as each command's --json).",
)
@click.option(
    "-q",
    "--quiet",
    is_flag=True,
    help="Leave out notes: what the files already acknowledge (meshes marked 'surface: true').",
)
@click.pass_context
def main(ctx: click.Context, json_output: bool, quiet: bool) -> None:
    """rworld - world models, device physics and checks for robot workcells.

    A cell is a directory with cell.yaml (structure: devices, objects,
    sensors, frames, features, affixments, frame conditions), pose files
    (the numbers calibration may change), and symbolic programs that runs
    combine.  See docs/formats.md and docs/simulation.md.

    \b
    Examples:
      rworld validate workcells/*/cell.yaml
      rworld show workcells/paper_fig9
      rworld --json show workcells/puma560 > tree.json
      rworld schema --check
      rworld simulate workcells/paper_fig9 transfer -o out/fig9 --plot
      rworld check workcells/puma560 pick_place
      rworld kinematics ik workcells/puma560 --target workpiece.grasp
      rworld dynamics inverse workcells/puma560 --states states.csv --json

    Exit codes: 0 ok, 1 a check failed, 2 bad input or usage, 3 internal error.
    """
    ctx.ensure_object(dict)
    ctx.obj["json"] = json_output
    warnings.showwarning = _warning_line
    for stream in (sys.stdout, sys.stderr):
        # a file name whose bytes are not UTF-8 is printed as those bytes, never a crash
        if hasattr(stream, "reconfigure") and getattr(stream, "errors", "") == "strict":
            stream.reconfigure(errors="surrogateescape")

"""Simulation tasks: run a cell's programs together (simulate, check), and write what the run
gives.
"""

from __future__ import annotations

from pathlib import Path

from ..errors import UserError


def run_path(cell: str, run: str) -> str:
    """RUN may be a file, the name of CELL/runs/RUN.yaml, or - when the cell has no such run -
    of CELL/programs/RUN.yaml, which then runs alone."""
    from ..errors import did_you_mean

    p = Path(run)
    if p.is_file() or p.suffix:
        return run
    base = Path(cell) if Path(cell).is_dir() else Path(cell).parent
    candidate = base / "runs" / f"{run}.yaml"
    if candidate.is_file():
        return str(candidate)
    program = base / "programs" / f"{run}.yaml"
    if program.is_file():  # a program runs alone, as a run of one (schema.programs.load_run)
        return str(program)
    names = sorted(f.stem for f in (base / "runs").glob("*.yaml"))
    raise UserError(
        f"no run '{run}': not a file, and no {candidate}{did_you_mean(run, names)}"
        + (f"; the cell's runs: {', '.join(names)}" if names else "")
    )


def simulate_run(
    cell: str,
    run: str,
    dt: float | None = None,
    progress=None,
    clearance: float | str | None = None,
    collision_tolerance: float | str | None = None,
    collisions: bool = True,
    report: bool = True,
):
    """Load RUN's programs on CELL (located errors) and simulate them on one clock.

    Parameters
    ----------
    progress : callable(done, total, what), optional
        Called as the work proceeds.
    clearance, collision_tolerance : float [m] or str ('10mm'), optional
        Override the run file's values (docs/collision.md).
    collisions : bool
        Check collisions and clearance (default); False skips the check.
    report : bool
        Measure the pairs within 50 mm at every sample for the outputs' clearance columns
        (default); False: only what decides the check (``rworld check``).

    Returns
    -------
    (Run, SimulationResult)
    """
    from ..schema.programs import load_run
    from ..simulate.engine import simulate

    loaded = load_run(cell, run_path(cell, run), dt)
    if clearance is not None:
        loaded.clearance = parse_length_option(clearance, "--clearance")
    if collision_tolerance is not None:
        loaded.collision_tolerance = parse_length_option(
            collision_tolerance, "--collision-tolerance"
        )
        if loaded.collision_tolerance <= 0:
            raise UserError(
                "--collision-tolerance must be above 0: no check between instants can be exact"
            )
    return loaded, simulate(loaded, progress, collisions, report=report)


def parse_length_option(value, what: str) -> float:
    """A length option ('10mm', '0.01m', '0.01') in metres; UserError (exit 2) otherwise."""
    from ..units import parse_length

    try:
        return parse_length(value, what)
    except ValueError as exc:
        raise UserError(str(exc)) from None


def write_run_outputs(result, directory: str, plots: bool = False) -> list[Path]:
    """Timelines (CSV, JSON), events, summary and (``plots``) PNG plots of a run, written
    atomically.
    """
    from ..fileio import output_set
    from ..schema.results import RUN_OUTPUTS, write_results
    from ..simulate.output import output_files, write_plots

    # the folder's new files appear together, and none of an earlier run's outputs stays
    with output_set(directory, keep_others=True, replace=RUN_OUTPUTS):
        written = write_results(directory, *output_files(result))
        if plots:
            written += write_plots(result, Path(directory))
    return written


def run_summary(result) -> dict:
    """The stable JSON summary of a run (docs/simulation.md)."""
    from ..simulate.output import summary_dict

    return summary_dict(result)


def unlimited_notes(result) -> list[str]:
    """One line per device naming the joints the cell gives no limit of a kind, and per device
    whose links have no mass (its torques are only what it carries)."""
    from ..simulate.output import unlimited_lines

    massless = [
        f"{device}: its links have no mass in the cell (a URDF without <inertial>, say): its "
        "torques are only those of what it carries, and its torque ratios say nothing of it"
        for device in result.massless
    ]
    return unlimited_lines(result.unlimited) + massless


def collision_notes(result) -> list[str]:
    """What the collision check could not look at (bodies without geometry, open meshes) and
    the cell's static overlaps, once a pair."""
    report = result.collisions
    if report is None:
        return []
    notes = []
    if report.unchecked:
        notes.append(f"not checked for collisions (no geometry): {', '.join(report.unchecked)}")
    if report.open_meshes:
        notes.append(
            "meshes that are not closed solids, checked as surfaces only: "
            + ", ".join(report.open_meshes)
        )
    if report.static_overlaps:  # the cell's geometry: once a pair, not a collision
        pairs = "; ".join(
            f"{c.a} and {c.b} "
            + (
                f"{1000 * c.depth:.1f} mm deep"
                if c.collision
                else f"{1000 * c.distance:.1f} mm apart"
            )
            for c in report.static_overlaps
        )
        first = report.static_overlaps[0]
        notes.append(
            f"static overlaps in the cell ({len(report.static_overlaps)}; nothing in the run "
            f"moves either body, so they are the cell's geometry, not collisions of the run): "
            f"{pairs}. Not meant: move one in its pose file; meant (a part set into a "
            f"fixture): say so in cell.yaml, allowed_contacts: [{{between: [{first.a}, "
            f"{first.b}], reason: ...}}, ...]"
        )
    return notes


def render_run_contact(
    cell: str,
    run: str,
    outputs: str | list[str],
    view: tuple[float, float] = (25.0, -60.0),
    frames: bool = True,
    clearance: float | str | None = None,
    collision_tolerance: float | str | None = None,
):
    """Simulate RUN once and draw the state of its first contact (its deepest instant), the two
    bodies in the collision colour, into each of ``outputs``: a PNG, a .glb or an .html viewer
    by the file's suffix.

    Returns
    -------
    (list of Path, RunContact)
    """
    from ..units import SENSING_TOLERANCE
    from ..world.tree import World
    from .sensing import draw_world, picture_outputs

    outputs = picture_outputs(outputs)
    loaded, result = simulate_run(
        cell, run, None, None, clearance, collision_tolerance, collisions=True
    )
    report = result.collisions
    if report.first_state is None:
        raise UserError(f"{result.run}: no collision or clearance violation to draw")
    state = report.first_state
    world = World(loaded.cell)
    world.restore(state["snap"])
    for device, q in state["joints"].items():
        world.set_joints(device, q)
    first = next(rc for rc in report.contacts if (rc.contact.a, rc.contact.b) == state["pair"])
    title = f"{loaded.cell.name}: {first.describe().split(';')[0]} (t = {state['t']:.3f} s)"
    marks = [first.contact.point_a, first.contact.point_b]
    paths = draw_world(world, outputs, SENSING_TOLERANCE, view, frames, state["pair"], title, marks)
    return paths, first


def run_view(loaded, result, progress=None) -> tuple[bytes, dict]:
    """The animated scene of a simulated run (.glb bytes) and the viewer's panel data.

    Parameters
    ----------
    loaded, result : what :func:`simulate_run` returned.
    progress : callable(done, total, what), optional
    """
    from ..schema.gltf import scene_glb
    from ..simulate.scene import run_scene

    scene = run_scene(loaded.cell, result, progress=progress)
    return scene_glb(scene), scene.info


def write_run_view(
    glb: bytes,
    info: dict,
    glb_path: str | None = None,
    html_path: str | None = None,
    directory: str | None = None,
) -> list[Path]:
    """Write a run's scene: a .glb file, a viewer page, and/or the scene files of an output
    directory (``run.glb``, ``view.json``, which ``rworld view DIR`` reads); atomically."""
    from ..fileio import atomic_write_bytes, atomic_write_text, output_set
    from ..schema.results import SCENE_OUTPUTS, write_scene_files
    from ..viewer.page import viewer_page

    written = []
    with output_set(directory, keep_others=True, replace=SCENE_OUTPUTS):  # all appear together
        if directory:
            written += write_scene_files(directory, glb, info)
        if glb_path:
            written.append(atomic_write_bytes(glb_path, glb))
        if html_path:
            atomic_write_text(html_path, viewer_page(glb, info))
            written.append(Path(html_path))
    return written


def view_run_directory(directory: str, output: str | None = None) -> Path:
    """The viewer page of a run output directory (``simulate -o DIR``), written to ``output``
    (default ``DIR/view.html``); a directory with missing or damaged files is a UserError and
    nothing is written."""
    from ..fileio import atomic_write_text
    from ..schema.results import read_scene_files
    from ..viewer.page import viewer_page

    glb, info = read_scene_files(directory)
    path = Path(output) if output else Path(directory) / "view.html"
    atomic_write_text(path, viewer_page(glb, info))
    return path

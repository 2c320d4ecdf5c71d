"""Path files for planning: reading one as a joint spline, its joints' excursions out of their
range between waypoints, writing it again with new knots.  Below ``planning`` and ``cells``
(``validate`` checks path files): it imports neither."""

from __future__ import annotations

import numpy as np

from ..errors import Issue


def path_range_issues(path, device, path_file: str, located=None) -> list[Issue]:
    """Located issues for joints that leave their position range between the path's waypoints.

    The extrema are exact (the roots of q' on every cubic piece).  With ``located`` (a
    :class:`~rworld_cli.schema.paths.LoadedPath`) each issue points at the waypoint that ends the
    piece where the joint peaks, with the value and limit in the file's units.
    """
    from ..planning.path import range_excursions

    out = []
    scale = np.ones(device.dof) if located is None else located.scale
    for e in range_excursions(path, device.limit_array("lower"), device.limit_array("upper")):
        piece = int(
            np.clip(np.searchsorted(path.knots, e.s, side="right") - 1, 0, len(path.knots) - 2)
        )
        name = device.joints[e.joint].name
        where = "above its upper" if e.side == "upper" else "below its lower"
        message = (
            f"joint {name} leaves its position range between waypoints {piece + 1} and "
            f"{piece + 2}: "
            f"{e.value / scale[e.joint]:.6g} at s = {e.s:.4f}, {where} limit "
            f"{e.limit / scale[e.joint]:.6g}"
        )
        out.append(
            located.issue(piece + 1, e.joint, message)
            if located is not None
            else Issue(path_file, 0, 0, "(path)", message)
        )
    return out


def joint_path(spec):
    """The :class:`~rworld_cli.planning.path.JointPath` (cubic spline) of a PathSpec."""
    from ..planning.path import JointPath

    return JointPath(spec.waypoints, spec.knots, spec.boundary, spec.blends)


def load_joint_path(path_file: str, device, check_range: bool = True):
    """A :class:`~rworld_cli.planning.path.JointPath` from a path file, checked against the device.

    Raises
    ------
    UserError
        The file is malformed, or a waypoint is outside its joint's range (exit 2).
    CheckFailed
        ``check_range`` and the spline leaves a joint's range between waypoints (exit 1).
    """
    from ..errors import CheckFailed
    from ..schema.paths import read_path

    loaded = read_path(path_file, device)
    path = joint_path(loaded.spec)
    if check_range:
        issues = path_range_issues(path, device, path_file, loaded)
        if issues:
            raise CheckFailed(
                f"{path_file}: the path leaves a joint's position range between waypoints", issues
            )
    return path


def path_file_issues(path_file: str, device) -> list[Issue]:
    """For ``rworld validate``: the located range excursions of a path file (read errors are
    raised).
    """
    from ..schema.paths import read_path

    loaded = read_path(path_file, device)
    return path_range_issues(joint_path(loaded.spec), device, path_file, loaded)


def write_path_with_knots(path_file: str, knots, output: str, note: str = "") -> None:
    """Write ``path_file`` again with new ``knots`` (same waypoints, units and boundary),
    atomically.
    """
    from ..schema.paths import write_path_with_knots as write

    write(path_file, knots, output, note)

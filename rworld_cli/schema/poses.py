"""Pose files: the overlay that calibration writes (read with the cell in ``loader.py``)."""

from __future__ import annotations

import datetime as _dt

import numpy as np

from .. import spatial
from ..fileio import atomic_write_text
from ..units import ARCSEC
from .yamlio import yaml_value


def overlay_text(result, measurement_files: list[dict]) -> str:
    """The calibrated poses as a pose file (mm, deg) with provenance; the nominal files stay as they
    are.

    ``result``: a calibration result (``overlay``: frame -> T_parent_frame, SI; ``solutions``: frame
    ->
    solution with ``determined``, ``code``, ``residual_rms``, ``correction``, ``sigma_translation``,
    ``sigma_rotation``).
    """
    lines = [
        "# Calibrated poses written by 'rworld calibrate'.  List this file after the",
        "# nominal pose file(s) in the cell's pose_files; the nominal values stay there.",
        "units: {length: mm, angle: deg}",
        "poses:",
    ]
    for name, T in result.overlay.items():
        xyz = ", ".join(repr(float(x) * 1000) for x in T[:3, 3])
        rpy = ", ".join(repr(float(x)) for x in np.degrees(spatial.matrix_to_rpy(T[:3, :3])))
        lines.append(f"  {yaml_value(name)}: {{xyz: [{xyz}], rpy: [{rpy}]}}")
    lines.append("provenance:")
    lines.append(f"  date: {yaml_value(_dt.datetime.now().replace(microsecond=0).isoformat())}")
    lines.append("  measurements:")
    for f in measurement_files:  # paths are the user's: every character, quoted
        lines.append(f"    - {{path: {yaml_value(str(f['path']))}, sha256: {f['sha256']}}}")
    lines.append("  frames:")
    for name, sol in result.solutions.items():
        if not sol.determined:
            continue
        dt, dr = sol.correction
        entry = [
            f"condition: {sol.code}",
            f"residual_rms_mm: {sol.residual_rms * 1000:.6g}",
            f"correction_mm: {dt * 1000:.6g}",
            f"correction_deg: {np.degrees(dr):.6g}",
        ]
        if sol.sigma_translation is not None:
            entry.append(f"sigma_mm: {float(np.linalg.norm(sol.sigma_translation)) * 1000:.6g}")
            entry.append(f"sigma_arcsec: {float(np.linalg.norm(sol.sigma_rotation)) / ARCSEC:.6g}")
        lines.append(f"    {yaml_value(name)}: {{{', '.join(entry)}}}")
    return "\n".join(lines) + "\n"


def write_overlay(path, result, measurement_files: list[dict]) -> None:
    """Write :func:`overlay_text` to ``path`` atomically."""
    atomic_write_text(path, overlay_text(result, measurement_files))

"""A timed joint trajectory as CSV at a controller period, for streaming interfaces:
``t, <joint names>`` in s and rad (m for prismatic joints), stated in ``#`` lines above the
header (the sample count and period, ``# units: m, rad`` as the CSV readers take it)."""

from __future__ import annotations

import re

import numpy as np

from .common import number


def write(name: str, joint_names: list[str], times: np.ndarray, q: np.ndarray) -> dict[str, str]:
    """The file ``<name>.csv``: the name (a program file's stem) kept to letters, digits, '_',
    '-' and '.' - a newline or a separator in a file name is no file name a controller's
    transfer takes."""
    name = re.sub(r"[^A-Za-z0-9_.-]", "_", name, flags=re.ASCII).lstrip(".") or "program"
    period = float(times[1] - times[0]) if len(times) > 1 else 0.0
    lines = [
        f"# {len(times)} samples every {period * 1000:g} ms (rworld export program); t in s",
        "# units: m, rad",  # joint values: rad, m for prismatic joints (the CSV readers' line)
        "t," + ",".join(joint_names),
    ]
    for t, row in zip(times, q):
        lines.append(number(t, 6) + "," + ",".join(number(v, 9) for v in row))
    return {f"{name}.csv": "\n".join(lines) + "\n"}

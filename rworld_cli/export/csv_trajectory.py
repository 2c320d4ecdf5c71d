"""A timed joint trajectory as CSV at a controller period, for streaming interfaces:
``t, <joint names>`` in s and rad (m for prismatic joints)."""

from __future__ import annotations

import numpy as np

from .common import number


def write(name: str, joint_names: list[str], times: np.ndarray, q: np.ndarray) -> dict[str, str]:
    lines = ["t," + ",".join(joint_names)]
    for t, row in zip(times, q):
        lines.append(number(t, 6) + "," + ",".join(number(v, 9) for v in row))
    return {f"{name}.csv": "\n".join(lines) + "\n"}

"""The machine a bench ran on, for the line it prints first (docs/performance.md names the CPU
beside every figure)."""

from __future__ import annotations

import platform
from pathlib import Path


def cpu_model() -> str:
    """The CPU's model name, family and model as lscpu shows them (from /proc/cpuinfo)."""
    try:
        fields = dict(
            (key.strip(), value.strip())
            for key, _, value in (
                line.partition(":") for line in Path("/proc/cpuinfo").read_text().splitlines()
            )
        )
    except OSError:
        return platform.processor() or platform.machine()
    return f"{fields.get('model name', '?')} (family {fields.get('cpu family', '?')}, model " + (
        f"{fields.get('model', '?')})"
    )

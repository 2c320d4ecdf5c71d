"""rworld: world models, device physics, simulation, sensing, calibration and
planning for robot workcells, after the RWORLD design (Ravani, 1989).

The public API is in :mod:`rworld_cli.api`; ``docs/architecture.md`` shows
the rooms it builds on.  Importing this package is cheap; heavy modules load
on first use.
"""

__version__ = "0.2.0"  # the one place the version is written (pyproject reads it)

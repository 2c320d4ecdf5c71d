"""rworld: world models, device physics, simulation, sensing, calibration and
planning for robot workcells, after the RWORLD design (Ravani, 1989).

The public API is in :mod:`rworld_cli.api`; the pieces it uses live in
``schema`` (file formats and loader), ``world`` (cell model and frame tree),
``spatial`` and ``kinematics``.  Importing this package is cheap; heavy
modules load on first use.
"""

__version__ = "0.1.0"

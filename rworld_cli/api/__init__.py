"""Task-level functions: what each CLI command does, callable from Python.

One module per command family (``cells``: validate, show, schema; ``physics``; ``sensing``;
``calibration``; ``planning``; ``simulation``); nothing here prints or exits.  Results are
dataclasses; problems are raised as :class:`~rworld_cli.errors.UserError` (exit 2) or
:class:`~rworld_cli.errors.CheckFailed` (exit 1).

The names below load their module when first used (PEP 562): a command imports what it
calls, not every command family (`rworld check` reads its cell some 40 ms sooner).
"""

# ruff: noqa: F401  (the names are the package's, served by __getattr__ below)

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # the names as type checkers and readers see them
    from ..fileio import output_set
    from ..jsonvalues import finite as json_ready
    from .calibration import (
        CalibrationRun,
        MeasurementPlan,
        analyze_calibration,
        calibrate_cell,
        parse_angle,
        parse_length,
        plan_cell_measurements,
        simulate_measurement_file,
        simulate_probe_measurements,
        write_measurement_template,
    )
    from .cells import (
        CellSummary,
        FileReport,
        FrameNode,
        clearance,
        installed_schemas,
        load_world,
        schema_documents,
        stale_schemas,
        summarize_cell,
        validate_files,
        write_schemas,
    )
    from .export import (
        ProgramExport,
        Signals,
        TargetChange,
        export_program,
        measure_from_log,
    )
    from .fleet import (
        FleetCheck,
        RunCheck,
        check_fleet,
        github_annotations,
        junit_xml,
        write_junit,
    )
    from .motion import PlannedPath, plan_free_path
    from .physics import (
        DeviceContext,
        JacobianResult,
        StaticResult,
        carried_loads,
        carried_summary,
        configuration_of,
        device_context,
        device_dynamics,
        forward_dynamics,
        forward_kinematics,
        grasped,
        inverse_kinematics,
        jacobians,
        joint_states,
        load_notes,
        pose_rows,
        resolve_payload,
        static_torques,
        table_text,
        target_pose,
        the_device,
        write_table,
    )
    from .planning import (
        ImpulsePlan,
        PayloadResult,
        TimedTrajectory,
        TimeOptimalPlan,
        binding_shares,
        impulse_plan,
        joint_path,
        load_joint_path,
        load_optimal_plan,
        parse_period,
        path_file_issues,
        path_range_issues,
        plan_payload,
        plan_time_optimal,
        planning_limits,
        read_trajectory,
        sample_timed_path,
        time_optimal_plan,
        trajectory_table,
        unlimited_joints,
        write_path_with_knots,
    )
    from .robotcal import RobotCalibrationRun, calibrate_robot
    from .robotplan import RobotPosePlanRun, plan_robot_calibration
    from .robots import (
        UrdfExport,
        UrdfImport,
        export_urdf,
        import_ur_calibration,
        import_urdf,
    )
    from .sensing import (
        describe_reading,
        render_camera,
        render_scene,
        sense,
        write_sensor_maps,
    )
    from .simulation import (
        collision_notes,
        parse_length_option,
        render_run_contact,
        run_path,
        run_summary,
        run_view,
        simulate_run,
        unlimited_notes,
        view_run_directory,
        write_run_outputs,
        write_run_view,
    )
    from .sweep import SweepResult, sweep_rows, sweep_run, write_sweep
    from .vision import (
        CameraCalibrationRun,
        ViewPlanRun,
        calibrate_camera,
        captures_from_log,
        plan_views,
    )

# module (relative to this package) -> the names the package serves from it, as imported
# above for type checkers (tests/test_architecture.py holds the two lists equal)
_MODULES: dict[str, str] = {
    "..fileio": "output_set",
    ".calibration": (
        "CalibrationRun MeasurementPlan analyze_calibration calibrate_cell parse_angle "
        "parse_length plan_cell_measurements simulate_measurement_file "
        "simulate_probe_measurements write_measurement_template"
    ),
    ".cells": (
        "CellSummary FileReport FrameNode clearance installed_schemas load_world "
        "schema_documents stale_schemas summarize_cell validate_files write_schemas"
    ),
    ".export": "ProgramExport Signals TargetChange export_program measure_from_log",
    ".fleet": "FleetCheck RunCheck check_fleet github_annotations junit_xml write_junit",
    ".motion": "PlannedPath plan_free_path",
    ".physics": (
        "DeviceContext JacobianResult StaticResult carried_loads carried_summary "
        "configuration_of device_context device_dynamics forward_dynamics "
        "forward_kinematics grasped inverse_kinematics jacobians joint_states "
        "load_notes pose_rows resolve_payload static_torques table_text target_pose "
        "the_device write_table"
    ),
    ".planning": (
        "ImpulsePlan PayloadResult TimedTrajectory TimeOptimalPlan binding_shares "
        "impulse_plan joint_path load_joint_path load_optimal_plan parse_period "
        "path_file_issues path_range_issues plan_payload plan_time_optimal "
        "planning_limits read_trajectory sample_timed_path time_optimal_plan "
        "trajectory_table unlimited_joints write_path_with_knots"
    ),
    ".robotcal": "RobotCalibrationRun calibrate_robot",
    ".robotplan": "RobotPosePlanRun plan_robot_calibration",
    ".robots": "UrdfExport UrdfImport export_urdf import_ur_calibration import_urdf",
    ".sensing": "describe_reading render_camera render_scene sense write_sensor_maps",
    ".simulation": (
        "collision_notes parse_length_option render_run_contact run_path run_summary "
        "run_view simulate_run unlimited_notes view_run_directory write_run_outputs "
        "write_run_view"
    ),
    ".sweep": "SweepResult sweep_rows sweep_run write_sweep",
    ".vision": "CameraCalibrationRun ViewPlanRun calibrate_camera captures_from_log plan_views",
}
# name -> (module, its name there)
_LAZY: dict[str, tuple[str, str]] = {
    "json_ready": ("..jsonvalues", "finite"),
    **{name: (module, name) for module, names in _MODULES.items() for name in names.split()},
}
__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    """A name of the package, its module imported on first use (then kept here)."""
    try:
        module, attribute = _LAZY[name]
    except KeyError:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
    value = getattr(importlib.import_module(module, __name__), attribute)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return __all__

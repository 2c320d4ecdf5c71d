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

# name -> (module, its name there), relative to this package
_LAZY: dict[str, tuple[str, str]] = {
    "output_set": ("..fileio", "output_set"),
    "json_ready": ("..jsonvalues", "finite"),
    "CalibrationRun": (".calibration", "CalibrationRun"),
    "MeasurementPlan": (".calibration", "MeasurementPlan"),
    "analyze_calibration": (".calibration", "analyze_calibration"),
    "calibrate_cell": (".calibration", "calibrate_cell"),
    "parse_angle": (".calibration", "parse_angle"),
    "parse_length": (".calibration", "parse_length"),
    "plan_cell_measurements": (".calibration", "plan_cell_measurements"),
    "simulate_measurement_file": (".calibration", "simulate_measurement_file"),
    "simulate_probe_measurements": (".calibration", "simulate_probe_measurements"),
    "write_measurement_template": (".calibration", "write_measurement_template"),
    "CellSummary": (".cells", "CellSummary"),
    "FileReport": (".cells", "FileReport"),
    "FrameNode": (".cells", "FrameNode"),
    "clearance": (".cells", "clearance"),
    "installed_schemas": (".cells", "installed_schemas"),
    "load_world": (".cells", "load_world"),
    "schema_documents": (".cells", "schema_documents"),
    "stale_schemas": (".cells", "stale_schemas"),
    "summarize_cell": (".cells", "summarize_cell"),
    "validate_files": (".cells", "validate_files"),
    "write_schemas": (".cells", "write_schemas"),
    "ProgramExport": (".export", "ProgramExport"),
    "Signals": (".export", "Signals"),
    "TargetChange": (".export", "TargetChange"),
    "export_program": (".export", "export_program"),
    "measure_from_log": (".export", "measure_from_log"),
    "FleetCheck": (".fleet", "FleetCheck"),
    "RunCheck": (".fleet", "RunCheck"),
    "check_fleet": (".fleet", "check_fleet"),
    "github_annotations": (".fleet", "github_annotations"),
    "junit_xml": (".fleet", "junit_xml"),
    "write_junit": (".fleet", "write_junit"),
    "PlannedPath": (".motion", "PlannedPath"),
    "plan_free_path": (".motion", "plan_free_path"),
    "DeviceContext": (".physics", "DeviceContext"),
    "JacobianResult": (".physics", "JacobianResult"),
    "StaticResult": (".physics", "StaticResult"),
    "carried_loads": (".physics", "carried_loads"),
    "carried_summary": (".physics", "carried_summary"),
    "configuration_of": (".physics", "configuration_of"),
    "device_context": (".physics", "device_context"),
    "device_dynamics": (".physics", "device_dynamics"),
    "forward_dynamics": (".physics", "forward_dynamics"),
    "forward_kinematics": (".physics", "forward_kinematics"),
    "grasped": (".physics", "grasped"),
    "inverse_kinematics": (".physics", "inverse_kinematics"),
    "jacobians": (".physics", "jacobians"),
    "joint_states": (".physics", "joint_states"),
    "load_notes": (".physics", "load_notes"),
    "pose_rows": (".physics", "pose_rows"),
    "resolve_payload": (".physics", "resolve_payload"),
    "static_torques": (".physics", "static_torques"),
    "table_text": (".physics", "table_text"),
    "target_pose": (".physics", "target_pose"),
    "the_device": (".physics", "the_device"),
    "write_table": (".physics", "write_table"),
    "ImpulsePlan": (".planning", "ImpulsePlan"),
    "PayloadResult": (".planning", "PayloadResult"),
    "TimedTrajectory": (".planning", "TimedTrajectory"),
    "TimeOptimalPlan": (".planning", "TimeOptimalPlan"),
    "binding_shares": (".planning", "binding_shares"),
    "impulse_plan": (".planning", "impulse_plan"),
    "joint_path": (".planning", "joint_path"),
    "load_joint_path": (".planning", "load_joint_path"),
    "load_optimal_plan": (".planning", "load_optimal_plan"),
    "parse_period": (".planning", "parse_period"),
    "path_file_issues": (".planning", "path_file_issues"),
    "path_range_issues": (".planning", "path_range_issues"),
    "plan_payload": (".planning", "plan_payload"),
    "plan_time_optimal": (".planning", "plan_time_optimal"),
    "planning_limits": (".planning", "planning_limits"),
    "read_trajectory": (".planning", "read_trajectory"),
    "sample_timed_path": (".planning", "sample_timed_path"),
    "time_optimal_plan": (".planning", "time_optimal_plan"),
    "trajectory_table": (".planning", "trajectory_table"),
    "unlimited_joints": (".planning", "unlimited_joints"),
    "write_path_with_knots": (".planning", "write_path_with_knots"),
    "RobotCalibrationRun": (".robotcal", "RobotCalibrationRun"),
    "calibrate_robot": (".robotcal", "calibrate_robot"),
    "RobotPosePlanRun": (".robotplan", "RobotPosePlanRun"),
    "plan_robot_calibration": (".robotplan", "plan_robot_calibration"),
    "UrdfExport": (".robots", "UrdfExport"),
    "UrdfImport": (".robots", "UrdfImport"),
    "export_urdf": (".robots", "export_urdf"),
    "import_ur_calibration": (".robots", "import_ur_calibration"),
    "import_urdf": (".robots", "import_urdf"),
    "describe_reading": (".sensing", "describe_reading"),
    "render_scene": (".sensing", "render_scene"),
    "sense": (".sensing", "sense"),
    "write_sensor_maps": (".sensing", "write_sensor_maps"),
    "collision_notes": (".simulation", "collision_notes"),
    "parse_length_option": (".simulation", "parse_length_option"),
    "render_run_contact": (".simulation", "render_run_contact"),
    "run_path": (".simulation", "run_path"),
    "run_summary": (".simulation", "run_summary"),
    "run_view": (".simulation", "run_view"),
    "simulate_run": (".simulation", "simulate_run"),
    "unlimited_notes": (".simulation", "unlimited_notes"),
    "view_run_directory": (".simulation", "view_run_directory"),
    "write_run_outputs": (".simulation", "write_run_outputs"),
    "write_run_view": (".simulation", "write_run_view"),
    "SweepResult": (".sweep", "SweepResult"),
    "sweep_rows": (".sweep", "sweep_rows"),
    "sweep_run": (".sweep", "sweep_run"),
    "write_sweep": (".sweep", "write_sweep"),
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

"""Task-level functions: what each CLI command does, callable from Python.

One module per command family (``cells``: validate, show, schema; ``physics``; ``sensing``;
``calibration``; ``planning``; ``simulation``); nothing here prints or exits.  Results are
dataclasses; problems are raised as :class:`~rworld_cli.errors.UserError` (exit 2) or
:class:`~rworld_cli.errors.CheckFailed` (exit 1).
"""

from ..fileio import output_set  # noqa: F401  (every command's writes: one set)
from ..jsonvalues import finite as json_ready  # noqa: F401  (every JSON document: no inf, NaN)
from .calibration import (  # noqa: F401
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
from .cells import (  # noqa: F401
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
from .export import (  # noqa: F401
    ProgramExport,
    Signals,
    TargetChange,
    export_program,
    measure_from_log,
)
from .fleet import (  # noqa: F401
    FleetCheck,
    RunCheck,
    check_fleet,
    github_annotations,
    junit_xml,
    write_junit,
)
from .motion import PlannedPath, plan_free_path  # noqa: F401
from .physics import (  # noqa: F401
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
from .planning import (  # noqa: F401
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
from .robotcal import RobotCalibrationRun, calibrate_robot  # noqa: F401
from .robotplan import RobotPosePlanRun, plan_robot_calibration  # noqa: F401
from .robots import (  # noqa: F401
    UrdfExport,
    UrdfImport,
    export_urdf,
    import_ur_calibration,
    import_urdf,
)
from .sensing import (  # noqa: F401
    describe_reading,
    render_scene,
    sense,
    write_sensor_maps,
)
from .simulation import (  # noqa: F401
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
from .sweep import SweepResult, sweep_rows, sweep_run, write_sweep  # noqa: F401

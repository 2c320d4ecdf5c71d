"""Task-level functions: what each CLI command does, callable from Python.

One module per command family (``cells``: validate, show, schema; ``physics``; ``sensing``;
``calibration``; ``planning``; ``simulation``); nothing here prints or exits.  Results are
dataclasses; problems are raised as :class:`~rworld_cli.errors.UserError` (exit 2) or
:class:`~rworld_cli.errors.CheckFailed` (exit 1).
"""

from .cells import (  # noqa: F401
    FileReport,
    validate_files,
    load_world,
    FrameNode,
    CellSummary,
    summarize_cell,
    schema_documents,
    write_schemas,
    stale_schemas,
)
from .physics import (  # noqa: F401
    joint_states,
    pose_rows,
    table_text,
    target_pose,
    the_device,
    write_table,
    DeviceContext,
    device_context,
    forward_kinematics,
    JacobianResult,
    jacobians,
    inverse_kinematics,
    resolve_payload,
    carried_loads,
    carried_summary,
    device_dynamics,
    StaticResult,
    static_torques,
)
from .sensing import (  # noqa: F401
    describe_reading,
    render_scene,
    write_sensor_maps,
    sense,
)
from .calibration import (  # noqa: F401
    parse_length,
    CalibrationRun,
    calibrate_cell,
    simulate_measurement_file,
    write_measurement_template,
    analyze_calibration,
    plan_cell_measurements,
)
from .planning import (  # noqa: F401
    ImpulsePlan,
    TimeOptimalPlan,
    binding_shares,
    impulse_plan,
    load_optimal_plan,
    time_optimal_plan,
    path_range_issues,
    joint_path,
    load_joint_path,
    path_file_issues,
    write_path_with_knots,
    planning_limits,
    unlimited_joints,
    plan_time_optimal,
    parse_period,
    sample_timed_path,
    trajectory_table,
    TimedTrajectory,
    read_trajectory,
    PayloadResult,
    plan_payload,
)
from .simulation import (  # noqa: F401
    run_path,
    run_summary,
    simulate_run,
    unlimited_notes,
    write_run_outputs,
)

"""The calibration loop through a real controller's output (issue 44): an exported probe program
reports each contact in its language, a stand-in controller (``controller_logs``, written
without rworld's exporters) produces what the controller would record from the simulated
contacts, ``rworld measure --from-log`` reads it back, and ``calibrate`` gives what the
simulated loop gives; a log that does not match the program is refused at its line."""

from __future__ import annotations

import re
import shutil

import numpy as np
import pytest

from rworld_cli.calibration.pipeline import calibrate
from rworld_cli.calibration.probe_run import probe_run
from rworld_cli.errors import UserError
from rworld_cli.schema.loader import load_cell
from rworld_cli.schema.measurements import load_measurements
from rworld_cli.schema.programs import load_run
from rworld_cli.simulate.engine import simulate
from rworld_cli.world.tree import World
from tests.calibration.test_probing import make_truth
from tests.conftest import WORKCELLS
from tests.export import controller_logs
from tests.export.controller_logs import Reported, reports_in

# the program's simulation made once a worker for the same files (tests/conftest.py)
pytestmark = pytest.mark.usefixtures("simulation_once")

PROGRAM = "programs/probe_features.yaml"  # probe: on features (the steps of issue 44's item 2)
LOG_FILES = {
    "urscript": "robot.log",
    "rapid": "rworld.log",
    "krl": "probe.dat",
    "fanuc": "POSREG.VA",
    "inform": "VAR.DAT",
    "drl": "tp_log.txt",
    "val3": "val3.log",
}


@pytest.fixture(scope="module")
def loop(tmp_path_factory):
    """The nominal cell, a truth cell with the parts moved, the program's simulated contacts on
    the truth (as the controller records them: its nominal kinematics at the contact) and the
    measurement file of the simulated loop (noise-free)."""
    from rworld_cli.api import simulate_probe_measurements

    root = tmp_path_factory.mktemp("loop")
    cell = root / "cell"
    shutil.copytree(WORKCELLS / "probing", cell)
    truth = make_truth(root / "truth")
    run = load_run(str(cell), str(cell / PROGRAM))
    result = simulate(run, collisions=False)
    probed = probe_run(result, run, load_cell(str(truth)).cell)
    simulated = root / "simulated.yaml"
    simulate_probe_measurements(str(cell), str(truth), str(cell / PROGRAM), str(simulated), 0.0)
    return cell, truth, run, result, probed, simulated


def _tcp_poses(run, result, probed, frame: str | None, device="puma") -> list[np.ndarray]:
    """Where the controller's TCP stood at each recorded contact, in the robot's frame or the
    user frame: the search's orientation (a straight search keeps it), placed so that the
    probe's ball centre is the recorded point."""
    world = World(run.cell)
    T_world_base = world.T_world(device)
    T_base_frame = (
        np.eye(4) if frame is None else np.linalg.solve(T_world_base, world.T_world(frame))
    )
    probes = [e for e in result.events if e.device == device and e.kind == "probe"]
    out = []
    for event, point in zip(probes, probed, strict=True):
        search = result.resolved[device][event.reading["guard_move"]].move
        offset = world.T(search.tcp, search.guard)[:3, 3]
        R = search.T_base_planned[:3, :3]
        T = np.eye(4)
        T[:3, :3] = R
        T[:3, 3] = np.linalg.solve(T_world_base, np.append(point.reported, 1.0))[:3] - R @ offset
        out.append(np.linalg.solve(T_base_frame, T))
    return out


def _controller_output(fmt, exported, contacts, digits=None, noise=None) -> str:
    if fmt == "urscript":
        return controller_logs.urscript_log(contacts, *(() if digits is None else (digits,)))
    if fmt == "rapid":
        return controller_logs.rapid_file(contacts, *(() if digits is None else (digits,)))
    if fmt == "krl":
        return controller_logs.krl_dat(exported, contacts)
    if fmt == "drl":
        return controller_logs.drl_log(exported, contacts, digits)
    if fmt == "val3":
        return controller_logs.val3_log(exported, contacts, *(() if digits is None else (digits,)))
    if fmt == "inform":
        tools = controller_logs.inform_contact_tools(exported)
        return controller_logs.inform_var_dat(contacts, 101, (digits or 9, digits or 9), tools)
    return controller_logs.fanuc_posreg(contacts, 101, 9 if digits is None else digits)


_EXPORTED: dict[tuple[str, str, str | None], str] = {}  # the same export, made once a worker


def _export(cli, cell, fmt, frame, out):
    key = (str(cell), fmt, frame)
    if key not in _EXPORTED:
        _EXPORTED[key] = _export_now(cli, cell, fmt, frame, out)
    return _EXPORTED[key]


def _export_now(cli, cell, fmt, frame, out):
    args = ["export", "program", str(cell), str(cell / PROGRAM), "--format", fmt, "-o", str(out)]
    result = cli(args + (["--frame", frame] if frame else []))
    assert result.exit_code == 0, result.output
    if fmt == "val3":  # an application folder: the code is its start program
        return next(out.glob("*/start.pgx")).read_text()
    files = {p.suffix: p.read_text() for p in out.iterdir()}
    return files.get(".dat") if fmt == "krl" else next(iter(files.values()))


def _write_log(cli, loop, fmt, frame, tmp_path, digits=None, shift=None):
    cell, _, run, result, probed, _ = loop
    exported = _export(cli, cell, fmt, frame, tmp_path / "exported")
    # INFORM keeps a contact as $PX001 gives it: in the base frame whatever the job's frame
    poses = _tcp_poses(run, result, probed, None if fmt == "inform" else frame)
    if shift is not None:
        poses = [T.copy() for T in poses]
        poses[shift[0]][:3, 3] += shift[1]
    fields = reports_in(exported) if fmt not in ("fanuc", "inform") else [""] * len(poses)
    assert len(fields) == len(poses) == 12  # every probe: on a feature reports its contact
    contacts = [Reported(f, T) for f, T in zip(fields, poses)]
    tmp_path.mkdir(parents=True, exist_ok=True)  # the export (cached) may not have made it
    log = tmp_path / LOG_FILES[fmt]
    log.write_text(_controller_output(fmt, exported, contacts, digits))
    return log


def _read_back(cli, cell, log, fmt, out, *extra):
    args = ["measure", "--from-log", str(log), "--cell", str(cell), "--run", str(cell / PROGRAM)]
    return cli(args + ["--format", fmt, "-o", str(out), *extra])


def assert_read_back_is_the_loop(cli, cell, program, log, fmt, simulated, tmp_path, *extra):
    """``measure --from-log`` of ``log`` writes the simulated loop's points, feature by
    feature, to 1e-9 m (the vendor robots' loops)."""
    read = tmp_path / "from_log.yaml"
    back = cli(
        ["measure", "--from-log", str(log), "--cell", str(cell), "--run", str(program)]
        + ["--format", fmt, "-o", str(read), *extra]
    )
    assert back.exit_code == 0, back.output
    nominal = load_cell(str(cell)).cell
    a = load_measurements([str(simulated)], nominal).measurements
    b = load_measurements([str(read)], nominal).measurements
    assert sorted(a) == sorted(b) and len(a) == 4
    for name in a:
        assert np.abs(a[name].points - b[name].points).max() < 1e-9, name


_SIMULATED_FRAMES: dict[str, dict] = {}  # the simulated loop's frames, solved once a worker


def _frames(cell, path, sigma=2e-5):
    """The frames ``calibrate`` solves from the file, weighting both files alike (the
    noise-free simulated file states no usable sigma); the loop's own file once."""
    if path.name == "simulated.yaml" and sigma == 2e-5:
        key = str(path)
        if key not in _SIMULATED_FRAMES:
            _SIMULATED_FRAMES[key] = _solve_frames(cell, path, sigma)
        return _SIMULATED_FRAMES[key]
    return _solve_frames(cell, path, sigma)


def _solve_frames(cell, path, sigma):
    nominal = load_cell(str(cell)).cell
    measured = load_measurements([str(path)], nominal)
    measured.sigma = sigma
    return calibrate(nominal, measured).solutions


@pytest.mark.parametrize(
    "fmt, frame",
    [
        ("urscript", None),
        ("rapid", "plate"),
        ("krl", "table"),
        ("fanuc", "plate"),
        ("inform", None),
        ("inform", "plate"),
        ("drl", None),
        ("drl", "plate"),
        ("val3", None),
        ("val3", "plate"),
    ],
)
def test_a_controller_log_calibrates_as_the_simulated_loop(cli, loop, tmp_path, fmt, frame):
    """Each language's contact reports, read back through the controller's frames (the user
    frame where the export used one), give the simulated loop's points and frames to 1e-9 m."""
    cell, truth, *_, simulated = loop
    log = _write_log(cli, loop, fmt, frame, tmp_path)
    out = tmp_path / "from_log.yaml"
    extra = ["--frame", frame] if fmt == "fanuc" and frame else []
    result = _read_back(cli, cell, log, fmt, out, "--sigma", "0.02mm", *extra)
    assert result.exit_code == 0, result.output
    nominal = load_cell(str(cell)).cell
    a = load_measurements([str(simulated)], nominal).measurements
    b = load_measurements([str(out)], nominal).measurements
    assert sorted(a) == sorted(b)
    for name in a:
        assert np.abs(a[name].points - b[name].points).max() < 1e-9, name
    expected, got = _frames(cell, simulated), _frames(cell, out)
    for frame_name in expected:
        T_a, T_b = expected[frame_name].T_world, got[frame_name].T_world
        assert np.abs(T_a - T_b).max() < 1e-9, frame_name
    T_true = World(load_cell(str(truth)).cell).T_world("plate")
    assert np.abs(got["plate"].T_world[:3, 3] - T_true[:3, 3]).max() < 1e-6  # noise-free


def test_fanuc_registers_at_the_controllers_precision(cli, loop, tmp_path):
    """POSREG.VA prints 3 decimals (mm, deg): the plate comes out within 5 um of the simulated
    loop's."""
    cell, *_, simulated = loop
    log = _write_log(cli, loop, "fanuc", None, tmp_path, digits=3)
    assert "  X: " in log.read_text() and " -." in log.read_text()
    out = tmp_path / "m.yaml"
    result = _read_back(cli, cell, log, "fanuc", out)
    assert result.exit_code == 0, result.output
    T_a, T_b = _frames(cell, simulated)["plate"].T_world, _frames(cell, out)["plate"].T_world
    assert 0 < np.abs(T_a[:3, 3] - T_b[:3, 3]).max() < 5e-6


def test_inform_keeps_each_contact_in_its_position_variable(cli, loop, tmp_path):
    """The job clears P101..P112 first, and after each search copies the current position
    into the contact's variable; the variables come back from VAR.DAT at the controller's
    precision (mm to 3 decimals, deg to 4) within 5 um, and as USER-type positions of the
    job's user frame as the base-frame ones."""
    cell, _, run, result, probed, simulated = loop
    exported = _export(cli, cell, "inform", "plate", tmp_path / "job")
    lines = exported.splitlines()
    clears = [k for k, line in enumerate(lines) if re.fullmatch(r"SUB PX(\d{3}) PX\1", line)]
    gets = [line for line in lines if line.startswith("GETS ")]
    assert [lines[k] for k in clears] == [f"SUB PX{n:03d} PX{n:03d}" for n in range(101, 113)]
    assert gets == [f"GETS PX{n:03d} $PX001" for n in range(101, 113)]
    first_move = next(k for k, line in enumerate(lines) if line.startswith("MOV"))
    assert clears[-1] < first_move  # cleared before the robot moves
    searches = [k for k, line in enumerate(lines) if "UNTIL IN#(" in line]
    for k, n in zip(searches, range(101, 113)):  # each after its search, before the next move
        after = next(line for line in lines[k + 1 :] if not line.startswith("'"))
        assert after == f"GETS PX{n:03d} $PX001", after
    base = _tcp_poses(run, result, probed, None)
    contacts = [Reported("", T) for T in base]
    log = tmp_path / "VAR.DAT"
    tools = controller_logs.inform_contact_tools(exported)
    assert set(tools) == {2}  # the probe, the job's second tool
    log.write_text(controller_logs.inform_var_dat(contacts, 101, (3, 4), tools))
    out = tmp_path / "m.yaml"
    assert _read_back(cli, cell, log, "inform", out).exit_code == 0
    T_a, T_b = _frames(cell, simulated)["plate"].T_world, _frames(cell, out)["plate"].T_world
    assert 0 < np.abs(T_a[:3, 3] - T_b[:3, 3]).max() < 5e-6
    in_user = [Reported("", T) for T in _tcp_poses(run, result, probed, "plate")]
    log.write_text(controller_logs.inform_var_dat(in_user, 101, tools=tools, user=1))
    assert _read_back(cli, cell, log, "inform", out, "--frame", "plate").exit_code == 0
    nominal = load_cell(str(cell)).cell
    a = load_measurements([str(simulated)], nominal).measurements
    b = load_measurements([str(out)], nominal).measurements
    for name in a:
        assert np.abs(a[name].points - b[name].points).max() < 1e-9, name


@pytest.mark.parametrize(
    "edit, frame, message",
    [
        (
            lambda t: t.replace("///TOOL 2", "///TOOL 3"),
            None,
            "VAR.DAT:117: contact 1 was kept with TOOL 3, but the job searched with TOOL 2",
        ),
        (
            lambda t: t.replace("///POSTYPE BASE", "///USER 1\n///POSTYPE USER"),
            None,
            "VAR.DAT:118: contact 1 is a USER 1 position, but the job was given no user frame",
        ),
        (
            lambda t: re.sub(r"P0105=[^\n]*", "P0105=0.000,0.000,0.000,0.0000,0.0000,0.0000", t),
            "plate",
            "the log holds 4 of the program's 12 contacts: contact 5 (plate.front, step 3",
        ),
    ],
)
def test_inform_variables_that_are_not_the_jobs_contacts_are_refused(
    cli, loop, tmp_path, edit, frame, message
):
    """A variable of another tool or frame, a run that stopped (a variable still zero): each
    refused at its line, nothing written."""
    cell = loop[0]
    log = _write_log(cli, loop, "inform", frame, tmp_path)
    log.write_text(edit(log.read_text()))
    out = tmp_path / "m.yaml"
    extra = ["--frame", frame] if frame else []
    _refused(_read_back(cli, cell, log, "inform", out, *extra), out, message)


def test_inform_variables_the_reader_refuses(cli, loop, tmp_path):
    """A pulse-type variable, a variable listed twice, a decimal comma (seven values): refused
    at the line by the reader itself."""
    log = _write_log(cli, loop, "inform", None, tmp_path)
    text = log.read_text()
    for edit, message in [
        (
            lambda t: t.replace("///POSTYPE BASE\n///RECTAN", "///POSTYPE BASE\n///PULSE"),
            "VAR.DAT:117:1: contact log: P101 is a base position (joint pulses): a contact is "
            "kept as an XYZ-type position",
        ),
        (
            lambda t: t.replace("P0102=", "P0101=1,2,3,4,5,6\nP0102=", 1),
            "VAR.DAT:118:1: contact log: P101 listed twice (line 117 first)",
        ),
        (
            lambda t: re.sub(r"(P0103=)[^,]*", r"\g<1>417,775", t, count=1),
            "VAR.DAT:119:1: contact log: P103: 6 numbers expected, found 7",
        ),
    ]:
        log.write_text(edit(text))
        with pytest.raises(UserError) as caught:
            _reads(log, "inform")
        assert message in str(caught.value), caught.value


def test_the_loop_recovers_the_moved_plate_within_its_predicted_sigma(cli, loop, tmp_path):
    """The contacts with 20 um of probing noise (the stand-in controller's own generator): the
    calibrated plate lies within 4 of its predicted sigmas of the true plate, per axis."""
    cell, truth, run, result, probed, _ = loop
    exported = _export(cli, cell, "urscript", None, tmp_path / "ur")
    rng = np.random.default_rng(7)
    noisy = [p.reported + rng.normal(0.0, 2e-5, 3) for p in probed]
    shifted = [
        type(p)(p.feature, p.step, p.where, p.nominal, p.true, reported=q)
        for p, q in zip(probed, noisy)
    ]
    poses = _tcp_poses(run, result, shifted, None)
    log = tmp_path / "robot.log"
    log.write_text(
        controller_logs.urscript_log([Reported(f, T) for f, T in zip(reports_in(exported), poses)])
    )
    out = tmp_path / "m.yaml"
    result = _read_back(cli, cell, log, "urscript", out, "--sigma", "0.02mm")
    assert result.exit_code == 0, result.output
    solution = _frames(cell, out)["plate"]
    T_true = World(load_cell(str(truth)).cell).T_world("plate")
    T_nominal = World(load_cell(str(cell)).cell).T_world("plate")
    error = np.abs(solution.T_world[:3, 3] - T_true[:3, 3])
    assert np.all(error <= 4 * solution.sigma_translation), (error, solution.sigma_translation)
    assert np.linalg.norm(T_nominal[:3, 3] - T_true[:3, 3]) > 10 * np.linalg.norm(error)


# ---------------------------------------------------------------- a log that does not match


def _refused(result, out, *words):
    assert result.exit_code == 2, result.output
    for word in words:
        assert word in result.output, (word, result.output)
    assert not out.exists()


def test_a_cut_log_is_refused_naming_the_missing_contact(cli, loop, tmp_path):
    cell = loop[0]
    log = _write_log(cli, loop, "urscript", None, tmp_path)
    lines = log.read_text().splitlines()
    last = max(i for i, line in enumerate(lines) if "rworld contact" in line)
    log.write_text("\n".join(lines[:last]) + "\n")
    out = tmp_path / "m.yaml"
    _refused(
        _read_back(cli, cell, log, "urscript", out),
        out,
        f"robot.log:{last}:",
        "11 of the program's 12 contacts: contact 12 (plate.hole2, step 5",
    )


def test_a_contact_off_its_search_is_refused_at_its_line(cli, loop, tmp_path):
    cell = loop[0]
    log = _write_log(cli, loop, "rapid", None, tmp_path, shift=(4, [0.0, 0.0, 0.01]))
    out = tmp_path / "m.yaml"
    _refused(
        _read_back(cli, cell, log, "rapid", out),
        out,
        "rworld.log:5: contact 5 (plate.front, step 3) lies 10.000 mm off its search's line",
    )


def test_a_report_of_another_feature_or_unit_is_refused_at_its_line(cli, loop, tmp_path):
    cell = loop[0]
    log = _write_log(cli, loop, "urscript", None, tmp_path)
    text = log.read_text()
    out = tmp_path / "m.yaml"
    log.write_text(text.replace("feature=plate.top", "feature=plate.bottom", 1))
    _refused(
        _read_back(cli, cell, log, "urscript", out),
        out,
        "robot.log:3: contact 1: feature=plate.bottom, but the program's contact 1 has "
        "feature=plate.top",
    )
    log.write_text(text.replace("unit=m ", "unit=in ", 1))
    _refused(_read_back(cli, cell, log, "urscript", out), out, "robot.log:3:", "unit=in")
    log.write_text(text.replace("rworld contact 1/12", "rworld contact 1/13"))
    _refused(_read_back(cli, cell, log, "urscript", out), out, "the log is another program's")


def test_a_krl_run_that_stopped_early_is_refused(cli, loop, tmp_path):
    cell = loop[0]
    log = _write_log(cli, loop, "krl", None, tmp_path)
    log.write_text(log.read_text().replace("DECL INT RWC_COUNT=12", "DECL INT RWC_COUNT=7"))
    out = tmp_path / "m.yaml"
    _refused(
        _read_back(cli, cell, log, "krl", out),
        out,
        "RWC_COUNT = 7: the program recorded 7 of its 12 contacts",
    )


def test_several_runs_in_one_log_take_the_last(cli, loop, tmp_path):
    cell = loop[0]
    log = _write_log(cli, loop, "urscript", None, tmp_path)
    text = log.read_text()
    earlier = re.sub(r"pose=p\[[^\]]*\]", "pose=p[0, 0, 0, 0, 0, 0]", text)  # off every search
    log.write_text(earlier + text)
    out = tmp_path / "m.yaml"
    result = _read_back(cli, cell, log, "urscript", out)
    assert result.exit_code == 0, result.output
    assert "1 earlier run(s)" in result.output


def test_a_frame_level_probe_program_reads_back_too(cli, loop, tmp_path):
    """The program plan-measurements --program writes (guarded moves to frames, then probe:
    FEATURE): its RAPID contact file gives the simulated loop's points."""
    cell, truth, *_ = loop
    program = cell / "programs" / "probe.yaml"
    run = load_run(str(cell), str(program))
    result = simulate(run, collisions=False)
    probed = probe_run(result, run, load_cell(str(truth)).cell)
    out = tmp_path / "abb"
    assert (
        cli(
            ["export", "program", str(cell), str(program), "--format", "rapid", "-o", str(out)]
        ).exit_code
        == 0
    )
    fields = reports_in(next(out.iterdir()).read_text())
    poses = _tcp_poses(run, result, probed, None)
    assert len(fields) == len(poses) == 39
    log = tmp_path / "rworld.log"
    log.write_text(controller_logs.rapid_file([Reported(f, T) for f, T in zip(fields, poses)]))
    read = tmp_path / "read.yaml"
    args = ["measure", "--from-log", str(log), "--cell", str(cell), "--run", str(program)]
    result = cli(args + ["--format", "rapid", "-o", str(read)])
    assert result.exit_code == 0, result.output
    # the simulated loop's points (what measure --simulate --program writes), feature by feature
    nominal = load_cell(str(cell)).cell
    b = load_measurements([str(read)], nominal).measurements
    assert sorted(b) == sorted({p.feature for p in probed})
    for name, measured in b.items():
        expected = np.array([p.reported for p in probed if p.feature == name])
        assert measured.points.shape == expected.shape, name
        gaps = np.linalg.norm(measured.points[:, None] - expected[None], axis=2)
        assert gaps.min(axis=1).max() < 1e-9 and gaps.min(axis=0).max() < 1e-9, name


# ---------------------------------------------------------------- vendors' robots

PLATE = {
    "name": "plate",
    "mass": 1.0,
    "com": [0.0, 0.0, -0.01],
    "geometry": {"box": [0.2, 0.2, 0.02], "origin": {"xyz": [0.0, 0.0, -0.01]}},
    "features": [{"name": "top", "plane": {"point": [0, 0, 0], "normal": [0, 0, 1]}}],
}
TOUCH = """device: {device}
units: {{length: mm, angle: deg}}
steps:
  - move: {{to: target, tcp: tip, offset: {{xyz: [0, 0, -50]}}}}
  - move: {{to: target, tcp: tip, offset: {{xyz: [0, 0, 10]}}, motion: linear, speed: 0.04,
      until: ball}}
  - probe: plate.top
  - move: {{to: target, tcp: tip, offset: {{xyz: [0, 0, -50]}}, motion: linear}}
  - move: {{to: target, tcp: tip, offset: {{xyz: [30, 20, -50]}}, motion: linear}}
  - move: {{to: target, tcp: tip, offset: {{xyz: [30, 20, 10]}}, motion: linear, speed: 0.04,
      until: ball}}
  - probe: plate.top
"""


@pytest.mark.parametrize("vendor", ["ur5", "kr16", "irb2400", "lrmate200id"])
def test_vendor_robots_report_in_their_controllers_frames(cli, vendor, tmp_path):
    """A robot from the vendor's ROS package (its controller's flange tool0 and base 'base':
    UR's turned by pi about z) touches a plate with a ball on its tool; its language's contact
    report, as the controller gives it in its base frame (the frame taken from the cell's
    'base' link), reads back to the simulated contacts (1e-7 m)."""
    import yaml

    from tests.conftest import urdf_without_meshes
    from tests.export.test_vendors import TIP, VENDORS

    urdf_path, fmt, _, target = VENDORS[vendor]
    from rworld_cli.api import import_urdf

    urdf = urdf_without_meshes(urdf_path, tmp_path / urdf_path.name)
    root = tmp_path / "cell"
    device = import_urdf(str(urdf), str(root)).device
    cell = yaml.safe_load((root / "cell.yaml").read_text())
    [dev] = cell["devices"]
    for joint in dev["joints"]:
        joint["limits"]["acceleration"] = 10.0
    dev["tcps"].append({"name": "tip", "parent": "tool0"})
    cell["frames"] = [{"name": "target"}]
    cell["objects"] = [PLATE]
    cell["sensors"] = [{"name": "ball", "type": "touch", "ball": 0.003}]
    cell["affixments"] = [
        {"parent": f"{device}.tip", "child": "ball", "type": "rigid", "kind": "fixture"}
    ]
    (root / "cell.yaml").write_text(yaml.safe_dump(cell, sort_keys=False))
    poses = yaml.safe_load((root / "poses.yaml").read_text())
    poses["poses"][f"{device}.tip"] = TIP
    poses["poses"]["target"] = target
    poses["poses"]["plate"] = {"xyz": target["xyz"]}  # its top through the target, level
    poses["poses"]["ball"] = {"xyz": [0, 0, 0]}
    (root / "poses.yaml").write_text(yaml.safe_dump(poses, sort_keys=False))
    program = root / "touch.yaml"
    program.write_text(TOUCH.format(device=device))
    out = tmp_path / "out"
    assert cli(["export", "program", str(root), str(program), "-o", str(out)]).exit_code == 0
    run = load_run(str(root), str(program))
    result = simulate(run, collisions=False)
    nominal = load_cell(str(root)).cell
    probed = probe_run(result, run, nominal)  # the cell as truth: the contacts as simulated
    world = World(nominal)
    T_world_controller = world.T_world(f"{device}.base")
    T_world_base = world.T_world(device)
    poses_in_controller = [
        np.linalg.solve(np.linalg.solve(T_world_base, T_world_controller), T)
        for T in _tcp_poses(run, result, probed, None, device)
    ]
    assert len(poses_in_controller) == 2
    exported = {p.suffix: p.read_text() for p in out.iterdir()}
    text = exported.get(".dat") if fmt == "krl" else next(iter(exported.values()))
    fields = reports_in(text) if fmt != "fanuc" else ["", ""]
    contacts = [Reported(f, T) for f, T in zip(fields, poses_in_controller, strict=True)]
    log = tmp_path / LOG_FILES[fmt]
    log.write_text(_controller_output(fmt, text, contacts))
    read = tmp_path / "m.yaml"
    args = ["measure", "--from-log", str(log), "--cell", str(root), "--run", str(program)]
    answer = cli(args + ["-o", str(read), "--json"])  # the vendor names the language
    assert answer.exit_code == 0, answer.output
    import json

    report = json.loads(answer.output)
    assert report["format"] == fmt
    events = [e for e in result.events if e.kind == "probe"]
    for contact, event in zip(report["contacts"], events, strict=True):
        assert np.abs(np.array(contact["point_mm"]) / 1000 - event.reading["point"]).max() < 1e-7


def test_a_condition_naming_an_unmeasured_feature_uses_the_measured_ones(cli, loop, tmp_path):
    """Issue 50: the plate's condition names a left face the probe program did not touch; the
    measured top, front and holes determine the plate: calibrate solves it from them and says
    so.  The bracket, of which nothing was measured, names the ways out."""
    from rworld_cli.api import simulate_probe_measurements

    cell, truth, *_ = loop
    simulated = tmp_path / "m.yaml"
    simulate_probe_measurements(str(cell), str(truth), str(cell / PROGRAM), str(simulated), 2e-5)
    edited = tmp_path / "cell"
    shutil.copytree(cell, edited)
    text = (edited / "cell.yaml").read_text()
    text = text.replace(
        "      - name: front\n        plane: {point: [0, 0, 0], normal: [0, -1, 0]}\n",
        "      - name: front\n        plane: {point: [0, 0, 0], normal: [0, -1, 0]}\n"
        "      - name: left\n        plane: {point: [0, 0, 0], normal: [-1, 0, 0]}\n",
    )
    text = text.replace(
        "features: [top, front, hole1, hole2]}", "features: [top, front, hole1, hole2, left]}"
    )
    (edited / "cell.yaml").write_text(text)
    result = cli(["calibrate", str(edited), str(simulated), "--dry-run"])
    said = " ".join(result.output.split())  # the text as wrapped for the terminal, unwrapped
    assert "solved from the measured features plate.top, plate.front, plate.hole1" in said
    assert "not measured: plate.left" in said
    assert "measure bracket.base_top" in said and "leave bracket out (--frames)" in said
    only = cli(["calibrate", str(edited), str(simulated), "--frames", "plate", "--dry-run"])
    assert only.exit_code == 0, only.output


# --- a log cannot lie (issue 58) ----------------------------------------------------------------

# a numeric token's mutations: those the reader must refuse (never read as another number), and
# those that keep the number (the reader must read the same pose)
REFUSED = {
    "decimal comma": lambda t: t.replace(".", ",", 1) if "." in t else t + ",5",
    "hex": lambda t: "0x10",
    "underscore": lambda t: t[:1] + "_" + t[1:] if len(t) > 1 else "1_0",
    "nan": lambda t: "nan",
    "inf": lambda t: "inf",
    "overflow": lambda t: "1e999",
    "huge": lambda t: "1e300",
    "arabic-indic digits": lambda t: t.translate(str.maketrans("0123456789", "٠١٢٣٤٥٦٧٨٩")),
    "trailing text": lambda t: t + "abc",
    "empty": lambda t: "",
    "two numbers": lambda t: t + "-1",
}
KEPT = {
    "plus sign": lambda t: t if t.startswith(("-", "+")) else "+" + t,
    "trailing zero": lambda t: t + "0" if "." in t and "e" not in t.lower() else t,
}
NUMERIC = re.compile(r"(?<![\w.])[-+]?\d+\.\d+(?![\w.])")  # the pose values the writers print
POSE_REGION = {  # where each language's log holds the pose
    "urscript": r"p\[[^\]]*\]",
    "rapid": r" x=.*$",
    "krl": r"RWC_\d+=\{[^}]*\}",
    "fanuc": r"\b[XYZWPR]:\s*\S+",
    "inform": r"^P0(?:10[1-9]|11[0-2])=.*$",
    "drl": r"posx=\[[^\]]*\]",
    "val3": r"point=\S*",
}


def _reads(log, fmt):
    from rworld_cli.schema.contactlog import read_contact_log

    return read_contact_log(str(log), fmt, count=12 if fmt == "inform" else None)


def test_a_log_fuzz_refuses_every_lie_and_keeps_every_truth(cli, loop, tmp_path):
    """At least 300 mutations of real logs in seven languages: each numeric token of a pose
    replaced as a controller never writes it, or as one may; a key given twice; a count that
    does not count.  The counts are printed for the closing note."""
    rng = np.random.default_rng(58)
    counts = {"mutations": 0, "refused": 0, "kept": 0, "wrong": 0}
    for fmt, frame in [
        ("urscript", None),
        ("rapid", "plate"),
        ("krl", "table"),
        ("fanuc", "plate"),
        ("inform", "plate"),
        ("drl", "plate"),
        ("val3", None),
    ]:
        log = _write_log(cli, loop, fmt, frame, tmp_path / fmt)
        text = log.read_text()
        truth = [c.T_frame_tcp for c in _reads(log, fmt).contacts]
        spans = [(r.start() + m.start(), r.start() + m.end())
                 for r in re.finditer(POSE_REGION[fmt], text, re.MULTILINE)
                 for m in NUMERIC.finditer(r.group())]  # fmt: skip
        assert len(spans) >= 50
        picks = rng.choice(len(spans), size=min(len(spans), 90), replace=False)
        for k, pick in enumerate(picks):
            start, end = spans[pick]
            token = text[start:end]
            kinds = list(REFUSED) + list(KEPT)
            kind = kinds[k % len(kinds)]
            new = (REFUSED | KEPT)[kind](token)
            mutated = tmp_path / fmt / f"m{k}{log.suffix}"
            mutated.write_text(text[:start] + new + text[end:], encoding="utf-8")
            counts["mutations"] += 1
            try:
                read = [c.T_frame_tcp for c in _reads(mutated, fmt).contacts]
            except UserError as exc:
                assert exc.issues and exc.issues[0].line > 0, exc  # located
                counts["refused" if kind in REFUSED else "wrong"] += 1
                continue
            same = len(read) == len(truth) and all(
                np.allclose(a, b, atol=1e-12, rtol=0) for a, b in zip(read, truth)
            )
            unchanged = new == token
            ok = kind in KEPT or unchanged
            counts["kept" if ok and same else "wrong"] += 1
            assert ok and same, (fmt, kind, token, new)
            assert all(np.all(np.isfinite(T)) for T in read)
    print("log fuzz:", counts)
    assert counts["mutations"] >= 300 and counts["wrong"] == 0


@pytest.mark.parametrize(
    "fmt, frame, edit, message",
    [
        ("rapid", "plate", lambda t: t.replace(" x=", " x=1 x=", 1), "'x' given twice"),
        ("krl", "table", lambda t: re.sub(r"(RWC_1=\{)X ", r"\1X 1,X ", t), "'X' given twice"),
        (
            "urscript",
            None,
            lambda t: t.replace("contact 1/12", "contact 13/12", 1),
            "a report counts 1 to N",
        ),
        (
            "urscript",
            None,
            lambda t: t.replace("pose=p[", "pose=p[1e300, 0, 0, 0, 0, 0] p[", 1),
            "not a plausible value",
        ),
        (
            "fanuc",
            "plate",
            lambda t: re.sub(r"X:\s*(\S+)", r"X: \1 X: 1.0", t, count=1),
            "'X' given twice",
        ),
        ("drl", None, lambda t: t.replace(" unit=mm", " unit=mm unit=mm", 1), "'unit' given twice"),
        (
            "drl",
            None,
            lambda t: re.sub(r"\n[^\n]*contact 1/12 posx=[^\n]*", "", t, count=1),
            "contact 1/12 of line 2 has no posx= line",
        ),
        (
            "drl",
            "plate",
            lambda t: re.sub(r"(posx=\[)[^,]*", r"\g<1>417,775", t, count=1),
            "posx: 6 numbers expected, found 7",
        ),
        (
            "val3",
            None,
            lambda t: re.sub(r"\n[^\n]*contact 1/12 point=[^\n]*", "", t, count=1),
            "contact 1/12 of line 2 has no point= line",
        ),
        (
            "val3",
            "plate",
            lambda t: re.sub(r"(point=)[^,]*", r"\g<1>417,775", t, count=1),
            "point: 6 numbers expected, found 7",
        ),
    ],
)
def test_keys_counts_and_sizes_are_checked(cli, loop, tmp_path, fmt, frame, edit, message):
    log = _write_log(cli, loop, fmt, frame, tmp_path)
    log.write_text(edit(log.read_text()))
    with pytest.raises(UserError) as caught:
        _reads(log, fmt)
    assert message in str(caught.value), caught.value


def test_a_decimal_comma_never_reaches_calibrate(cli, loop, tmp_path):
    """The outside report's case: 'Z 417,775' read as 417.0 stayed inside the 2 mm line
    tolerance and put the plate 0.82 mm off; now the log is refused and nothing written."""
    cell = loop[0]
    log = _write_log(cli, loop, "krl", "table", tmp_path)
    text = log.read_text()
    z = re.search(r"RWC_1=\{[^}]*?Z (-?\d+)\.(\d+)", text)
    log.write_text(text[: z.start(1)] + f"{z.group(1)},{z.group(2)}" + text[z.end(2) :])
    out = tmp_path / "m.yaml"
    result = _read_back(cli, cell, log, "krl", out)
    assert result.exit_code == 2 and not out.exists(), result.output
    assert "is not 'NAME value'" in result.output and f"{log}:" in result.output


def test_a_log_over_the_size_bound_is_refused_at_once(tmp_path, monkeypatch):
    from rworld_cli.schema import contactlog

    monkeypatch.setattr(contactlog, "MAX_LOG_BYTES", 1000)
    log = tmp_path / "big.log"
    log.write_text("x" * 2000)
    with pytest.raises(UserError, match="over 1000 bytes"):
        contactlog.read_contact_log(str(log), "urscript")


def test_drl_reports_fit_tp_logs_256_bytes():
    """DSR_ROBOT2 documents tp_log's message as 256 bytes at most: a report's fields are split
    into lines of whole fields under it, each with its 'rworld contact K/N'; a single field
    longer than a line is refused (exit 2), not cut."""
    from rworld_cli.export.common import report_lines

    head = "rworld contact 3/12"
    fields = f"{head} program=p step=2 line={'d/' * 90}probe.yaml:40 feature=plate.top tcp=t.p"
    fields += " frame=base unit=mm dir=0,0,-1"
    lines = report_lines(fields, head, 256, "DRL's tp_log")
    assert len(lines) == 2 and all(len(x.encode()) <= 256 for x in lines)
    assert all(x.startswith(head + " ") for x in lines)
    assert " ".join(x[len(head) + 1 :] for x in lines) == fields[len(head) + 1 :]
    with pytest.raises(UserError, match="longer than DRL's tp_log holds"):
        report_lines(f"{head} line={'d' * 300}", head, 256, "DRL's tp_log")


def test_val3_reports_fit_its_128_character_strings(cli, loop, tmp_path):
    """A VAL3 string holds 128 characters: every logMsg literal of the exported probe program
    is under it, and the point's line is too with each of its six values as long as
    ``toString(".9", ...)`` prints a value under 100 m (mm) or a turn (deg)."""
    cell = loop[0]
    text = _export(cli, cell, "val3", "plate", tmp_path / "val3")
    literals = re.findall(r'logMsg\("([^"]*)"', text)
    assert len(literals) >= 24
    assert all(len(x) <= 128 for x in literals)
    longest_value = len("-99999.999999999")
    points = [x for x in literals if x.endswith(" point=")]
    assert len(points) == 12
    assert all(len(x) + 6 * longest_value + 5 <= 128 for x in points)


ROBOT_CORRECTIONS = """\
units: {length: mm, angle: deg}
corrections:
  puma.j2: {xyz: [0.4, -0.3, 0.2], rpy: [0.03, -0.02, 0.04]}
  puma.j3: {xyz: [-0.2, 0.5, 0.1], rpy: [-0.02, 0.05, 0.01]}
"""


ROBOT_COMPLIANCE = """\
compliance:
  puma.j2: 0.8
  puma.j3: 1.2
"""


@pytest.mark.parametrize("compliant", [False, True])
def test_a_calibrated_robots_contacts_come_back_through_its_calibration(
    cli, loop, tmp_path, compliant
):
    """Issue 62: a cell that carries a robot calibration the controller does not: the pose the
    controller logs is its nominal forward kinematics at the joints it stood at.  The contacts
    read back through the calibration (the nominal inverse kinematics of each logged pose,
    then the calibrated robot's pose there) give the simulated loop's points to 1e-9 m; read
    as the nominal pose they would be off by the calibration (over 0.1 mm).  With joint
    compliance (0.8 and 1.2 deg/kN m on joints 2 and 3) the controller's joints are its
    encoders', the commands that hold the yielding arm where it touched (``commanded``, with
    the holding torques of what the arm carries then); read back, the arm's ``q + c g(q)``."""
    from rworld_cli.api import simulate_probe_measurements
    from rworld_cli.api.export import _holding_at
    from rworld_cli.dynamics.compliance import commanded
    from rworld_cli.kinematics.inverse import solve_ik
    from rworld_cli.kinematics.jacobian import ToolMount, tool_pose

    cell, truth, *_ = loop
    calibrated = tmp_path / "calibrated"
    shutil.copytree(cell, calibrated)
    (calibrated / "robot.yaml").write_text(
        ROBOT_CORRECTIONS + (ROBOT_COMPLIANCE if compliant else "")
    )
    text = (calibrated / "cell.yaml").read_text()
    assert "pose_files: [poses.yaml]" in text
    (calibrated / "cell.yaml").write_text(
        text.replace("pose_files: [poses.yaml]", "pose_files: [poses.yaml, robot.yaml]")
    )
    run = load_run(str(calibrated), str(calibrated / PROGRAM))
    result = simulate(run, collisions=False)
    probed = probe_run(result, run, load_cell(str(truth)).cell)
    poses = _tcp_poses(run, result, probed, None)  # the real (calibrated) robot's TCP
    nominal = load_cell(str(cell)).cell.devices["puma"]
    real = run.cell.devices["puma"]
    exported = _export(cli, calibrated, "urscript", None, tmp_path / "exported")
    logged, off, yielded = [], 0.0, 0.0
    events = [e for e in result.events if e.kind == "probe"]
    holding = _holding_at(World(run.cell), result, "puma")
    for T, event in zip(poses, events, strict=True):
        search = result.resolved["puma"][event.reading["guard_move"]].move
        mount = ToolMount(search.link, search.T_link_tcp)
        q = solve_ik(real, T, mount, seed=search.q_planned, position_tolerance=1e-13).q
        if compliant:  # the encoders hold the commands that put the yielding arm at q
            q_arm, q = q, commanded(real, q, holding(event.t))
            yielded = max(yielded, float(np.abs(q_arm - q).max()))
        T_nominal = tool_pose(nominal, q, mount)  # what the controller logs
        off = max(off, float(np.linalg.norm(T_nominal[:3, 3] - T[:3, 3])))
        logged.append(T_nominal)
    assert off > 1e-4
    assert (yielded > 1e-5) == compliant  # 10 urad and more where the arm yields
    log = tmp_path / "robot.log"
    log.write_text(
        controller_logs.urscript_log([Reported(f, T) for f, T in zip(reports_in(exported), logged)])
    )
    out = tmp_path / "from_log.yaml"
    read = _read_back(cli, calibrated, log, "urscript", out)
    assert read.exit_code == 0, read.output
    simulated = tmp_path / "simulated.yaml"
    simulate_probe_measurements(
        str(calibrated), str(truth), str(calibrated / PROGRAM), str(simulated), 0.0
    )
    nominal_cell = load_cell(str(calibrated)).cell
    a = load_measurements([str(simulated)], nominal_cell).measurements
    b = load_measurements([str(out)], nominal_cell).measurements
    assert sorted(a) == sorted(b)
    for name in a:
        assert np.abs(a[name].points - b[name].points).max() < 1e-9, name

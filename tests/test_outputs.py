"""Outputs under hostile and unlucky conditions (issue 45): a claimed folder never writes
through a link inside it; a run's folder holds no output of an earlier run; a full disk, a
read-only file system, a parent that is a file and names too long are exit 2 with the path and
the reason, the old output intact and no debris; devices and FIFOs are written in place, never
replaced; '-' is refused; work is bounded before it is allocated, and numbers on the command
line are checked like file values."""

from __future__ import annotations

import os
import shutil
import stat
import subprocess
import sys
from importlib.metadata import distribution
from pathlib import Path

import pytest

from tests.conftest import REPO, WORKCELLS

RWORLD = [sys.executable, "-c", "from rworld_cli.cli import main; main()"]
SHARE = Path(str(distribution("example-robot-data").locate_file("cmeel.prefix/share")))
UR5 = SHARE / "example-robot-data" / "robots" / "ur_description" / "urdf" / "ur5_robot.urdf"
EXPORT = ["export", "program", "workcells/puma560", "pick_place", "--format", "urscript"]
CALIBRATE = [
    "calibrate",
    "workcells/calibration_example",
    "measurements/calibration_example/block_2026-11-21.yaml",
]


def _run(args, **kw) -> subprocess.CompletedProcess:
    return subprocess.run(RWORLD + args, cwd=REPO, capture_output=True, text=True, **kw)


# a small process that runs the command and reports its peak memory: a child forked straight
# from a large test worker would count the worker's pages in its own peak
MEASURE = (
    "import resource, subprocess, sys; "
    "done = subprocess.run(sys.argv[1:], capture_output=True, text=True); "
    "sys.stdout.write(done.stdout + done.stderr); "
    "sys.stderr.write(str(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)); "
    "sys.exit(done.returncode)"
)


def _peak(args) -> tuple[int, str, float]:
    """(exit code, output, peak memory [MB]) of one command, measured on its own process."""
    done = subprocess.run(
        [sys.executable, "-c", MEASURE, *RWORLD, *args], cwd=REPO, capture_output=True, text=True
    )
    return done.returncode, done.stdout, int(done.stderr.strip().splitlines()[-1]) / 1024


def _debris(folder: Path) -> list[str]:
    return [p.name for p in folder.rglob("*") if ".rworld-" in p.name]


def test_a_link_inside_a_claimed_folder_is_not_written_through(cli, tmp_path):
    """A cell received with meshes -> elsewhere: import urdf --force refuses at the link."""
    cell = tmp_path / "cell"
    args = ["import", "urdf", str(UR5), "-o", str(cell), "--package-path", str(SHARE)]
    assert cli(args).exit_code == 0
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "base_link.stl").write_text("someone's file")
    shutil.rmtree(cell / "meshes")
    (cell / "meshes").symlink_to(elsewhere)
    before = (cell / "cell.yaml").read_text()
    result = cli(args + ["--force"])
    assert result.exit_code == 2, result.output
    assert f"{cell / 'meshes'} is a link (to {elsewhere})" in result.output
    assert [p.name for p in elsewhere.iterdir()] == ["base_link.stl"]
    assert (elsewhere / "base_link.stl").read_text() == "someone's file"
    assert (cell / "cell.yaml").read_text() == before and not _debris(tmp_path)


def test_a_run_folder_holds_no_output_of_an_earlier_run(cli, tmp_path):
    out = tmp_path / "run"
    puma = str(WORKCELLS / "puma560")
    assert cli(["simulate", puma, "through_table", "--plot", "-o", str(out)]).exit_code == 0
    assert cli(["view", str(out)]).exit_code == 0
    assert {"collisions.json", "plot_puma.png", "view.html"} <= {p.name for p in out.iterdir()}
    (out / "notes.txt").write_text("the user's")
    result = cli(["simulate", puma, "pick_place", "--no-collisions", "-o", str(out)])
    assert result.exit_code == 0, result.output
    names = {p.name for p in out.iterdir()}
    assert not names & {"collisions.json", "plot_puma.png", "view.html"}, names
    assert {"summary.json", "run.glb", "notes.txt"} <= names
    assert (
        '"run": "pick_place"' in (out / "summary.json").read_text()
        or "pick_place" in (out / "summary.json").read_text()
    )


@pytest.fixture
def small_disk(tmp_path):
    """A 2 MiB tmpfs (skipped where mounting is not allowed)."""
    mount = tmp_path / "disk"
    mount.mkdir()
    made = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs", str(mount)], capture_output=True
    )
    if made.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {made.stderr.decode().strip()}")
    try:
        yield mount
    finally:
        subprocess.run(["umount", "-l", str(mount)], capture_output=True)


def _fill(mount: Path, free: int) -> None:
    """Fill the file system to ``free`` bytes left."""
    (mount / "filler").unlink(missing_ok=True)
    left = shutil.disk_usage(mount).free
    with open(mount / "filler", "wb") as fh:
        fh.write(b"\0" * max(left - free, 0))


@pytest.mark.parametrize("free_kib", [0, 8, 64])
def test_a_full_disk_is_exit_2_with_the_old_output_and_no_debris(small_disk, free_kib):
    out, cal = small_disk / "out", small_disk / "cal.yaml"
    assert _run(EXPORT + ["-o", str(out)]).returncode == 0
    assert _run(CALIBRATE + ["-o", str(cal)]).returncode == 0
    old = {p.name: p.read_bytes() for p in out.iterdir()}
    old_cal = cal.read_bytes()
    _fill(small_disk, free_kib * 1024)
    for args, target in ((EXPORT + ["-o", str(out)], out), (CALIBRATE + ["-o", str(cal)], cal)):
        result = _run(args)
        assert result.returncode in (0, 2), result.stderr
        if result.returncode == 2:
            assert f"cannot write {target}" in result.stderr or f"cannot write {small_disk}" in (
                result.stderr
            ), result.stderr
            assert "no space left on device" in result.stderr, result.stderr
        assert "internal error" not in result.stderr
        assert _debris(small_disk) == [], _debris(small_disk)
    if free_kib == 0:
        assert {p.name: p.read_bytes() for p in out.iterdir()} == old
        assert cal.read_bytes() == old_cal


def test_a_read_only_file_system_is_exit_2(small_disk):
    cal = small_disk / "cal.yaml"
    assert _run(CALIBRATE + ["-o", str(cal)]).returncode == 0
    old = cal.read_bytes()
    assert subprocess.run(["mount", "-o", "remount,ro", str(small_disk)]).returncode == 0
    result = _run(CALIBRATE + ["-o", str(cal)])
    assert result.returncode == 2, result.stderr
    assert f"cannot write {cal}: read-only file system" in result.stderr
    assert cal.read_bytes() == old


def test_names_up_to_the_limit_work_and_beyond_it_exit_2(tmp_path):
    long = tmp_path / ("c" * 250 + ".yaml")  # 255 bytes: the longest name
    result = _run(CALIBRATE + ["-o", str(long)])
    assert result.returncode == 0, result.stderr and long.exists()
    too_long = tmp_path / ("c" * 251 + ".yaml")
    result = _run(CALIBRATE + ["-o", str(too_long)])
    assert result.returncode == 2 and "file name too long" in result.stderr, result.stderr
    folder = tmp_path / ("d" * 255)
    assert _run(EXPORT + ["-o", str(folder)]).returncode == 0
    assert _debris(tmp_path) == []


def test_a_parent_that_is_a_file_and_a_read_only_proc_file_are_exit_2(tmp_path):
    (tmp_path / "file").write_text("x")
    result = _run(CALIBRATE + ["-o", str(tmp_path / "file" / "cal.yaml")])
    assert result.returncode == 2 and "cannot write" in result.stderr, result.stderr
    result = _run(CALIBRATE + ["-o", "/proc/version"])
    assert result.returncode == 2 and "cannot write /proc/version" in result.stderr
    assert "internal error" not in result.stderr


def test_devices_are_written_in_place_and_dash_is_refused(tmp_path):
    if os.geteuid() != 0:
        pytest.skip("mknod needs root")
    node = tmp_path / "null"
    os.mknod(node, stat.S_IFCHR | 0o666, os.makedev(1, 3))  # a private /dev/null
    check = ["check", "workcells/puma560", "pick_place", "--junit"]
    result = _run(check + [str(node)])
    assert result.returncode == 0, result.stderr
    assert stat.S_ISCHR(node.stat().st_mode)  # still the device, not replaced by a file
    result = _run(check + ["-"])
    assert result.returncode == 2 and "'-' is not a file name here" in result.stderr
    assert not (REPO / "-").exists()
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    reader = subprocess.Popen(["cat", str(fifo)], stdout=subprocess.PIPE)
    result = _run(check + [str(fifo)])
    written = reader.communicate(timeout=60)[0]
    assert (
        result.returncode == 0 and b"<testsuite" in written and stat.S_ISFIFO(fifo.stat().st_mode)
    )


@pytest.mark.parametrize(
    "args, message",
    [
        (
            ["sweep", "workcells/puma560", "pick_place", "--speed", "0.0001", "--workers", "1"],
            "at speed 1e-06 the move takes",
        ),
        (
            ["export", "program", "workcells/puma560", "pick_place", "--format", "csv"]
            + ["--period", "1e-9", "-o", "out/never"],
            "--period '1e-9' is outside 0.1 ms to 1 s",
        ),
        (
            ["sweep", "workcells/puma560", "pick_place", "--mass", "workpiece=inf"],
            "--mass: inf is not a finite number of at least 0",
        ),
        (["simulate", "workcells/puma560", "pick_place", "--dt", "nan"], "not a finite number"),
        (["sweep", "workcells/puma560", "pick_place", "--pose-files", ""], "an empty value"),
    ],
)
def test_work_is_bounded_and_numbers_are_checked(args, message):
    code, output, megabytes = _peak(args)
    assert code == 2, output
    assert message in output, output
    assert megabytes < 1024 and "internal error" not in output


def test_a_slow_speed_in_a_program_is_refused_naming_it(tmp_path):
    cell = tmp_path / "puma560"
    shutil.copytree(WORKCELLS / "puma560", cell)
    program = cell / "programs" / "slow.yaml"
    for speed, code in (("1e-9", 2), ("1e-5", 2), ("0.1", 0)):
        program.write_text(f"device: puma\nsteps:\n  - move: {{to: ready, speed: {speed}}}\n")
        status, output, megabytes = _peak(["check", str(cell), str(program)])
        assert status == code, output
        assert megabytes < 1024
        if code == 2:
            assert f"slow.yaml:3: puma step 1 (move to ready): at speed {float(speed):g}" in output
            assert "above the bound of 300,000" in output


def test_a_chain_of_500_fixed_links_and_1500_nested_frames_load(cli, tmp_path):
    """No recursion on a tree's depth: a URDF of 500 links joined by fixed joints (one
    revolute) imports; a cell of 1500 nested frames validates and shows."""
    links = ['<robot name="chain">', '<link name="l0"/>']
    for i in range(1, 501):
        links.append(
            f'<link name="l{i}"><inertial><mass value="0.1"/><inertia ixx="0.001" iyy="0.001" '
            'izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        )
        kind = "revolute" if i == 1 else "fixed"
        limit = (
            '<limit lower="-1" upper="1" velocity="1" effort="1"/><axis xyz="0 0 1"/>'
            if i == 1
            else ""
        )
        links.append(
            f'<joint name="j{i}" type="{kind}"><parent link="l{i - 1}"/><child link="l{i}"/>'
            f'<origin xyz="0 0 0.01"/>{limit}</joint>'
        )
    urdf = tmp_path / "chain.urdf"
    urdf.write_text("\n".join(links + ["</robot>"]))
    result = cli(["import", "urdf", str(urdf), "-o", str(tmp_path / "chain")])
    assert result.exit_code == 0, result.output
    assert "l0 -> l1" in result.output
    frames = ["  - name: f0"] + [f"  - name: f{i}\n    parent: f{i - 1}" for i in range(1, 1500)]
    deep = tmp_path / "deep"
    deep.mkdir()
    (deep / "cell.yaml").write_text(
        "name: deep\nunits: {length: m, angle: rad}\npose_files: [poses.yaml]\nframes:\n"
        + "\n".join(frames)
        + "\n"
    )
    (deep / "poses.yaml").write_text(
        "units: {length: m, angle: rad}\nposes:\n"
        + "".join(f"  f{i}: {{xyz: [0, 0, 0.001]}}\n" for i in range(1500))
    )
    assert cli(["validate", str(deep / "cell.yaml")]).exit_code == 0
    shown = cli(["show", str(deep), "--json"])
    assert shown.exit_code == 0, shown.output[-500:]
    assert cli(["show", str(deep)]).exit_code == 0

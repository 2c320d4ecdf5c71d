"""Bounds wherever work grows with input, and options checked before they are used (issue 58):
each refused with a clear message and exit 2, nothing written."""

from __future__ import annotations

import shutil
from types import SimpleNamespace

import numpy as np
import pytest

from rworld_cli.errors import UserError
from tests.conftest import WORKCELLS


def test_a_path_file_over_its_bounds_is_refused_before_it_is_parsed(cli, tmp_path):
    """200 000 waypoints validated in 93 s and 1.83 GB; the file is now refused by its size,
    and a count over 20 000 by the count."""
    rows = "".join(
        "  - [0.0000000, 0.0000000, 0.0000000, 0.0000000, 0.0000000, 0.0]\n" for _ in range(200_000)
    )
    big = tmp_path / "big.yaml"
    big.write_text("units: {angle: rad}\nwaypoints:\n" + rows)
    out = tmp_path / "t.csv"
    args = ["plan", "time-optimal", str(WORKCELLS / "puma560"), "--path", str(big), "-o", str(out)]
    result = cli(args)
    assert result.exit_code == 2 and "a path file holds at most 4,000,000" in result.output
    assert not out.exists()
    rows = "".join(f"  - [{k * 1e-6:.6f}, 0, 0, 0, 0, 0]\n" for k in range(20_001))
    big.write_text("units: {angle: rad}\nwaypoints:\n" + rows)
    result = cli(args)
    assert result.exit_code == 2 and "20001 waypoints; a path file holds at most 20,000" in (
        result.output
    )


def test_rows_at_a_period_are_bounded_before_they_are_allocated():
    from rworld_cli.planning.topp import sample_instants

    with pytest.raises(UserError, match="above the bound of 300,000"):
        sample_instants(SimpleNamespace(duration=2e300), period=0.008)
    assert len(sample_instants(SimpleNamespace(duration=1.0), period=0.25)) == 5


@pytest.mark.parametrize(
    "option, message",
    [
        (["--seed", "-1"], "-1 is not in the range x>=0"),
        (["--timeout", "0"], "0.0 is not in the range x>0"),
    ],
)
def test_plan_path_checks_its_seed_and_timeout(cli, tmp_path, option, message):
    out = tmp_path / "p.yaml"
    result = cli(
        ["plan", "path", str(WORKCELLS / "puma560"), "--to", "home", "-o", str(out), *option]
    )
    assert result.exit_code == 2 and message in result.output, result.output
    assert not out.exists()


@pytest.mark.parametrize("pulses", ["0.001", "1.0e9", ".nan"])
def test_pulses_per_degree_out_of_an_encoders_range_are_refused(cli, tmp_path, pulses):
    """0.001 wrote a 25 deg target as 0 pulses, 1e9 a 2.5e10-pulse target, exit 0."""
    cell = tmp_path / "cell"
    shutil.copytree(WORKCELLS / "puma560", cell)
    text = (cell / "cell.yaml").read_text()
    assert "  - name: puma\n" in text
    values = ", ".join([pulses] * 6)
    text = text.replace(
        "  - name: puma\n",
        f"  - name: puma\n    controller: {{vendor: yaskawa, pulses_per_degree: [{values}]}}\n",
        1,
    )
    (cell / "cell.yaml").write_text(text)
    result = cli(["validate", str(cell / "cell.yaml")])
    assert result.exit_code == 2, result.output
    assert "pulses_per_degree" in result.output
    assert "is not an encoder's" in result.output or "finite" in result.output


def test_a_csv_export_names_its_file_without_the_program_file_names_controls(cli, tmp_path):
    cell = tmp_path / "cell"
    shutil.copytree(WORKCELLS / "puma560", cell)
    program = cell / "programs" / "pick\r\nplace.yaml"
    shutil.copy(cell / "programs" / "pick_place.yaml", program)
    out = tmp_path / "out"
    result = cli(["export", "program", str(cell), str(program), "--format", "csv", "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert [p.name for p in out.iterdir()] == ["pick__place.csv"]
    data = np.loadtxt(out / "pick__place.csv", delimiter=",", comments="#", skiprows=3)
    assert data.shape[1] == 7 and np.all(np.isfinite(data))

"""Every YAML and CSV format on seeded mutations: cells, pose files, programs, runs, paths,
measurement files (YAML, CSV) and joint-state tables.

Thresholds: 0 internal errors (exit 3), 0 tracebacks; a refusal (exit 2) names the file; a check
that runs may pass or fail (exit 0 or 1).  Alias bombs (10^9 leaves from 9 lines), alias cycles
and deep nesting are refused by a count, never by exhausting the machine.
"""

from __future__ import annotations

import json
import random
import shutil

import pytest
import yaml

from tests.conftest import WORKCELLS, run_cli
from tests.fuzz import value_paths

HOSTILE = [
    "", "abc", 1e300, -1e300, float("nan"), float("inf"), None, True, [], {}, [1, 2], {"a": 1},
    "1e999", "10mm", "-5", -5, 0, 10**40, "x" * 2000, "a\nb", 3.5, [[1, 2, 3]], "deg", "mm",
]  # fmt: skip
# (cell, file, command): the command that reads the file
YAML_TARGETS = [
    ("puma560", "cell.yaml", ["validate", "{cell}"]),
    ("puma560", "poses.yaml", ["validate", "{cell}"]),
    ("puma560", "programs/pick_place.yaml", ["check", "{cell}", "pick_place", "--no-collisions"]),
    ("puma560", "runs/pick_place.yaml", ["check", "{cell}", "pick_place", "--no-collisions"]),
    (
        "puma560",
        "paths/reference.yaml",
        ["plan", "time-optimal", "{cell}", "--path", "{cell}/paths/reference.yaml"]
        + ["--gridpoints", "50", "--samples", "50"],
    ),
    ("paper_fig9", "cell.yaml", ["validate", "{cell}"]),
    ("probing", "cell.yaml", ["validate", "{cell}"]),
]
STATES = "q1,q2,q3,q4,q5,q6,qd1,qd2,qd3,qd4,qd5,qd6,qdd1,qdd2,qdd3,qdd4,qdd5,qdd6\n" + "".join(
    ",".join(f"{0.1 * ((i * 7 + j) % 11) - 0.5:.3f}" for j in range(18)) + "\n" for i in range(5)
)
TOKENS = ["", "nan", "inf", "1e999", "abc", '"', '""', ";", "\t", "1,5", "\ufeff", "-", "#", "\n"]


def _mutate_doc(rng: random.Random, doc):
    doc = json.loads(json.dumps(doc))
    path = rng.choice([p for p in value_paths(doc, per_list=4) if p])
    node = doc
    for k in path[:-1]:
        node = node[k]
    if rng.random() < 0.25 and isinstance(node, dict):
        del node[path[-1]]
    else:
        node[path[-1]] = rng.choice(HOSTILE)
    return doc


def _mutate_text(rng: random.Random, text: str) -> str:
    k = rng.randrange(4)
    if k == 0:
        return text[: rng.randrange(len(text))]
    lines = text.splitlines(True)
    if k == 1:
        del lines[rng.randrange(len(lines))]
        return "".join(lines)
    fields = text.split(",")
    i = rng.randrange(len(fields))
    fields[i] = rng.choice(TOKENS) + ("\n" if fields[i].endswith("\n") else "")
    return ",".join(fields)


def _run(args: list[str]):
    result = run_cli(args)
    assert result.exit_code in (0, 1, 2), result.output
    assert "Traceback" not in result.output and "internal error" not in result.output
    return result


@pytest.mark.parametrize("seed", range(3))
def test_mutated_yaml_files_are_read_or_refused_cleanly(tmp_path, seed):
    rng = random.Random(seed)
    codes = set()
    for k in range(40):
        cell, rel, command = rng.choice(YAML_TARGETS)
        root = tmp_path / f"c{k}"
        shutil.copytree(WORKCELLS / cell, root)
        text = (root / rel).read_text()
        if rng.random() < 0.8:
            doc = yaml.safe_load(text)
            for _ in range(rng.choice([1, 1, 2])):
                doc = _mutate_doc(rng, doc)
            text = yaml.safe_dump(doc, sort_keys=False, allow_unicode=True)
        else:  # a cut file, or a character YAML reads as syntax
            chars = list(text)
            chars[rng.randrange(len(chars))] = rng.choice(["\t", ":", "'", "{", "&", "*", "\x00"])
            text = "".join(chars) if rng.random() < 0.5 else text[: rng.randrange(len(text))]
        (root / rel).write_text(text)
        result = _run([a.format(cell=root) for a in command])
        codes.add(result.exit_code)
        if result.exit_code == 2:
            assert str(root) in result.output or rel in result.output, result.output
        shutil.rmtree(root)
    assert 2 in codes and (0 in codes or 1 in codes)


@pytest.mark.parametrize("seed", range(3))
def test_mutated_csv_files_are_read_or_refused_cleanly(tmp_path, seed):
    rng = random.Random(100 + seed)
    measured = (
        "feature,x_mm,y_mm,z_mm,role\n"
        + "".join(f"block.f1,{400 + 10 * i},{-40 + 7 * i},{800.5 + 0.01 * i},\n" for i in range(6))
        + "block.f1,476.9,22.5,811.1,above\n"
    )
    for k in range(40):
        kind = rng.choice(["states", "fk", "measurements"])
        text = measured if kind == "measurements" else STATES
        for _ in range(rng.choice([1, 2])):
            text = _mutate_text(rng, text)
        path = tmp_path / f"x{k}.csv"
        path.write_text(text)
        if kind == "measurements":
            args = ["calibrate", str(WORKCELLS / "calibration_example"), str(path), "--dry-run"]
        else:
            verb = ["dynamics", "inverse"] if kind == "states" else ["kinematics", "fk"]
            args = verb + [str(WORKCELLS / "puma560"), "--states", str(path)]
        result = _run(args)
        if result.exit_code == 2:
            assert f"x{k}.csv" in result.output, result.output


@pytest.mark.parametrize(
    "text, message",
    [
        (
            "a0: &a0 [x, x, x, x, x, x, x, x, x, x]\n"
            + "".join(f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 10)}]\n" for i in range(1, 9))
            + "units: {length: m, angle: rad}\nposes: {}\n",
            "expands to more than 2,000,000 values",
        ),
        ("units: &u {length: m, angle: rad, x: *u}\nposes: {}\n", "refers to itself"),
        ("poses: " + "[" * 20000 + "]" * 20000 + "\n", "nesting depth"),
    ],
    ids=["alias bomb", "alias cycle", "deep nesting"],
)
def test_yaml_that_would_exhaust_the_machine_is_refused_quickly(tmp_path, text, message):
    (tmp_path / "poses.yaml").write_text(text)
    result = _run(["validate", str(tmp_path / "poses.yaml")])
    assert result.exit_code == 2 and message in result.output, result.output

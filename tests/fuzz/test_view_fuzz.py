"""`rworld view` on damaged run outputs: seeded mutations of a real run's view.json and run.glb.

Thresholds: 0 internal errors (exit 3), 0 tracebacks, 0 damaged inputs accepted (every
mutation here breaks a rule of the format: a wrong type, an index out of range, a number that is
not finite, lengths that disagree, a cut file), and nothing written on refusal.  Text that is
hostile but valid (a `</script>` in a title) must be accepted and escaped; the browser test
plays such a page (tests/viewer/test_browser.py).
"""

from __future__ import annotations

import json
import random
import shutil
import struct

import pytest

from tests.conftest import WORKCELLS, run_cli
from tests.fuzz import value_paths

SEEDS = range(12)
CASES = 40  # per seed and file


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("run") / "out"
    result = run_cli(["simulate", str(WORKCELLS / "puma560"), "pick_place", "-o", str(out)])
    assert result.exit_code == 0, result.output
    return out


def _set(doc, path, value):
    node = doc
    for p in path[:-1]:
        node = node[p]
    node[path[-1]] = value


def _get(doc, path):
    for p in path:
        doc = doc[p]
    return doc


# glTF keys whose absence breaks the file (others have defaults: removing them is no damage)
REQUIRED = {"asset", "version", "buffers", "byteLength", "buffer", "bufferView", "componentType"}
REQUIRED |= {"count", "type", "primitives", "attributes", "POSITION", "samplers", "channels"}
REQUIRED |= {"input", "output", "sampler", "node", "path"}  # 'target': a view's is optional


def _damage(rng: random.Random, doc, required=None) -> tuple[object, str]:
    """A copy of the document with one rule of its format broken, and what was done;
    ``required``: the keys whose removal is damage (default: every key)."""
    doc = json.loads(json.dumps(doc))
    paths = [p for p in value_paths(doc, per_list=3) if p]
    path = rng.choice(paths)
    value = _get(doc, path)
    if isinstance(value, bool):
        replacement = "yes"
    elif isinstance(value, (int, float)):
        replacement = rng.choice(["12", None, [], {}, True, float("nan"), float("inf"), 1e400])
    elif isinstance(value, str):
        replacement = rng.choice([5, None, [], {"a": 1}, False])
    elif isinstance(value, list):
        replacement = rng.choice(
            [
                "list",
                7,
                None,
                value[:-1] if len(value) > 1 and isinstance(value[0], (int, float)) else 7,
                value + ([9.5] if value and isinstance(value[0], (int, float)) else ["x"]),
            ]
        )
    else:  # a mapping
        keys = [k for k in value if required is None or k in required]
        key = rng.choice(keys) if keys else None
        if key is not None and rng.random() < 0.5:
            del value[key]
            return doc, f"removed {'/'.join(map(str, path + (key,)))}"
        replacement = rng.choice([[], "x", 3, None])
    if isinstance(value, (list, dict)) and replacement == value:
        replacement = None
    _set(doc, path, replacement)
    return doc, f"{'/'.join(map(str, path))} = {json.dumps(replacement)[:40]}"


def _glb_parts(data: bytes) -> tuple[dict, bytes]:
    n = struct.unpack_from("<I", data, 12)[0]
    gltf = json.loads(data[20 : 20 + n])
    return gltf, data[20 + n :]


def _glb(gltf: dict, rest: bytes) -> bytes:
    text = json.dumps(gltf, allow_nan=True).encode()
    text += b" " * (-len(text) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text + rest
    return struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body


def _refused(tmp_path, run_dir, view: str | None = None, glb: bytes | None = None):
    case = tmp_path / "case"
    if case.exists():
        shutil.rmtree(case)
    shutil.copytree(run_dir, case)
    if view is not None:
        (case / "view.json").write_text(view, encoding="utf-8", errors="surrogatepass")
    if glb is not None:
        (case / "run.glb").write_bytes(glb)
    result = run_cli(["view", str(case)])
    assert result.exit_code in (0, 2), result.output
    assert "Traceback" not in result.output and "internal error" not in result.output
    if result.exit_code == 2:
        assert not (case / "view.html").exists()
    return result


@pytest.mark.parametrize("seed", SEEDS)
def test_damaged_view_json_is_refused(tmp_path, run_dir, seed):
    rng = random.Random(seed)
    doc = json.loads((run_dir / "view.json").read_text())
    accepted = []
    for _ in range(CASES):
        damaged, what = _damage(rng, doc)
        result = _refused(tmp_path, run_dir, view=json.dumps(damaged, allow_nan=True))
        if result.exit_code == 0:
            accepted.append(what)
        else:
            assert "view.json" in result.output
    assert not accepted, "accepted:\n" + "\n".join(accepted)


@pytest.mark.parametrize("seed", SEEDS)
def test_damaged_run_glb_is_refused(tmp_path, run_dir, seed):
    rng = random.Random(100 + seed)
    data = (run_dir / "run.glb").read_bytes()
    gltf, rest = _glb_parts(data)
    accepted = []
    for k in range(CASES):
        if k % 4 == 3:  # the binary side: cut short, or a float that is not finite
            blob = bytearray(data)
            if rng.random() < 0.5:
                damaged, what = bytes(blob[: rng.randrange(20, len(blob))]), "cut"
            else:
                chunk = 20 + struct.unpack_from("<I", data, 12)[0] + 8
                at = chunk + 4 * rng.randrange((len(data) - chunk) // 4)
                blob[at : at + 4] = struct.pack("<f", float("nan"))
                damaged, what = bytes(blob), f"NaN at byte {at}"
                # a NaN in an index buffer is a large index, in a float one not finite: both
                # break a rule, unless the word was padding between views
                views = gltf["bufferViews"]
                inside = any(
                    chunk + v.get("byteOffset", 0) <= at < chunk + v["byteOffset"] + v["byteLength"]
                    for v in views
                )
                if not inside:
                    continue
        else:
            changed, what = _damage(rng, gltf, REQUIRED)
            damaged = _glb(changed, rest)
        result = _refused(tmp_path, run_dir, glb=damaged)
        if result.exit_code == 0:
            accepted.append(what)
        else:
            assert "run.glb" in result.output
    assert not accepted, "accepted:\n" + "\n".join(accepted)


def test_deep_nesting_constants_and_lone_surrogates_are_refused(tmp_path, run_dir):
    text = (run_dir / "view.json").read_text()
    deep = text.replace('"marks": [', '"marks": [' + "[" * 100_000 + "]" * 100_000 + ",", 1)
    for bad in (
        deep,
        text.replace('"t_end": ', '"t_end": NaN, "x": ', 1),
        text.replace('"title": "', '"title": "\\ud800', 1),
        text[: len(text) // 2],
    ):
        assert _refused(tmp_path, run_dir, view=bad).exit_code == 2


def test_hostile_but_valid_text_is_accepted_and_escaped(tmp_path, run_dir):
    doc = json.loads((run_dir / "view.json").read_text())
    doc["title"] = "</script><script>alert(1)</script><!-- & \u2028"
    result = _refused(tmp_path, run_dir, view=json.dumps(doc))
    assert result.exit_code == 0
    page = (tmp_path / "case" / "view.html").read_text()
    assert "</script><script>alert(1)" not in page and "<!-- &" not in page

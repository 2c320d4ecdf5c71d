"""The caches' trust rule (issue 45, ``rworld_cli/cache.py``, docs/security.md): a cache folder
another user made or may write is refused with one warning and the command runs uncached; an
entry nobody but this user could have written is the only one used - a planted pickle, a forged
kernel, a link at an entry's name, flipped bits and torn files are misses, removed and
recomputed, with the uncached result; entries and folders are private."""

from __future__ import annotations

import json
import os
import pickle
import pwd
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rworld_cli import cache
from tests.conftest import REPO, WORKCELLS

RWORLD = [sys.executable, "-c", "from rworld_cli.cli import main; main()"]
ATTACKER = "rworld-attacker"


def _states(path: Path, joints: int) -> Path:
    """Three states q, qd, qdd of ``joints`` joints [rad, rad/s, rad/s^2]."""
    header = ",".join(f"{kind}{j}" for kind in ("q", "qd", "qdd") for j in range(1, joints + 1))
    rows = [
        ",".join(repr(0.1 * (k + 1) * ((j % 5) - 2)) for j in range(3 * joints)) for k in range(3)
    ]
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return path


def _tau(folder: Path) -> list[str]:
    return [
        "dynamics",
        "inverse",
        "workcells/puma560",
        "--json",
        "--states",
        str(_states(folder / "states.csv", 6)),
    ]


def _rworld(args, cache_dir, **env) -> subprocess.CompletedProcess:
    run_env = os.environ | {"RWORLD_CACHE_DIR": str(cache_dir)} | env
    return subprocess.run(
        RWORLD + args, cwd=REPO, env=run_env, capture_output=True, text=True, timeout=300
    )


def _attacker() -> int:
    """The uid of a second user (made with useradd where the tests run as root)."""
    if os.geteuid() != 0:
        pytest.skip("planting as another user needs root (useradd, chown)")
    try:
        return pwd.getpwnam(ATTACKER).pw_uid
    except KeyError:
        pass
    made = subprocess.run(
        ["useradd", "--system", "--no-create-home", ATTACKER], capture_output=True, text=True
    )
    if made.returncode not in (0, 9):  # 9: made meanwhile by a parallel test
        pytest.skip(f"useradd failed: {made.stderr.strip()}")
    return pwd.getpwnam(ATTACKER).pw_uid


class _Planted:
    """A pickle that runs a command when unpickled: what an attacker plants."""

    def __init__(self, marker: Path):
        self.marker = marker

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


@pytest.fixture(scope="module")
def uncached(tmp_path_factory):
    """The Puma's torques and tree without any cache."""
    off = tmp_path_factory.mktemp("off")
    tau = _rworld(_tau(off), off / "none", RWORLD_CELL_CACHE="0", RWORLD_KERNELS="numpy")
    show = _rworld(["show", "workcells/puma560", "--json"], off / "none", RWORLD_CELL_CACHE="0")
    assert tau.returncode == 0 and show.returncode == 0, tau.stderr + show.stderr
    return json.loads(tau.stdout), json.loads(show.stdout)


def _same(tau_text: str, reference: dict) -> None:
    got = json.loads(tau_text)
    assert got.keys() == reference.keys()
    assert np.allclose(np.array(got["tau"]), np.array(reference["tau"]), rtol=0, atol=1e-9)


def test_a_folder_another_user_owns_or_may_write_is_refused(tmp_path, uncached):
    """The shared folder (made by the second user, 0777, full of planted entries): one warning
    naming it, nothing planted runs, no file outside is written, the uncached results."""
    uid = _attacker()
    shared = tmp_path / "shared"
    marker = tmp_path / "pwned"
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me")
    for kind in ("cells", "kernels", "meshes"):
        (shared / kind).mkdir(parents=True)
    # the entries the victim would look up, planted: a pickle under every cell name, links
    payload = pickle.dumps(_Planted(marker))
    for name in [f"{k:040x}.pickle" for k in range(4)]:
        (shared / "cells" / name).write_bytes(payload)
    (shared / "kernels" / "x.o").symlink_to(victim)
    (shared / "secret.key").write_bytes(b"\0" * 32)
    for path in [shared, *shared.rglob("*")]:
        os.chown(path, uid, uid, follow_symlinks=False)
        if not path.is_symlink():
            path.chmod(0o777 if path.is_dir() else 0o666)
    tau_ref, show_ref = uncached
    for _ in range(2):
        tau = _rworld(_tau(tmp_path), shared)
        assert tau.returncode == 0, tau.stderr
        _same(tau.stdout, tau_ref)
        warnings = [line for line in tau.stderr.splitlines() if "not using the cache" in line]
        assert len(warnings) == 1 and str(shared) in warnings[0], tau.stderr
        assert "belongs to another user" in warnings[0]
        show = _rworld(["show", "workcells/puma560", "--json"], shared)
        assert show.returncode == 0 and json.loads(show.stdout) == show_ref
    assert not marker.exists() and victim.read_text() == "keep me"
    assert all(p.stat(follow_symlinks=False).st_uid == uid for p in shared.rglob("*"))
    # the victim's own folder, opened to others: refused the same way
    mine = tmp_path / "mine"
    mine.mkdir(mode=0o777)
    mine.chmod(0o777)
    open_folder = _rworld(_tau(tmp_path), mine)
    assert open_folder.returncode == 0 and "others may write in it (mode 0777)" in (
        open_folder.stderr
    )
    assert list(mine.iterdir()) == []


def test_forged_entries_in_the_users_own_folder_are_misses(tmp_path, uncached):
    """In a private folder, entries not made with the user's secret: a pickle that would run a
    command, a kernel whose code was changed with its old-style checksum recomputed, a link
    at an entry's name. None is used; each is removed and made anew; the link's target is
    untouched."""
    folder = tmp_path / "cache"
    tau_ref, show_ref = uncached
    first = _rworld(_tau(tmp_path), folder)
    assert first.returncode == 0 and "warning" not in first.stderr, first.stderr
    assert stat.S_IMODE(folder.stat().st_mode) == 0o700
    entries = [p for p in folder.rglob("*") if p.is_file()]
    assert entries and all(stat.S_IMODE(p.stat().st_mode) == 0o600 for p in entries)
    marker = tmp_path / "pwned"
    [cell_entry] = (folder / "cells").glob("*.pickle")
    cell_entry.write_bytes(pickle.dumps(_Planted(marker)))
    [kernel] = (folder / "kernels").glob("*.o")
    code = bytearray(kernel.read_bytes())
    code[len(code) // 2] ^= 0xFF  # the code changed, the file's framing kept
    kernel.write_bytes(bytes(code))
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me")
    links = [cell_entry.with_name("0" * 40 + ".pickle")]
    links[0].symlink_to(victim)
    again = _rworld(_tau(tmp_path), folder)
    assert again.returncode == 0, again.stderr
    _same(again.stdout, tau_ref)
    show = _rworld(["show", "workcells/puma560", "--json"], folder)
    assert json.loads(show.stdout) == show_ref
    assert not marker.exists() and victim.read_text() == "keep me"
    assert kernel.read_bytes() != bytes(code)  # recompiled and stored anew
    assert not list(folder.rglob(".tmp-*"))


@pytest.mark.parametrize("kind", ["cells", "meshes", "kernels"])
def test_every_flipped_bit_and_truncation_is_a_miss(tmp_path, monkeypatch, kind):
    """Seeded: 100 single-bit flips and 20 truncations of a real entry of each kind; every one
    fails authentication (so nothing is used) and is removed; the intact entry still reads."""
    monkeypatch.setenv("RWORLD_CACHE_DIR", str(tmp_path / "cache"))
    cell = tmp_path / "panda"
    shutil.copytree(WORKCELLS / "panda", cell)
    subprocess.run(
        RWORLD
        + ["dynamics", "inverse", str(cell), "--json"]
        + ["--states", str(_states(tmp_path / "s.csv", 7))],
        env=os.environ | {"RWORLD_CACHE_DIR": str(tmp_path / "cache")},
        capture_output=True,
        check=True,
        cwd=REPO,
    )
    [entry] = sorted((tmp_path / "cache" / kind).glob("[0-9a-f]*"))[:1]
    good = entry.read_bytes()
    assert cache.read(kind, entry.name) is not None
    rng = np.random.default_rng(45)
    for k in range(120):
        if k < 100:
            bit = int(rng.integers(len(good) * 8))
            bad = bytearray(good)
            bad[bit // 8] ^= 1 << (bit % 8)
        else:
            bad = bytearray(good[: int(rng.integers(len(good)))])
        entry.write_bytes(bytes(bad))
        assert cache.read(kind, entry.name) is None, k
        assert not entry.exists()
    entry.write_bytes(good)
    assert cache.read(kind, entry.name) is not None


def test_an_entry_moved_to_another_name_is_refused(tmp_path, monkeypatch):
    """A valid entry of one mesh copied under another mesh's name: the tag binds the name."""
    monkeypatch.setenv("RWORLD_CACHE_DIR", str(tmp_path))
    assert cache.write("meshes", "a.json", b'{"extents": [1, 2, 3]}')
    shutil.copy(tmp_path / "meshes" / "a.json", tmp_path / "meshes" / "b.json")
    assert cache.read("meshes", "b.json") is None
    assert cache.read("meshes", "a.json") == b'{"extents": [1, 2, 3]}'
    key = tmp_path / "secret.key"
    assert stat.S_IMODE(key.stat().st_mode) == 0o600 and len(key.read_bytes()) == 32


def test_a_key_others_can_read_is_refused(tmp_path, monkeypatch):
    monkeypatch.setenv("RWORLD_CACHE_DIR", str(tmp_path / "c"))
    assert cache.write("meshes", "a.json", b"1")
    (tmp_path / "c" / "secret.key").chmod(0o644)
    monkeypatch.setattr(cache, "_STATE", {})  # a new process's look
    with pytest.warns(cache.CacheWarning, match="not a private file"):
        assert cache.read("meshes", "a.json") is None
    assert Path(tmp_path / "c" / "meshes" / "a.json").exists()  # refused, not removed

"""Loaded cells kept on disk, beside the compiled kernels: a command on a cell whose files have
not changed reads the checked model back instead of parsing YAML, importing pydantic and
checking every rule again (issue 35, start-up: about 0.1 s of every command).

**When an entry is used.**  The key is a hash of the cell file's bytes, the path it was named
by and where it really is, the pose files given instead of the cell's own, rworld's version and
the size and modification time of every source file that shapes a loaded cell (``schema/``,
``model/``, ``units.py``, ``spatial.py``, ``errors.py``).  The entry lists every other file the
load read - pose files and meshes - with a hash of its bytes; each is read and hashed again
before the entry is used.  So a changed byte anywhere, a moved file or a changed rworld loads
the cell afresh.  Only cells that loaded without errors are kept (with their warnings, which
are reported again); bad input is always checked and located anew.

**Trust.**  Entries live behind :mod:`rworld_cli.cache`: a folder only the user can write, and
an HMAC with the user's secret over the whole entry, checked before it is unpickled - an entry
nobody but this user could have written, byte for byte.  Anything else (planted, flipped,
torn, of another layout) is a miss, removed and loaded afresh; never an error.
``RWORLD_CELL_CACHE=0`` turns the cache off.  The folder keeps the 256 most recently used
entries.
"""

from __future__ import annotations

import hashlib
import os
import pickle
from pathlib import Path
from typing import Any

FORMAT = 3  # bump when an entry's layout changes
KIND = "cells"  # the cache's folder (rworld_cli.cache)
MAX_ENTRIES = 256  # the least recently used beyond this are removed when one is added

_FINGERPRINT: list[str] = []  # computed once per process


def enabled() -> bool:
    return os.environ.get("RWORLD_CELL_CACHE", "1").strip() not in ("0", "false", "no", "off")


def _fingerprint() -> str:
    """rworld's version and the stat of every source file a loaded cell depends on."""
    if not _FINGERPRINT:
        from .. import __version__

        package = Path(__file__).resolve().parents[1]
        files = sorted((package / "schema").glob("*.py")) + sorted((package / "model").glob("*.py"))
        files += [package / name for name in ("units.py", "spatial.py", "errors.py")]
        h = hashlib.sha256(f"{FORMAT}|{__version__}".encode())
        for f in files:
            st = f.stat()
            h.update(f"|{f.name}|{st.st_size}|{st.st_mtime_ns}".encode())
        _FINGERPRINT.append(h.hexdigest())
    return _FINGERPRINT[0]


def file_digest(path: Path) -> str:
    """SHA-256 of a file's bytes (what an entry records of each file a load read)."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def entry(real: Path, shown: str, pose_files: list[str] | None) -> tuple[str, str] | None:
    """The name of this load's entry and the digest of the cell file's bytes it was named by,
    or None (cache off, the cell file unreadable)."""
    if not enabled():
        return None
    try:
        h = hashlib.sha256(_fingerprint().encode())
        for part in (real.resolve(), shown, repr(pose_files)):  # names as bytes, whatever
            h.update(b"|" + os.fsencode(part))  # their encoding (a folder named in latin-1)
        data = real.read_bytes()
        h.update(b"|" + data)
        return f"{h.hexdigest()[:40]}.pickle", hashlib.sha256(data).hexdigest()
    except (OSError, ValueError):  # unreadable; a name no file system can hold
        return None


def lookup(key: tuple[str, str] | None) -> Any:
    """The ``LoadedCell`` kept under ``name`` (:func:`entry`) when its entry authenticates and
    every file it read is unchanged, else None."""
    if key is None:
        return None
    from .. import cache

    name = key[0]
    data = cache.read(KIND, name)  # authenticated: only then unpickled
    if data is None:
        return None
    try:
        kept = pickle.loads(data)
        for file, digest in kept["read"]:
            if file_digest(Path(file)) != digest:
                return None
        cache.touch(KIND, name)  # recently used: kept when the cache is pruned
        return kept["loaded"]
    except Exception:  # a layout of another rworld, a file gone: loaded afresh
        return None


def store(key: tuple[str, str] | None, loaded: Any, read: list[tuple[Path, str]]) -> None:
    """Keep ``loaded`` (a cell that loaded without errors) under ``key`` (:func:`entry`) with
    the digests of the bytes it parsed (``read``: each file with the digest taken when it was
    read, the cell file first).  Nothing is kept when the cell file parsed is not the one the
    key was made from, or any file has changed since it was read: an editor's save, a
    ``calibrate -o`` or a ``git checkout`` under a running command must not leave the model of
    the old bytes under the new bytes' name."""
    if key is None:
        return
    from .. import cache

    name, cell_digest = key
    try:
        if not read or read[0][1] != cell_digest:
            return
        if any(file_digest(path) != digest for path, digest in read):
            return
        data = pickle.dumps(
            {"read": [(str(p.resolve()), d) for p, d in read[1:]], "loaded": loaded},
            protocol=pickle.HIGHEST_PROTOCOL,
        )
    except Exception:  # a cache: whatever cannot be kept is loaded afresh next time
        return
    if cache.write(KIND, name, data):
        cache.prune(KIND, "*.pickle", MAX_ENTRIES)

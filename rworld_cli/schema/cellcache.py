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

**Trust.**  An entry is a pickle, read from the user's own cache folder (``RWORLD_CACHE_DIR``,
else ``$XDG_CACHE_HOME/rworld`` or ``~/.cache/rworld``), as Python's ``__pycache__`` and the
compiled kernels are: whoever can write there can already run code as the user.  A damaged
or unreadable entry is a miss, never an error; ``RWORLD_CELL_CACHE=0`` turns the cache off.
The folder keeps the 256 most recently used entries.
"""

from __future__ import annotations

import hashlib
import os
import pickle
from pathlib import Path
from typing import Any

FORMAT = 1  # bump when an entry's layout changes
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


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def entry(real: Path, shown: str, pose_files: list[str] | None) -> Path | None:
    """Where the entry of this load lives, or None (cache off, the cell file unreadable)."""
    if not enabled():
        return None
    try:
        from ..kernels import cache_dir

        h = hashlib.sha256(_fingerprint().encode())
        for part in (real.resolve(), shown, repr(pose_files)):  # names as bytes, whatever
            h.update(b"|" + os.fsencode(part))  # their encoding (a folder named in latin-1)
        h.update(b"|" + real.read_bytes())
        return cache_dir().parent / "cells" / f"{h.hexdigest()[:40]}.pickle"
    except (OSError, ValueError):  # unreadable; a name no file system can hold
        return None


def lookup(where: Path | None) -> Any:
    """The ``LoadedCell`` kept at ``where`` (:func:`entry`) when every file it read is
    unchanged, else None."""
    if where is None:
        return None
    try:
        data = pickle.loads(where.read_bytes())
        for file, digest in data["read"]:
            if _digest(Path(file)) != digest:
                return None
        os.utime(where)  # recently used: kept when the cache is pruned
        return data["loaded"]
    except Exception:  # a miss: absent, damaged, from another layout - loaded afresh
        return None


def store(where: Path | None, loaded: Any, read: list[Path]) -> None:
    """Keep ``loaded`` (a cell that loaded without errors) at ``where`` (:func:`entry`) with
    the digests of the files it read.  A cache, not an output: written to a temporary and
    renamed (a torn entry fails to load and is redone); a read-only cache is left alone."""
    if where is None:
        return
    try:
        data = pickle.dumps(
            {"read": [(str(p.resolve()), _digest(p)) for p in read], "loaded": loaded},
            protocol=pickle.HIGHEST_PROTOCOL,
        )
        where.parent.mkdir(parents=True, exist_ok=True)
        temporary = where.with_name(f".{where.name}.{os.getpid()}")
        temporary.write_bytes(data)
        os.replace(temporary, where)
        _prune(where.parent)
    except Exception:  # a cache: whatever fails to be kept is loaded afresh next time
        pass


def _prune(folder: Path) -> None:
    """Keep the :data:`MAX_ENTRIES` most recently used entries (a test suite or a sweep over
    many generated cells would otherwise fill the folder)."""
    entries = list(folder.glob("*.pickle"))
    if len(entries) <= MAX_ENTRIES:
        return
    by_age = sorted(entries, key=lambda e: e.stat().st_mtime_ns)
    for old in by_age[: len(entries) - MAX_ENTRIES]:
        old.unlink(missing_ok=True)

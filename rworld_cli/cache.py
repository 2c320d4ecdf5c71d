"""What rworld keeps between commands - compiled kernels, loaded cells, mesh facts - behind one
trust rule (``docs/security.md``).

**Where.**  ``$RWORLD_CACHE_DIR``, else ``$XDG_CACHE_HOME/rworld``, else ``~/.cache/rworld``;
one folder per kind inside it (``kernels/``, ``cells/``, ``meshes/``).

**Which folders.**  The root and each kind's folder are used only when they are folders (not
links) owned by the user running rworld and writable by nobody else.  rworld creates them 0700;
a folder that breaks the rule is refused with one warning line naming it, and the command runs
without that cache (slower, never different).

**Which entries.**  Each entry is authenticated, not only checksummed: an HMAC-SHA256 with a
per-user secret (``secret.key``, 32 random bytes, 0600 in the root, made once) over the kind,
the entry's name and its bytes, checked before anything is unpickled, parsed or handed to the
JIT.  Whoever cannot read the secret cannot make an entry rworld accepts, nor move a valid
entry to another name; a flipped bit or a torn file fails the same check.  An entry that fails
is a miss: it is removed and computed again - never an error, never a different result.

**Writes.**  A new entry is written to a temporary with an unpredictable name, created with
``O_CREAT | O_EXCL`` (``tempfile.mkstemp``, mode 0600), in the entry's own folder, then renamed
over the entry: a planted link at either name is replaced, never followed.  A cache that cannot
be written (read-only, full) is no error.
"""

from __future__ import annotations

import hashlib
import hmac
import os
import stat
import tempfile
import threading
import warnings
from pathlib import Path

SECRET = "secret.key"
SECRET_BYTES = 32
MAGIC = b"rworld-cache-2\n"  # entries written before the trust rule fail to authenticate
TAG = hashlib.sha256().digest_size

_LOCK = threading.Lock()
# per cache root (the environment names it; tests change it): "" -> the checked root, a kind ->
# its checked folder (None: refused or absent), and "key" -> the secret (None: unusable)
_STATE: dict[Path, dict] = {}


class CacheWarning(UserWarning):
    """A cache folder rworld will not use (``docs/security.md``)."""


def root() -> Path:
    """The cache root as the environment names it (it may not exist)."""
    named = os.environ.get("RWORLD_CACHE_DIR")
    if named:
        return Path(named)
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "rworld"


def _state() -> dict:
    return _STATE.setdefault(root(), {})


def _refuse(path: Path, why: str) -> None:
    warnings.warn(
        f"not using the cache folder {path}: {why}; running without a cache (docs/security.md)",
        CacheWarning,
        stacklevel=4,
    )


def _owned(path: Path, create: bool) -> bool:
    """``path`` is a folder, not a link, owned by this user and writable by no one else;
    created 0700 (with its missing parents) when ``create``.  Refused folders warn."""
    try:
        if create:
            missing = [p for p in [path, *path.parents] if not os.path.lexists(p)]
            for parent in reversed(missing):
                try:
                    os.mkdir(parent, 0o700)
                except FileExistsError:
                    pass
        info = os.lstat(path)
    except OSError:
        return False  # absent and not creatable (a read-only disk): uncached, no warning
    if stat.S_ISLNK(info.st_mode) or not stat.S_ISDIR(info.st_mode):
        _refuse(path, "it is a link or not a folder")
        return False
    if info.st_uid != os.geteuid():
        _refuse(path, f"it belongs to another user (uid {info.st_uid})")
        return False
    if info.st_mode & 0o022:
        _refuse(path, f"others may write in it (mode {stat.S_IMODE(info.st_mode):04o})")
        return False
    return True


def folder(kind: str) -> Path | None:
    """The checked folder of one kind of entry, created 0700; None when refused or unusable."""
    with _LOCK:
        state = _state()
        if kind not in state:
            top = _top()
            state[kind] = top / kind if top is not None and _owned(top / kind, True) else None
        return state[kind]


def _top() -> Path | None:
    """The checked root (once per process and root: one warning when it is refused)."""
    state = _state()
    if "" not in state:
        top = root()
        state[""] = top if _owned(top, True) else None
    return state[""]


def _secret() -> bytes | None:
    """The per-user key: read from ``secret.key`` (a regular file, not a link, this user's,
    0600, 32 bytes) or made once, published whole by a hard link so that a racing process
    reads all of it or none."""
    with _LOCK:
        state = _state()
        if "key" in state:
            return state["key"]
        key = None
        top = _top()
        if top is not None:
            path = top / SECRET
            key = _read_secret(path)
            if key is None and not path.exists():
                try:
                    fd, temporary = tempfile.mkstemp(dir=top, prefix=".secret-")
                    try:
                        os.write(fd, os.urandom(SECRET_BYTES))
                        os.fsync(fd)
                    finally:
                        os.close(fd)
                    try:
                        os.link(temporary, path)
                    except FileExistsError:
                        pass  # another process made it first: its key is the one
                    finally:
                        os.unlink(temporary)
                except OSError:
                    pass
                key = _read_secret(path)
            elif key is None:
                _refuse(path, "the cache's key is not a private file of this user")
        state["key"] = key
        return key


def _read_secret(path: Path) -> bytes | None:
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW)
    except OSError:
        return None
    try:
        info = os.fstat(fd)
        if (
            not stat.S_ISREG(info.st_mode)
            or info.st_uid != os.geteuid()
            or info.st_mode & 0o077
            or info.st_size != SECRET_BYTES
        ):
            return None
        data = os.read(fd, SECRET_BYTES + 1)
        return data if len(data) == SECRET_BYTES else None
    finally:
        os.close(fd)


def _tag(key: bytes, kind: str, name: str, payload: bytes) -> bytes:
    h = hmac.new(key, digestmod=hashlib.sha256)
    h.update(kind.encode() + b"\0" + name.encode() + b"\0")
    h.update(payload)
    return h.digest()


def read(kind: str, name: str) -> bytes | None:
    """The payload stored under ``name`` when its tag is this user's, else None (an entry that
    fails is removed)."""
    where = folder(kind)
    key = _secret() if where is not None else None
    if where is None or key is None:
        return None
    path = where / name
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW)
    except FileNotFoundError:
        return None
    except OSError:  # a link planted at the name, unreadable: a miss, cleared
        _remove(path)
        return None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode) or info.st_uid != os.geteuid():
            data = b""
        else:
            with os.fdopen(os.dup(fd), "rb") as stream:
                data = stream.read()
    finally:
        os.close(fd)
    head = len(MAGIC) + TAG
    payload = data[head:]
    if (
        len(data) < head
        or not data.startswith(MAGIC)
        or not hmac.compare_digest(data[len(MAGIC) : head], _tag(key, kind, name, payload))
    ):
        _remove(path)
        return None
    return payload


def write(kind: str, name: str, payload: bytes) -> bool:
    """Store ``payload`` under ``name`` (atomically: a fresh private temporary renamed over
    it); False when the cache is refused, absent or cannot be written."""
    where = folder(kind)
    key = _secret() if where is not None else None
    if where is None or key is None:
        return False
    temporary = None
    try:
        fd, temporary = tempfile.mkstemp(dir=where, prefix=".tmp-")
        with os.fdopen(fd, "wb") as stream:
            stream.write(MAGIC + _tag(key, kind, name, payload) + payload)
        os.replace(temporary, where / name)
        return True
    except OSError:
        if temporary is not None:
            _remove(Path(temporary))
        return False


def arrays(kind: str, name: str, fields: tuple[str, ...], compute) -> dict:
    """Numpy arrays kept under ``name``: read back when an entry holds every one of ``fields``
    (an npz of plain arrays, loaded with ``allow_pickle=False`` after authentication), else
    ``compute()`` (a dict of those arrays) stored.  A cache that cannot be used is no error:
    the arrays are computed."""
    import io

    import numpy as np

    stored = read(kind, name)
    if stored is not None:
        try:
            with np.load(io.BytesIO(stored), allow_pickle=False) as npz:
                return {f: npz[f] for f in fields}
        except (ValueError, KeyError, OSError):
            pass  # another layout: computed again
    out = compute()
    buffer = io.BytesIO()
    np.savez(buffer, **out)
    write(kind, name, buffer.getvalue())
    return out


def touch(kind: str, name: str) -> None:
    """Mark an entry recently used (pruning keeps it)."""
    where = folder(kind)
    if where is not None:
        try:
            os.utime(where / name, follow_symlinks=False)
        except OSError:
            pass


def prune(kind: str, pattern: str, keep: int) -> None:
    """Keep the ``keep`` most recently used entries matching ``pattern``."""
    where = folder(kind)
    if where is None:
        return
    try:
        entries = [(p.lstat().st_mtime_ns, p) for p in where.glob(pattern)]
    except OSError:
        return
    if len(entries) > keep:
        for _, old in sorted(entries)[: len(entries) - keep]:
            _remove(old)


def _remove(path: Path) -> None:
    try:
        path.unlink()
    except OSError:
        pass

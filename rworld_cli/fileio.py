"""Writing outputs so that a kill at any instant leaves the old output or the new one, whole.

Two mechanisms, one naming scheme (docs/architecture.md, "Writes that survive a kill"):

* **One file** (:func:`atomic_write_bytes`): a temporary beside the target, fsync, rename over
  it.  A reader sees the old file or the new one.
* **Several files or a folder** (:func:`output_set`): every file a command writes inside the
  ``with`` block is staged - in a staging copy of a claimed folder, or as a temporary beside a
  loose target - and nothing appears until the block ends.  Then a journal naming every staged
  unit is written (the commit point), each folder is swapped in (``renameat2(RENAME_EXCHANGE)``
  on Linux: the path is never missing; elsewhere two renames) and each loose file renamed over
  its target, and the journal is removed.  A run killed before the journal leaves the old
  output; after it, the next rworld command that writes any of the targets rolls the journal
  forward and so completes the new output.

Every temporary is named ``.<target name>.rworld-<kind>.<pid>.<random>`` beside its target
(journals ``.rworld-journal.<pid>.<random>.json``), so rworld knows its own debris: before
writing a target, a command finishes or removes what a killed run (a process no longer alive on
this machine) left beside it, and says so in one line on the ``rworld`` logger (the CLI prints it
on stderr).  ``rworld validate`` lists such debris in a cell folder (:func:`debris_in`).
"""

from __future__ import annotations

import contextlib
import contextvars
import errno
import json
import os
import re
import secrets
import shutil
import stat
import sys
from dataclasses import dataclass, field
from pathlib import Path

_NAME = re.compile(r"^\.(?P<target>.+)\.rworld-(?P<kind>tmp|stage|old)\.(?P<pid>\d+)\.[0-9a-f]+")
_JOURNAL = re.compile(r"^\.rworld-journal\.(?P<pid>\d+)\.[0-9a-f]+\.json$")


NAME_MAX = 255  # bytes in one file name (Linux, macOS, Windows' NTFS: the common limit)


def _tag(name: str) -> str:
    """``name`` as it appears in its temporaries' names: shortened with a hash when a long
    name (up to the file system's limit) would make the temporary's too long."""
    if len(os.fsencode(name)) <= NAME_MAX - 48:
        return name
    import hashlib

    digest = hashlib.sha256(os.fsencode(name)).hexdigest()[:16]
    return os.fsdecode(os.fsencode(name)[:120]).rstrip("\ufffd") + "~" + digest


def _temporary_name(target: Path, kind: str) -> Path:
    """A name beside ``target`` that marks the file as rworld's (kind: tmp, stage, old)."""
    tag = _tag(target.name)
    return target.parent / f".{tag}.rworld-{kind}.{os.getpid()}.{secrets.token_hex(4)}"


def _cannot_write(path: str | Path, exc: OSError):
    """An environment failure (a full disk, a read-only file system, a parent that is a file, a
    name too long) as bad input: exit 2 with the path and the reason."""
    from .errors import UserError

    reason = exc.strerror or str(exc)
    return UserError(f"cannot write {path}: {reason[:1].lower() + reason[1:]}")


def _special(path: Path) -> str | None:
    """What ``path`` is when it exists and is neither a regular file nor a folder (a device,
    a FIFO, a socket; links followed), else None."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return None
    if stat.S_ISREG(mode) or stat.S_ISDIR(mode):
        return None
    if stat.S_ISCHR(mode):
        return "a character device"
    if stat.S_ISFIFO(mode):
        return "a FIFO"
    return "a socket" if stat.S_ISSOCK(mode) else "a block device"


def _write_in_place(path: str | Path, data: bytes) -> Path | None:
    """Write to a character device or a FIFO as it is (never replaced by a file); refuse a
    socket, a block device and ``-``.  None when ``path`` is an ordinary target."""
    from .errors import UserError

    if str(path) == "-":
        raise UserError("'-' is not a file name here: give a file to write")
    kind = _special(Path(path))
    if kind is None:
        return None
    if kind not in ("a character device", "a FIFO"):
        raise UserError(f"cannot write {path}: it is {kind}, not a file")
    try:
        fd = os.open(path, os.O_WRONLY)
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(fd, view) :]
        finally:
            os.close(fd)
    except OSError as exc:
        raise _cannot_write(path, exc) from None
    return Path(path)


def temporary_path(target: str | Path, suffix: str = "") -> Path:
    """A fresh rworld-named temporary path beside ``target`` (with ``suffix``, e.g. '.yaml' for a
    trial file that a reader recognises by its ending); removed by the next run if left."""
    target = Path(target)
    return target.parent / (_temporary_name(target, "tmp").name + suffix)


def _alive(pid: int) -> bool:
    """Whether process ``pid`` runs on this machine (the owner of a temporary is still writing)."""
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # it exists but is not ours (PermissionError), or we cannot tell: alive
        pass
    return True


def _mode_for(path: Path) -> int:
    """The old file's mode, or the umask's default for a new file (mkstemp alone makes 0600)."""
    if path.exists():
        return path.stat().st_mode & 0o777
    return 0o666 & ~_umask()


def _write_new_file(path: Path, data: bytes, mode: int) -> None:
    """Create ``path`` (never through an existing link: staged copies share inodes) and fsync;
    a failed write (a full disk) leaves no partial file."""
    path.unlink(missing_ok=True)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, mode)
    try:
        with os.fdopen(fd, "wb") as fh:
            os.fchmod(fh.fileno(), mode)  # the mode as asked, whatever the umask
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
    except BaseException:
        path.unlink(missing_ok=True)
        raise


def _fsync_dir(folder: Path) -> None:
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


# ------------------------------------------------------------------ swapping folders


def _exchange(a: Path, b: Path) -> bool:
    """Swap the entries ``a`` and ``b`` in one step (Linux renameat2 RENAME_EXCHANGE); False where
    the kernel, the libc or the file system cannot."""
    if not sys.platform.startswith("linux"):
        return False
    import ctypes

    try:
        libc = ctypes.CDLL(None, use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError):
        return False
    at_fdcwd, rename_exchange = -100, 2
    renameat2.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p]
    renameat2.argtypes += [ctypes.c_uint]
    if renameat2(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.ENOSYS, errno.EINVAL, errno.EOPNOTSUPP):
        return False
    raise OSError(code, os.strerror(code), str(a))


def _swap_in(staged: Path, target: Path) -> None:
    """Put the folder ``staged`` at ``target``; the old folder (if any) is removed afterwards."""
    if not target.exists():
        os.rename(staged, target)
        return
    if _exchange(staged, target):  # the path is never missing; ``staged`` now holds the old
        shutil.rmtree(staged, ignore_errors=True)
        return
    old = _temporary_name(target, "old")  # elsewhere: two renames, the journal covers the gap
    os.rename(target, old)
    os.rename(staged, target)
    shutil.rmtree(old, ignore_errors=True)


# ------------------------------------------------------------------ output sets


@dataclass
class _Unit:
    target: str  # absolute path of the output (a folder or a file)
    staged: str  # where it is staged, beside the target
    folder: bool
    inode: int = 0  # the staged folder's inode: after a swap the target has it


@dataclass
class OutputSet:
    """The files of one command's output, staged until :meth:`commit` (see the module doc)."""

    units: list[_Unit] = field(default_factory=list)

    def claim_folder(
        self, folder: str | Path, keep_others: bool = False, replace: tuple[str, ...] = ()
    ) -> Path:
        """Make ``folder`` an output replaced as a whole: files written under it go to a staging
        copy.  ``keep_others``: the copy starts with the folder's present files (hard links where
        the file system allows), so files the command does not write survive (a cell's programs
        when its robot is imported again).  ``replace``: glob patterns of the command's own
        outputs; the copy starts without them, so an output this run does not write (an earlier
        run's plot, its collisions) is gone, not left beside the new ones."""
        target = Path(os.path.abspath(folder))
        if target.exists() and not target.is_dir():
            from .errors import UserError

            raise UserError(f"{folder} exists and is not a folder")
        for unit in self.units:
            if unit.folder and Path(unit.target) == target:
                return Path(unit.staged)
        staged = _temporary_name(target, "stage")
        try:
            target.parent.mkdir(parents=True, exist_ok=True)
            recover(target)
            if keep_others and target.is_dir():
                shutil.copytree(target, staged, symlinks=True, copy_function=_link_or_copy)
                for pattern in replace:
                    for old in staged.glob(pattern):
                        if old.is_symlink() or old.is_file():
                            old.unlink()
            else:
                staged.mkdir()
            staged.chmod(target.stat().st_mode & 0o777 if target.exists() else 0o777 & ~_umask())
            self.units.append(_Unit(str(target), str(staged), True, staged.stat().st_ino))
        except OSError as exc:
            shutil.rmtree(staged, ignore_errors=True)
            raise _cannot_write(folder, exc) from None
        return staged

    def stage(self, path: str | Path, data: bytes) -> Path:
        """Stage ``data`` for ``path``; returns ``path`` (where it will be)."""
        target = Path(os.path.abspath(path))
        try:
            for unit in self.units:
                if unit.folder and target.is_relative_to(unit.target):
                    inside = Path(unit.staged) / target.relative_to(unit.target)
                    _no_links_between(Path(unit.staged), inside.parent, Path(unit.target))
                    inside.parent.mkdir(parents=True, exist_ok=True)
                    _write_new_file(inside, data, _mode_for(target))
                    return Path(path)
                if not unit.folder and Path(unit.target) == target:
                    _write_new_file(Path(unit.staged), data, _mode_for(target))
                    return Path(path)
            if _write_in_place(path, data) is not None:
                return Path(path)
            target.parent.mkdir(parents=True, exist_ok=True)
            recover(target)
            staged = _temporary_name(target, "tmp")
            _write_new_file(staged, data, _mode_for(target))
            self.units.append(_Unit(str(target), str(staged), False))
        except OSError as exc:
            raise _cannot_write(path, exc) from None
        return Path(path)

    def commit(self) -> None:
        """Write the journal, move every unit into place, remove the journal."""
        if not self.units:
            return
        for unit in self.units:
            if unit.folder:
                _fsync_tree(Path(unit.staged))
        try:
            journals = _write_journals(self.units)
        except OSError as exc:  # nothing moved yet: the set is aborted, the old outputs stay
            raise _cannot_write(exc.filename or self.units[0].target, exc) from None
        _roll_forward(self.units)
        for path in journals:
            path.unlink(missing_ok=True)
        self.units = []

    def abort(self) -> None:
        """Remove everything staged; the old outputs stay as they were."""
        for unit in self.units:
            staged = Path(unit.staged)
            if unit.folder:
                shutil.rmtree(staged, ignore_errors=True)
            else:
                staged.unlink(missing_ok=True)
        self.units = []


_ACTIVE: contextvars.ContextVar[OutputSet | None] = contextvars.ContextVar(
    "rworld_outputs", default=None
)


@contextlib.contextmanager
def output_set(
    *folders: str | Path | None, keep_others: bool = False, replace: tuple[str, ...] = ()
):
    """Stage every file written in the block (by any writer in rworld: they all go through
    :func:`atomic_write_bytes`) and commit them together when the block ends without an error.

    ``folders`` (None entries are skipped) are claimed as whole outputs first
    (:meth:`OutputSet.claim_folder`).  An exception in the block removes what was staged and
    leaves every old output as it was.  Sets do not nest: an inner block joins the outer one.
    """
    outer = _ACTIVE.get()
    outputs = outer if outer is not None else OutputSet()
    token = _ACTIVE.set(outputs) if outer is None else None
    try:
        for folder in folders:
            if folder is not None:
                outputs.claim_folder(folder, keep_others, replace)
        yield outputs
        if token is None:
            return  # joined: the outer set commits
        _ACTIVE.reset(token)
        token = None
        outputs.commit()
    except BaseException:
        if outer is None:  # a joined set is the outer block's to keep or drop
            outputs.abort()
        raise
    finally:
        if token is not None:
            _ACTIVE.reset(token)


def _umask() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return umask


def _link_or_copy(src: str, dst: str) -> None:
    try:
        os.link(src, dst)
    except OSError:
        shutil.copy2(src, dst)


def _fsync_tree(folder: Path) -> None:
    for root, dirs, _ in os.walk(folder):
        for name in dirs:
            _fsync_dir(Path(root) / name)
    _fsync_dir(folder)


def _write_journals(units: list[_Unit]) -> list[Path]:
    """The commit point: one journal in each folder that holds a target, written atomically;
    a failure (a full disk) removes the journals written so far: nothing is committed."""
    name = f".rworld-journal.{os.getpid()}.{secrets.token_hex(4)}.json"
    parents = sorted({str(Path(u.target).parent) for u in units})
    journals = [Path(p) / name for p in parents]
    text = json.dumps(
        {
            "units": [u.__dict__ for u in units],
            "journals": [str(j) for j in journals],
        },
        indent=1,
    ).encode()
    written: list[Path] = []
    try:
        for journal in journals:
            staged = _temporary_name(journal, "tmp")
            _write_new_file(staged, text, 0o644)
            os.replace(staged, journal)
            written.append(journal)
            _fsync_dir(journal.parent)
    except OSError:
        for journal in written:
            journal.unlink(missing_ok=True)
        raise
    return journals


def _no_links_between(top: Path, folder: Path, shown: Path) -> None:
    """No folder from ``top`` down to ``folder`` is a link: a claimed output folder's files are
    never written through one (a cell received in a pull request can carry ``meshes ->
    /elsewhere``).  ``shown``: the output folder as the user knows it, for the message."""
    from .errors import UserError

    part = top
    for name in folder.relative_to(top).parts:
        part = part / name
        if part.is_symlink():
            inside = shown / part.relative_to(top)
            raise UserError(
                f"{inside} is a link (to {os.readlink(part)}): rworld does not write through "
                f"links inside its output folder {shown}; replace it with a folder, or write "
                "elsewhere"
            )


def _roll_forward(units: list[_Unit]) -> None:
    """Move every staged unit into place; units already in place are left alone (this runs on
    commit and again when a killed run's journal is found)."""
    for unit in units:
        staged, target = Path(unit.staged), Path(unit.target)
        if unit.folder:
            if target.exists() and target.stat().st_ino == unit.inode:
                shutil.rmtree(staged, ignore_errors=True)  # swapped: staged holds the old
            elif staged.is_dir() and staged.stat().st_ino == unit.inode:
                _swap_in(staged, target)
        elif staged.exists():
            os.replace(staged, target)
        _fsync_dir(target.parent)


# ------------------------------------------------------------------ the writers


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically: a temporary file in the same folder, then rename.

    A reader sees the old file or the new one, never a mix; a crash leaves the old file intact.
    The file keeps the old file's mode, or gets the umask default.  Inside :func:`output_set`
    the file is staged with the set's other files and appears with them.
    """
    outputs = _ACTIVE.get()
    if outputs is not None:
        return outputs.stage(path, data)
    if _write_in_place(path, data) is not None:
        return Path(path)
    shown, path = path, Path(path)
    tmp = _temporary_name(path, "tmp")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        recover(path)
        _write_new_file(tmp, data, _mode_for(path))
        os.replace(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise _cannot_write(shown, exc) from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def write_scratch(path: str | Path, data: bytes) -> None:
    """Write a scratch file now, outside any output set (a trial a command reads back before it
    decides what to write); name it with :func:`temporary_path` so a killed run's is removed."""
    _write_new_file(Path(path), data, _mode_for(Path(path)))


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically, as :func:`atomic_write_bytes` does."""
    atomic_write_bytes(path, text.encode("utf-8"))


def save_figure(fig, path: str | Path, dpi: int = 110) -> Path:
    """Save a matplotlib figure as PNG atomically and close it."""
    import io

    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, dpi=dpi, format="png")
    plt.close(fig)
    return atomic_write_bytes(path, buf.getvalue())


# ------------------------------------------------------------------ what a killed run left


def debris_in(folder: str | Path) -> list[Path]:
    """rworld's temporaries and journals in ``folder`` whose writer is no longer running."""
    out: list[Path] = []
    try:
        entries = sorted(Path(folder).iterdir())
    except OSError:
        return out
    for entry in entries:
        match = _NAME.match(entry.name) or _JOURNAL.match(entry.name)
        if match and not _alive(int(match["pid"])):
            out.append(entry)
    return out


def recover(target: str | Path) -> list[str]:
    """Finish or remove what killed runs left beside ``target``: roll forward their committed
    journals in its folder, then remove their temporaries of ``target``.  Returns one line per
    thing done (also logged on the ``rworld`` logger)."""
    target = Path(os.path.abspath(target))
    done = []
    found = debris_in(target.parent)
    for entry in found:
        if _JOURNAL.match(entry.name) and entry.exists():
            done += _recover_journal(entry)
    for entry in found:
        match = _NAME.match(entry.name)
        if not entry.exists() and not entry.is_symlink():
            continue  # a journal's roll-forward took it
        if match and (match["target"] == _tag(target.name) or _JOURNAL.match(match["target"])):
            _remove(entry)
            done.append(f"removed {entry}, left by a killed rworld run")
    if done:
        import logging

        log = logging.getLogger("rworld")
        for line in done:
            log.warning(line)
    return done


def _recover_journal(journal: Path) -> list[str]:
    try:
        doc = json.loads(journal.read_text(encoding="utf-8"))
        units = [_Unit(**u) for u in doc["units"]]
        journals = [Path(j) for j in doc["journals"]]
    except (OSError, ValueError, TypeError, KeyError):  # torn or foreign: nothing to finish
        journal.unlink(missing_ok=True)
        return [f"removed {journal}, an unreadable journal of a killed rworld run"]
    _roll_forward(units)
    for path in journals:
        path.unlink(missing_ok=True)
    targets = ", ".join(u.target for u in units)
    return [f"completed the output of a killed rworld run: {targets}"]


def _remove(entry: Path) -> None:
    if entry.is_dir() and not entry.is_symlink():
        shutil.rmtree(entry, ignore_errors=True)
    else:
        entry.unlink(missing_ok=True)

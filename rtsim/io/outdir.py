"""Whole output directories: a run is written beside its target and swapped in at the end.

``rtsim scenario``, ``rtsim reproduce`` (and ``rtsim simulate`` for its files, via
:class:`FileSet`) never write into the directory a reader may be looking at. They write into
a hidden staging directory beside the target, ``.NAME.rtsim-<token>``, and swap it in when
everything is written:

- on Linux with ``renameat2(RENAME_EXCHANGE)`` (one atomic step: at every instant the target
  is either the whole earlier run or the whole new one), then the earlier run — now under the
  staging name — is removed;
- elsewhere (or on a file system without the exchange) by renaming the earlier run aside,
  the new one in, and removing the earlier one; a kill between the two renames leaves no
  target, and the next run puts the earlier one back (:func:`clean_leftovers`).

The swap holds an exclusive ``flock`` on the parent directory, so two runs into one target
swap one after the other (the last one wins; neither mixes files). A run holds a ``flock``
on its own staging directory while it lives; a staging directory whose lock is free belongs
to a killed run and is removed by the next run into the same target.

The target is checked before anything is computed (:func:`stage`): its parent must be
writable (the staging directory is made there at once), it must not be the working
directory or one of its ancestors, not a symlink, not a file, and when it exists and is not
empty it must be an earlier rtsim output — a ``manifest.json`` whose ``outputs`` list
names every entry — so a user's own directory is never replaced. Each refusal is an
:class:`~rtsim.errors.InputError` (one line, exit 2 on the command line) naming the option.

The flock helpers here are local to this module (a sweep-wide lock lives elsewhere).
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import errno
import fcntl
import json
import os
import secrets
import shutil
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from rtsim.errors import InputError

__all__ = ["StagedDir", "FileSet", "stage", "clean_leftovers", "is_rtsim_output",
           "STAGING_MARK"]

#: Infix of staging directories: ``.NAME.rtsim-<token>`` beside the target NAME.
STAGING_MARK = ".rtsim-"
_NEW = ".new"  # suffix while a staging directory is being made (before its lock is held)
_RENAME_EXCHANGE = 2
_AT_FDCWD = -100
_OLD_AGE_S = 60.0  # a ".new" directory older than this belongs to a killed run


def _libc_renameat2() -> Any:
    if not sys.platform.startswith("linux"):
        return None
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):
        return None
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p,
                   ctypes.c_uint]
    fn.restype = ctypes.c_int
    return fn


_RENAMEAT2 = _libc_renameat2()


def exchange(a: Path, b: Path) -> bool:
    """Atomically swap the paths ``a`` and ``b`` (Linux ``renameat2(RENAME_EXCHANGE)``).

    Returns False where the exchange is not available (other systems, some file systems).
    """
    if _RENAMEAT2 is None:
        return False
    rc = _RENAMEAT2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE)
    if rc == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.EINVAL, errno.ENOSYS, errno.ENOTSUP, errno.EOPNOTSUPP):
        return False
    raise OSError(err, os.strerror(err), str(b))


@contextlib.contextmanager
def _flock(path: Path, *, blocking: bool = True) -> Iterator[bool]:
    """Hold an exclusive flock on ``path`` (a directory); yields False if not blocking and
    somebody else holds it."""
    fd = os.open(path, os.O_RDONLY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | (0 if blocking else fcntl.LOCK_NB))
        except BlockingIOError:
            yield False
            return
        yield True
    finally:
        os.close(fd)


def _listed(manifest: Path) -> set[str] | None:
    """The top-level names a manifest's ``outputs`` lists (None: not an rtsim manifest)."""
    try:
        data = json.loads(manifest.read_text("utf-8"))
    except (OSError, UnicodeDecodeError, ValueError):
        return None
    if not isinstance(data, dict) or "rtsim_version" not in data:
        return None
    outputs = data.get("outputs")
    if not isinstance(outputs, list) or not all(isinstance(o, str) for o in outputs):
        return None
    # report.html: rtsim's own report, which earlier versions of rtsim reproduce left unlisted
    return {o.replace("\\", "/").split("/", 1)[0] for o in outputs} | {"manifest.json",
                                                                       "report.html"}


def is_rtsim_output(path: str | os.PathLike[str]) -> bool:
    """True if ``path`` is a directory whose ``manifest.json`` (rtsim's) lists every entry
    (hidden entries included), or an empty directory."""
    d = Path(path)
    if not d.is_dir() or d.is_symlink():
        return False
    entries = {e.name for e in d.iterdir()}
    if not entries:
        return True
    listed = _listed(d / "manifest.json")
    return listed is not None and entries <= listed


def _staging_dirs(target: Path) -> list[Path]:
    prefix = f".{target.name}{STAGING_MARK}"
    try:
        return [p for p in target.parent.iterdir() if p.name.startswith(prefix)]
    except OSError:
        return []


def clean_leftovers(target: str | os.PathLike[str]) -> list[Path]:
    """Remove the staging directories of killed runs beside ``target``; returns them.

    A staging directory whose flock is free is a killed run's (a live run holds its lock).
    If the target itself is missing (a kill between the two renames of the fallback swap),
    the earlier run, saved aside as ``.NAME.rtsim-<token>.old``, is put back first.
    """
    target = Path(target)
    removed: list[Path] = []
    if not target.parent.is_dir():
        return removed
    with _flock(target.parent):
        for p in sorted(_staging_dirs(target)):
            _clean_one(p, target, removed)
    return removed


def _clean_one(p: Path, target: Path, removed: list[Path]) -> None:
    """Remove (or, for the saved earlier run, restore) one staging directory if unlocked."""
    if not p.is_dir() or p.is_symlink():
        return
    if p.name.endswith(_NEW):
        with contextlib.suppress(OSError):
            if time.time() - p.stat().st_mtime < _OLD_AGE_S:
                return  # being made right now
    try:
        with _flock(p, blocking=False) as free:
            if not free:
                return
            if p.name.endswith(".old") and not os.path.lexists(target):
                os.rename(p, target)
                return
            shutil.rmtree(p, ignore_errors=True)
            removed.append(p)
    except OSError:
        return


def _check_target(target: Path, option: str) -> None:
    """Refuse a target that must not be replaced (module docstring)."""
    if target.is_symlink():
        raise InputError(f"{option} {target}: is a symlink; give the directory itself")
    resolved = target.resolve()
    cwd = Path.cwd().resolve()
    if resolved == cwd or resolved in cwd.parents:
        raise InputError(f"{option} {target}: is the working directory or contains it; "
                         f"give a new or an earlier output directory")
    if target.exists():
        if not target.is_dir():
            raise InputError(f"{option} {target}: exists and is not a directory")
        if not is_rtsim_output(target):
            raise InputError(f"{option} {target}: not empty and not an earlier rtsim output "
                             f"(its manifest.json must list every entry); it is left alone — "
                             f"give a new directory")


class StagedDir:
    """A run's staging directory beside ``target`` (see the module docstring).

    Use :func:`stage`; write everything into :attr:`path`; :meth:`commit` swaps it in,
    :meth:`abort` removes it. As a context manager it aborts unless committed.
    """

    def __init__(self, target: Path, option: str) -> None:
        self.target = target
        self.option = option
        self.committed = False
        parent = target.parent
        token = f"{os.getpid()}-{secrets.token_hex(4)}"
        name = f".{target.name}{STAGING_MARK}{token}"
        tmp = parent / (name + _NEW)
        try:
            parent.mkdir(parents=True, exist_ok=True)
            os.mkdir(tmp)
        except OSError as exc:
            raise InputError(f"{option} {target}: cannot write in {parent} "
                             f"({_why(parent, exc)})") from None
        self._fd = os.open(tmp, os.O_RDONLY)
        fcntl.flock(self._fd, fcntl.LOCK_EX)
        self.path = parent / name
        os.rename(tmp, self.path)
        # mkdir gives 0o777 & ~umask already; nothing to change

    def commit(self) -> Path:
        """Swap the staged directory in as the target (atomic on Linux); returns the target."""
        if self.committed:
            return self.target
        target, staged = self.target, self.path
        with _flock(target.parent):
            _check_target(target, self.option)  # again: it may have changed meanwhile
            if not os.path.lexists(target):
                os.rename(staged, target)
                old = None
            elif exchange(staged, target):
                old = staged  # the earlier run now lives under the staging name
            else:
                old = staged.with_name(staged.name + ".old")
                os.rename(target, old)
                os.rename(staged, target)
            _fsync_dir(target.parent)
        self.committed = True
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
        self._release()
        return target

    def abort(self) -> None:
        """Remove the staged directory (the target is untouched)."""
        if not self.committed:
            shutil.rmtree(self.path, ignore_errors=True)
        self._release()

    def _release(self) -> None:
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1

    def __enter__(self) -> StagedDir:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.abort()


def _why(parent: Path, exc: OSError) -> str:
    """The reason a directory could not be made in ``parent`` (a file on the way, say)."""
    for p in (parent, *parent.parents):
        if os.path.lexists(p):
            if not p.is_dir():
                return f"{p} is not a directory"
            break
    return exc.strerror or str(exc)


def _fsync_dir(d: Path) -> None:
    with contextlib.suppress(OSError):
        fd = os.open(d, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def stage(target: str | os.PathLike[str], *, option: str = "--out") -> StagedDir:
    """Check ``target`` and make its staging directory (before any work is done).

    Raises :class:`InputError` naming ``option`` for a target that must not be replaced or
    whose parent is not writable. Staging directories of killed runs are removed first.
    """
    target = Path(target)
    if str(target) in ("", "."):
        target = Path(".")
    _check_target(target, option)
    target = Path(os.path.abspath(target))
    clean_leftovers(target)
    return StagedDir(target, option)


class FileSet:
    """Several output files of one run, each written to a temporary file beside its target
    and all renamed in at :meth:`commit` (so a failed run leaves none of its files).

    :meth:`add` makes the temporary file at once (the target's directory is checked
    writable before the simulation). Each file is replaced atomically; the set is renamed
    in file by file (single files have no directory to swap).
    """

    def __init__(self) -> None:
        self._files: list[tuple[Path, Path]] = []

    def add(self, target: str | os.PathLike[str], option: str) -> Path:
        """Reserve ``target``; returns the temporary path to write instead."""
        import tempfile

        from rtsim.io.atomic import FILE_MODE

        target = Path(target)
        if target.is_dir():
            raise InputError(f"{option} {target}: is a directory; give a file name")
        try:
            target.parent.mkdir(parents=True, exist_ok=True)
            # the target's suffix kept last: writers choose the format by it
            fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.",
                                       suffix=f".tmp{target.suffix}", dir=target.parent)
        except OSError as exc:
            raise InputError(f"{option} {target}: cannot write in {target.parent} "
                             f"({_why(target.parent, exc)})") from None
        os.close(fd)
        os.chmod(tmp, FILE_MODE)
        self._files.append((target, Path(tmp)))
        return Path(tmp)

    def commit(self) -> list[Path]:
        """Rename every file in; returns the targets."""
        for target, tmp in self._files:
            os.replace(tmp, target)
        done = [t for t, _ in self._files]
        self._files = []
        return done

    def abort(self) -> None:
        """Remove the temporary files."""
        for _, tmp in self._files:
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
        self._files = []

    def __enter__(self) -> FileSet:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.abort()

"""Whole output directories: a run is written into a hidden staging directory beside its target
and swapped in at the end (`stage`; atomically with ``renameat2`` on Linux), the target checked
before anything is computed; resumable commands check theirs with `check_resumable`, single
files go through `FileSet`. The rules a reader can rely on: docs/outputs.md.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import errno
import fcntl
import functools
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
from rtsim.io.atomic import FILE_MODE, stem, temp_target
from rtsim.io.lock import LOCK_NAME

__all__ = [
    "StagedDir",
    "FileSet",
    "stage",
    "clean_leftovers",
    "is_rtsim_output",
    "STAGING_MARK",
    "FILES_MARK",
    "check_resumable",
    "owner",
    "stem",
    "sidecar",
    "shown",
]

#: Infix of staging directories: ``.NAME.rtsim-<token>`` beside the target NAME.
STAGING_MARK = ".rtsim-"
_NEW = ".new"  # suffix while a staging directory is being made (before its lock is held)
_RENAME_EXCHANGE = 2
_AT_FDCWD = -100
_OLD_AGE_S = 60.0  # a ".new" directory older than this belongs to a killed run


#: The staging directories of this process and the places they stand for, for messages
#: (the latest `_SHOWN_KEPT`: an error is reported after its run's staging is gone).
_SHOWN: dict[str, str] = {}
_SHOWN_KEPT = 64


def _show_as(staged: Path, target: Path) -> None:
    _SHOWN[os.fspath(staged)] = os.fspath(target)
    while len(_SHOWN) > _SHOWN_KEPT:
        del _SHOWN[next(iter(_SHOWN))]


def shown(path: str | bytes | os.PathLike[Any]) -> str:
    """``path`` as the user knows it: a file inside one of this process's staging
    directories is named by its target (``out/.run.rtsim-1-ab/jobs.csv`` is ``out/run/
    jobs.csv``), so that a message about it (a full disk) names the output."""
    p = os.fsdecode(path)
    for staged, target in _SHOWN.items():
        if p == staged or p.startswith(staged + os.sep):
            return target + p[len(staged) :]
    return p


def sidecar(target: str | os.PathLike[str]) -> Path:
    """The manifest of a single output file, beside it: ``NAME.manifest.json`` (a long
    NAME cut as in `stem`)."""
    t = Path(target)
    return t.with_name(f"{stem(t.name)}.manifest.json")


@functools.cache
def _libc_renameat2() -> Any:
    """libc's renameat2, looked up on first use (``find_library`` runs ``ldconfig``: not at
    import, where it cost every command ~10 ms)."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):
        return None
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    fn.restype = ctypes.c_int
    return fn


def exchange(a: Path, b: Path) -> bool:
    """Atomically swap the paths ``a`` and ``b`` (Linux ``renameat2(RENAME_EXCHANGE)``).

    Returns False where the exchange is not available (other systems, some file systems).
    """
    renameat2 = _libc_renameat2()
    if renameat2 is None:
        return False
    rc = renameat2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE)
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
    except (OSError, UnicodeDecodeError, ValueError, RecursionError):
        return None
    if not isinstance(data, dict) or "rtsim_version" not in data:
        return None
    outputs = data.get("outputs")
    if not isinstance(outputs, list) or not all(isinstance(o, str) for o in outputs):
        return None
    # report.html: rtsim's own report, which earlier versions of rtsim reproduce left unlisted
    return {o.replace("\\", "/").split("/", 1)[0] for o in outputs} | {
        "manifest.json",
        "report.html",
    }


def owner(path: str | os.PathLike[str]) -> str | None:
    """The command (``scenario``, ``sweep``, ...) named by rtsim's ``manifest.json`` at
    ``path`` (a directory's, or a file's own ``NAME.manifest.json``), or None."""
    p = Path(path)
    man = p / "manifest.json" if p.is_dir() else p
    try:
        data = json.loads(man.read_text("utf-8"))
    except (OSError, UnicodeDecodeError, ValueError, RecursionError):
        return None
    if not isinstance(data, dict) or "rtsim_version" not in data:
        return None
    command = data.get("command")
    return command.removeprefix("rtsim ") if isinstance(command, str) else None


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
    prefix = f".{stem(target.name)}{STAGING_MARK}"
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


def _check_place(target: Path, option: str) -> None:
    """Refuse a directory target that is a symlink, the working directory (or contains it)
    or a file."""
    if target.is_symlink():
        raise InputError(f"{option} {target}: is a symlink; give the directory itself")
    resolved = target.resolve()
    cwd = Path.cwd().resolve()
    if resolved == cwd or resolved in cwd.parents:
        raise InputError(
            f"{option} {target}: is the working directory or contains it; "
            f"give a new or an earlier output directory"
        )
    if target.exists() and not target.is_dir():
        raise InputError(f"{option} {target}: exists and is not a directory")


def _other_command(target: Path, option: str, command: str | None) -> None:
    """Refuse a directory that another command's manifest claims."""
    other = owner(target) if command is not None else None
    if other is not None and other != command.removeprefix("rtsim "):  # type: ignore[union-attr]
        raise InputError(
            f"{option} {target}: is the output directory of `rtsim {other}`; it "
            f"is left alone — give a new directory"
        )


#: Commands whose output directory holds another command's by design (``validate``'s
#: sweeps, under ``sweeps/``).
_NESTS: dict[str, tuple[str, ...]] = {"validate": ("sweep",)}


def _enclosing(target: Path, command: str | None, first: int = 0) -> tuple[Path, str] | None:
    """The nearest ancestor of ``target`` (from its ``first``-th: 0 is its parent) that is an
    rtsim command's output directory (its ``manifest.json`` names the command), and that
    command: writing there would put a stranger inside it (a sweep then refuses to resume,
    a rerun of the command removes it). Single-file commands' directories (``simulate``'s)
    are shared and not counted, nor a command's own nested outputs (`_NESTS`)."""
    here = Path(os.path.abspath(target)).parent
    for a in [here, *here.parents][first:]:
        other = owner(a)
        if other is None or other in FILE_COMMANDS:
            continue
        if command is not None and command.removeprefix("rtsim ") in _NESTS.get(other, ()):
            continue
        return a, other
    return None


def _check_ancestors(target: Path, option: str, command: str | None) -> None:
    """Refuse a directory target inside another command's output directory."""
    inside = _enclosing(target, command)
    if inside is not None:
        raise InputError(
            f"{option} {os.fsdecode(target)}: is inside the output directory of `rtsim "
            f"{inside[1]}` ({os.fsdecode(inside[0])}); give a directory elsewhere"
        )


def _check_target(target: Path, option: str, command: str | None = None) -> None:
    """Refuse a target that must not be replaced (module docstring)."""
    _check_place(target, option)
    _check_ancestors(target, option, command)
    if target.exists():
        if not is_rtsim_output(target):
            raise InputError(
                f"{option} {target}: not empty and not an earlier rtsim output "
                f"(its manifest.json must list every entry); it is left alone — "
                f"give a new directory"
            )
        _other_command(target, option, command)


def check_resumable(
    target: str | os.PathLike[str],
    command: str,
    made: set[str],
    *,
    before_manifest: set[str] = frozenset(),  # type: ignore[assignment]
    option: str = "--out",
    clean: bool = False,
) -> None:
    """Check the directory of a resumable command (``sweep``, ``validate``), which works in
    place: new, empty, or holding only what ``command`` makes.

    With ``command``'s own ``manifest.json`` there, every entry must be one of ``made``;
    without one, one of ``before_manifest`` (what the command writes before its manifest).
    The temporary file of an atomic write of one of those files, left by a run killed while
    it wrote (`rtsim.io.atomic.temp_target`), is the command's own: tolerated, and
    removed with ``clean=True`` (call it holding the directory's lock, when no run of the
    command can be writing). Another command's directory and a user's files are refused
    (InputError naming the entry), so nothing the command did not make is ever overwritten
    or removed.
    """
    target = Path(target)
    _check_place(target, option)
    _check_ancestors(target, option, command)
    if not target.is_dir():
        return
    _other_command(target, option, command)
    own = owner(target) is not None
    if not own and (target / "manifest.json").exists():
        raise InputError(
            f"{option} {target}: has a manifest.json that is not rtsim's (a "
            f"user's file, or corrupt); it is left alone — remove it yourself or "
            f"give a new directory"
        )
    allowed = (made if own else set(before_manifest)) | {LOCK_NAME, "manifest.json"}
    stale = []
    for entry in sorted(e.name for e in target.iterdir()):
        if temp_target(entry) in allowed and (target / entry).is_file():
            stale.append(target / entry)
        elif entry not in allowed:
            raise InputError(
                f"{option} {target}: holds {entry!r}, which `rtsim {command}` did "
                f"not make; it is left alone — give a new directory"
            )
    if clean:
        for f in stale:
            f.unlink(missing_ok=True)


class StagedDir:
    """A run's staging directory beside ``target`` (see the module docstring).

    Use `stage`; write everything into `path`; `commit` swaps it in,
    `abort` removes it. As a context manager it aborts unless committed.
    """

    def __init__(self, target: Path, option: str, command: str | None = None) -> None:
        self.target = target
        self.option = option
        self.command = command
        self.committed = False
        parent = target.parent
        token = f"{os.getpid()}-{secrets.token_hex(4)}"
        name = f".{stem(target.name)}{STAGING_MARK}{token}"
        self.path, self._fd = _locked_dir(parent, name, option, target)
        _show_as(self.path, target)

    def commit(self) -> Path:
        """Swap the staged directory in as the target (atomic on Linux); returns the target."""
        if self.committed:
            return self.target
        target, staged = self.target, self.path
        with _flock(target.parent):
            _check_target(target, self.option, self.command)  # again: it may have changed meanwhile
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


def _locked_dir(parent: Path, name: str, option: str, target: Path) -> tuple[Path, int]:
    """Make the hidden directory ``parent/name`` holding its flock (made as ``name.new``
    first, so that a cleanup never takes it for a killed run's); returns it and the lock's
    descriptor."""
    tmp = parent / (name + _NEW)
    try:
        parent.mkdir(parents=True, exist_ok=True)
        os.mkdir(tmp)
    except OSError as exc:
        raise InputError(
            f"{option} {target}: cannot write in {parent} ({_why(parent, exc)})"
        ) from None
    fd = -1
    try:
        fd = os.open(tmp, os.O_RDONLY)
        fcntl.flock(fd, fcntl.LOCK_EX)
        os.rename(tmp, parent / name)
    except BaseException:  # Ctrl-C or SIGTERM right here: leave nothing
        shutil.rmtree(tmp, ignore_errors=True)
        if fd >= 0:
            os.close(fd)
        raise
    # mkdir gives 0o777 & ~umask already; nothing to change
    return parent / name, fd


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


def stage(
    target: str | os.PathLike[str], *, option: str = "--out", command: str | None = None
) -> StagedDir:
    """Check ``target`` and make its staging directory (before any work is done).

    Raises `InputError` naming ``option`` for a target that must not be replaced or
    whose parent is not writable, and (with ``command``) another command's directory.
    Staging directories of killed runs are removed first.
    """
    target = Path(target)
    if str(target) in ("", "."):
        target = Path(".")
    _check_target(target, option, command)
    target = Path(os.path.abspath(target))
    clean_leftovers(target)
    return StagedDir(target, option, command)


#: Commands whose outputs are single files in a shared directory (its ``manifest.json``
#: lists their files); every other command owns its whole output directory.
FILE_COMMANDS = ("simulate", "animate")
#: Name of a file set's staging directory beside its files: ``.rtsim-files-<token>``.
FILES_MARK = ".rtsim-files-"


def _clean_file_staging(parent: Path) -> None:
    """Remove the file-staging directories of killed runs in ``parent`` (unlocked ones)."""
    try:
        found = [p for p in parent.iterdir() if p.name.startswith(FILES_MARK)]
    except OSError:
        return
    removed: list[Path] = []
    for p in sorted(found):
        _clean_one(p, p, removed)


def _same(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return os.path.abspath(a) == os.path.abspath(b)


class FileSet:
    """Several output files of one run of ``command``, each written into a hidden staging
    directory beside its target (``.rtsim-files-<token>``, locked while the run lives) and
    all renamed in at `commit`: a failed, interrupted or killed run leaves none of its
    files (a killed run's staging directory is removed by the next run writing there).

    `add` checks each target before any work: not a directory, not one of the run's
    ``inputs``, not given twice, not inside another command's output directory, and — when
    it exists — a file rtsim ``command`` wrote (listed by a ``manifest.json`` of that
    command beside it, or its own ``NAME.manifest.json``). Each refusal is one InputError
    line naming the option. Each file is replaced atomically; the set is renamed in file by
    file (single files have no directory to swap).
    """

    def __init__(
        self, command: str = "simulate", inputs: tuple[str | os.PathLike[str], ...] = ()
    ) -> None:
        self.command = command
        self.inputs = [Path(i) for i in inputs]
        self._files: list[tuple[Path, Path, str]] = []
        self._dirs: dict[Path, tuple[Path, int]] = {}
        self._on_release: list[Any] = []

    def on_release(self, fn: Any) -> None:
        """Call ``fn()`` when the set is committed or aborted, before its staging directory
        is removed (to close a writer still open on a staged file after an error)."""
        self._on_release.append(fn)

    def _made_here(self, target: Path) -> bool:
        """Whether ``target`` (existing) is a file this command wrote."""
        if target.name == "manifest.json" or target.name.endswith(".manifest.json"):
            return owner(target) == self.command
        own = sidecar(target)
        if owner(own) == self.command:
            return True
        listed = _listed(target.parent / "manifest.json")
        return owner(target.parent) == self.command and listed is not None and target.name in listed

    def check(self, target: str | os.PathLike[str], option: str) -> Path:
        """Refuse ``target`` as `add` does, without reserving it; returns it."""
        target = Path(target)
        shown = os.fsdecode(target)
        if target.is_dir():
            raise InputError(f"{option} {shown}: is a directory; give a file name")
        for i in self.inputs:
            if _same(target, i):
                raise InputError(
                    f"{option} {shown}: is an input of this run; give another file name"
                )
        for t, _, opt in self._files:
            if _same(target, t):
                raise InputError(
                    f"{option} {shown}: is also the file of {opt}; give each output its own file"
                )
        # the directory the file goes into, or any above it (a sweep's points/, a
        # reproduce run's test1/), must not be another command's output directory
        inside = _enclosing(target, None, 1 if target.name.endswith(".manifest.json") else 0)
        if inside is not None:
            raise InputError(
                f"{option} {shown}: is inside the output directory of `rtsim "
                f"{inside[1]}` ({os.fsdecode(inside[0])}); give a file elsewhere"
            )
        if os.path.lexists(target) and not self._made_here(target):
            raise InputError(
                f"{option} {shown}: exists and was not written by `rtsim "
                f"{self.command}`; it is left alone — remove it or give another "
                f"name"
            )
        return target

    def add(self, target: str | os.PathLike[str], option: str) -> Path:
        """Check and reserve ``target``; returns the staging path to write instead."""
        target = self.check(target, option)
        parent = Path(os.path.abspath(target.parent))
        if parent not in self._dirs:
            if parent.is_dir():
                _clean_file_staging(parent)
            name = f"{FILES_MARK}{os.getpid()}-{secrets.token_hex(4)}"
            self._dirs[parent] = _locked_dir(parent, name, option, target)
            _show_as(self._dirs[parent][0], parent)
        staged = self._dirs[parent][0] / target.name
        try:
            fd = os.open(staged, os.O_WRONLY | os.O_CREAT | os.O_EXCL, FILE_MODE)
        except OSError as exc:
            raise InputError(
                f"{option} {os.fsdecode(target)}: cannot write in "
                f"{os.fsdecode(parent)} ({_why(parent, exc)})"
            ) from None
        os.close(fd)
        os.chmod(staged, FILE_MODE)
        self._files.append((target, staged, option))
        return staged

    def commit(self) -> list[Path]:
        """Rename every file in; returns the targets."""
        for target, staged, _ in self._files:
            os.replace(staged, target)
        done = [t for t, _, _ in self._files]
        self._files = []
        self._release()
        return done

    def abort(self) -> None:
        """Remove the staged files."""
        self._files = []
        self._release()

    def _release(self) -> None:
        for fn in self._on_release:
            with contextlib.suppress(Exception):
                fn()
        self._on_release = []
        for d, fd in self._dirs.values():
            shutil.rmtree(d, ignore_errors=True)
            os.close(fd)
        self._dirs = {}

    def __enter__(self) -> FileSet:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.abort()

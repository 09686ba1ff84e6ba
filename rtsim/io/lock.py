"""An output directory's lock: one run at a time writes into ``DIR`` (``DIR/.rtsim.lock``).

The lock is an OS lock (``flock``) on the file ``DIR/.rtsim.lock``: the kernel releases it
when its holder exits, however it exits (``kill -9`` included), so a dead run never blocks
the next one and no stale-lock cleanup is needed. The file itself stays; while locked it
says who holds the lock (pid, host, command line, since when), which a second run quotes in
its one-line refusal (`DirectoryLocked`, an `InputError`: exit
2). On a system without ``fcntl`` (Windows) the lock is a no-op.
"""

from __future__ import annotations

import json
import os
import socket
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from datetime import UTC, datetime
from pathlib import Path

from rtsim.errors import InputError

__all__ = ["LOCK_NAME", "DirectoryLocked", "lock_directory", "holder"]

#: The lock file's name inside the locked directory.
LOCK_NAME = ".rtsim.lock"


class DirectoryLocked(InputError):
    """Another run holds the output directory's lock."""


def holder(directory: str | os.PathLike[str]) -> dict[str, object] | None:
    """What the lock file of ``directory`` says about its (last) holder, or None."""
    try:
        info = json.loads((Path(directory) / LOCK_NAME).read_text("utf-8"))
    except (OSError, ValueError):
        return None
    return info if isinstance(info, dict) else None


def _describe(directory: Path) -> str:
    info = holder(directory)
    if not info:
        return "another rtsim run"
    argv = info.get("argv")
    cmd = (" ".join(str(a) for a in argv) if isinstance(argv, list) else "") or "?"
    return (
        f"pid {info.get('pid')} on {info.get('host')} (command: {cmd}; since {info.get('since')})"
    )


@contextmanager
def lock_directory(
    directory: str | os.PathLike[str], argv: Sequence[str] | None = None
) -> Iterator[Path]:
    """Hold ``directory``'s lock for the ``with`` block (the directory is created).

    Raises `DirectoryLocked` at once, naming the holder, when another process holds
    it. Re-entrant within one process is *not* supported (a second lock of the same
    directory from the same process is refused as well).
    """
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    path = d / LOCK_NAME
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows
        yield path
        return
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise DirectoryLocked(
                f"{d}: in use by {_describe(d)}; wait for it to finish or use another --out"
            ) from None
        info = {
            "pid": os.getpid(),
            "host": socket.gethostname(),
            "argv": list(sys.argv if argv is None else argv),
            "since": datetime.now(UTC).isoformat(timespec="seconds"),
        }
        os.ftruncate(fd, 0)
        os.pwrite(fd, (json.dumps(info) + "\n").encode("utf-8"), 0)
        yield path
    finally:
        os.close(fd)  # closing the descriptor releases the flock

"""Atomic file output: write to a temporary file beside the target, then rename.

An interrupted run never leaves a half-written result behind.
"""

from __future__ import annotations

import json
import math
import os
import re
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from rtsim.errors import InputError

__all__ = [
    "atomic_path",
    "stem",
    "temp_target",
    "naming",
    "write_text",
    "write_bytes",
    "write_json",
    "write_table",
    "dumps",
    "NonFiniteJSON",
    "inf_as_null",
]

_UMASK = os.umask(0)
os.umask(_UMASK)
#: Mode of written files: what ``open`` would give (mkstemp alone makes them owner-only).
FILE_MODE = 0o666 & ~_UMASK


@contextmanager
def naming(path: str | os.PathLike[str]) -> Iterator[None]:
    """Give an `OSError` raised inside without a file name (a ``write`` on a full
    disk: "No space left on device") the name ``path``, so that its one-line message says
    which output could not be written."""
    try:
        yield
    except OSError as exc:
        if exc.filename is not None or isinstance(exc, BrokenPipeError):
            raise
        code = exc.errno
        # the system's words for the error (pyarrow's strerror is a whole message)
        why = os.strerror(code) if code is not None else (exc.strerror or str(exc))
        raise OSError(code, why, os.fspath(path)) from exc


#: The name of [`atomic_path`][rtsim.io.atomic.atomic_path]'s temporary file: ``.<target name>.<8
#: characters of
#: tempfile's alphabet>.tmp`` (``mkstemp(prefix=".<name>.", suffix=".tmp")``).
_TEMP = re.compile(r"\.(?P<name>.+)\.[a-z0-9_]{8}\.tmp", re.DOTALL)


def temp_target(entry: str) -> str | None:
    """The target name whose [`atomic_path`][rtsim.io.atomic.atomic_path] temporary file ``entry``
    is
    (``.results.parquet.k2j9_x0a.tmp`` → ``results.parquet``), or None: what a write killed
    by ``kill -9`` leaves beside its target."""
    m = _TEMP.fullmatch(entry)
    return m.group("name") if m else None


#: Longest target name used whole in a staging name (a name is at most 255 bytes; the
#: staging prefix and suffix add about 30): longer names are cut and a hash appended.
_NAME_MAX_WHOLE = 180


def stem(name: str) -> str:
    """``name`` as it appears in the hidden staging names beside it: whole when short, else
    cut and followed by a hash of the whole (so 225- to 255-byte names still work)."""
    if len(os.fsencode(name)) <= _NAME_MAX_WHOLE:
        return name
    import hashlib

    digest = hashlib.sha256(os.fsencode(name)).hexdigest()[:16]
    cut = os.fsencode(name)[:100].decode("utf-8", "ignore")
    return f"{cut}~{digest}"


@contextmanager
def atomic_path(target: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``target``; on success it replaces ``target``. A write
    error inside names ``target`` ([`naming`][rtsim.io.atomic.naming])."""
    target = Path(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    try:  # (a long name is cut and hashed in the temporary name: stem)
        fd, tmp = tempfile.mkstemp(
            prefix=f".{stem(target.name)}.", suffix=".tmp", dir=target.parent
        )
    except OSError as exc:  # named by the target, never by the hidden temporary name
        raise OSError(exc.errno, exc.strerror, os.fspath(target)) from None
    os.close(fd)
    os.chmod(tmp, FILE_MODE)
    tmp_path = Path(tmp)
    try:
        with naming(target):
            try:
                yield tmp_path
                os.replace(tmp_path, target)
            except OSError as exc:
                if exc.filename is None or os.fspath(exc.filename) != tmp:
                    raise
                raise OSError(exc.errno, exc.strerror, os.fspath(target)) from None
    finally:
        if tmp_path.exists():
            tmp_path.unlink()


def write_bytes(target: str | os.PathLike[str], data: bytes) -> None:
    """Write ``data`` to ``target`` atomically."""
    with atomic_path(target) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())


def write_text(target: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` (UTF-8) to ``target`` atomically."""
    write_bytes(target, text.encode("utf-8"))


def _json_default(obj: Any) -> Any:
    import numpy as np

    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.floating):
        return float(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON serializable: {type(obj).__name__}")


class NonFiniteJSON(ValueError):
    """A NaN or infinite number reached a JSON writer (strict JSON has no such numbers)."""


def _path_of(obj: Any, path: str = "") -> str | None:
    """The JSON path (``a.b[2]``) of the first non-finite float in ``obj``, or None."""
    import math

    if isinstance(obj, float):
        return None if math.isfinite(obj) else (path or "<value>")
    if isinstance(obj, dict):
        for k, v in obj.items():
            found = _path_of(v, f"{path}.{k}" if path else str(k))
            if found:
                return found
    if isinstance(obj, list | tuple):
        for i, v in enumerate(obj):
            found = _path_of(v, f"{path}[{i}]")
            if found:
                return found
    return None


def inf_as_null(obj: Any) -> Any:
    """``obj`` with every infinite float replaced by None, for fields whose documentation
    says that null means "no limit" (a NaN is left alone: it still raises)."""
    if isinstance(obj, float) and obj in (math.inf, -math.inf):
        return None
    if isinstance(obj, dict):
        return {k: inf_as_null(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [inf_as_null(v) for v in obj]
    return obj


def dumps(obj: Any, indent: int | None = 2) -> str:
    """Strict JSON text (RFC 8259) with numpy scalars handled.

    A NaN or infinite float raises [`NonFiniteJSON`][rtsim.io.atomic.NonFiniteJSON] naming its path:
    each writer
    turns such a value into ``null`` where its field's documentation says what null means
    there (``wcrt``: above the deadline; ``lap_time_s``: no lap; see docs/outputs.md).
    """
    try:
        return json.dumps(
            obj, indent=indent, default=_json_default, sort_keys=False, allow_nan=False
        )
    except ValueError as exc:
        if "JSON compliant" not in str(exc):
            raise
        plain = json.loads(json.dumps(obj, default=_json_default, allow_nan=True))
        raise NonFiniteJSON(
            f"non-finite number at {_path_of(plain)} (strict JSON has none; "
            "write null where the field's documentation says what it means)"
        ) from None


def write_json(target: str | os.PathLike[str], obj: Any) -> None:
    """Write ``obj`` as indented JSON to ``target`` atomically."""
    write_text(target, dumps(obj) + "\n")


def _to_parquet(df: Any, p: Path) -> None:
    # through a file Python opened: pyarrow takes a path only as UTF-8, and a path that is
    # not (bytes the file system gave as surrogates) is written as the file system gave it
    # (pyarrow directly: pandas < 2.2 swaps an opened file for its name before pyarrow sees it)
    import pyarrow as pa
    import pyarrow.parquet as pq

    with open(p, "wb") as fh:
        pq.write_table(pa.Table.from_pandas(df, preserve_index=False), fh)


def write_table(target: str | os.PathLike[str], df: Any) -> None:
    """Write a DataFrame as CSV or Parquet (by the suffix of ``target``) atomically."""
    target = Path(target)
    suffix = target.suffix.lower()
    writers: dict[str, Callable[[Path], None]] = {
        ".csv": lambda p: df.to_csv(p, index=False),
        ".parquet": lambda p: _to_parquet(df, p),
    }
    if suffix not in writers:
        raise InputError(f"{target}: output must end in .csv or .parquet")
    with atomic_path(target) as tmp:
        writers[suffix](tmp)

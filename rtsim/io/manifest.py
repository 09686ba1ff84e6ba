"""``manifest.json``: what made an output directory (rtsim version, seed, inputs, command line)."""

from __future__ import annotations

import os
import platform
import sys
from collections.abc import Mapping
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from rtsim._version import __version__
from rtsim.io.atomic import write_json

__all__ = ["build_manifest", "write_manifest"]


def build_manifest(
    *,
    command: str,
    seed: int | None,
    inputs: Mapping[str, Any],
    argv: list[str] | None = None,
    extra: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """The manifest as a dict: version, seed, resolved inputs, command line, platform."""
    manifest: dict[str, Any] = {
        "rtsim_version": __version__,
        "command": command,
        "argv": list(sys.argv if argv is None else argv),
        "seed": seed,
        "inputs": dict(inputs),
        "python": platform.python_version(),
        "created_utc": datetime.now(UTC).isoformat(timespec="seconds"),
    }
    if extra:
        manifest.update(extra)
    return manifest


def write_manifest(out_dir: str | os.PathLike[str], **kwargs: Any) -> Path:
    """Write ``out_dir/manifest.json`` atomically (arguments as `build_manifest`)."""
    path = Path(out_dir) / "manifest.json"
    write_json(path, build_manifest(**kwargs))
    return path

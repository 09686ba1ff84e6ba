"""The base task-set or scenario file of a sweep (its own module, so that the sweep's kinds
and its specification both use it without importing each other)."""

from __future__ import annotations

import hashlib
import json
import tomllib
from dataclasses import dataclass
from typing import Any

__all__ = ["BaseFile"]


@dataclass(frozen=True)
class BaseFile:
    """The base task-set or scenario file of a sweep: its path and its text.

    The text travels with every point, so remote (Dask) workers need no shared disk.
    """

    path: str | None
    text: str
    packaged: str = "barrel_robots"

    @property
    def source(self) -> str:
        """The name the loaders use in error messages."""
        return self.path or f"{self.packaged}.toml (packaged)"

    @property
    def sha256(self) -> str:
        """sha256 of the file's text."""
        return hashlib.sha256(self.text.encode("utf-8")).hexdigest()

    @property
    def data_sha256(self) -> str:
        """sha256 of the parsed content (canonical JSON): comments and layout do not count."""
        text = json.dumps(self.data(), sort_keys=True, separators=(",", ":"), default=str)
        return hashlib.sha256(text.encode("utf-8")).hexdigest()

    def data(self) -> dict[str, Any]:
        """The parsed TOML dict (a fresh copy on every call)."""
        return tomllib.loads(self.text)

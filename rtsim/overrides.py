"""Dotted-path overrides of a scenario or task-set file: the run options of the sweep kinds
that have a base file, and `apply_overrides`, which sets resolved paths in a TOML document
(one implementation, `rtsim.config.dotted`; the library's ``overrides=`` mapping and
``--set KEY=VALUE`` use it through the loaders).
"""

from __future__ import annotations

from rtsim.config.dotted import apply_paths

__all__ = ["RUN_OPTIONS", "apply_overrides"]

#: The run options (not keys of the file) of the sweep kinds that have a base file.
RUN_OPTIONS: dict[str, tuple[str, ...]] = {
    "simulate": ("horizon", "exec", "suspension", "window", "scheduler"),
    "scenario": ("mode", "duration", "exec", "scheduler"),
}

#: Set each resolved path (a tuple of keys) in a TOML dict: a sweep point's overrides.
apply_overrides = apply_paths

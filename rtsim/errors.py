"""The few exceptions rtsim raises on purpose.

Every input error carries a one-line message that names the file, the task or key,
and the problem; the command line prints it as ``rtsim: <message>`` and exits 2.
"""

from __future__ import annotations

__all__ = ["RtsimError", "InputError", "TaskSetError", "ScenarioError", "SweepError",
           "OverrideError"]


class RtsimError(Exception):
    """Base class of rtsim's own errors."""


class InputError(RtsimError, ValueError):
    """Bad user input (a file, a key, a value, an option): exit status 2 on the CLI."""


class TaskSetError(InputError):
    """A task or task set is invalid (file, task and field named in the message)."""


class ScenarioError(InputError):
    """A robot scenario is invalid."""


class SweepError(InputError):
    """A sweep file is invalid."""


class OverrideError(InputError):
    """A dotted override (``load_scenario(..., overrides={...})``, ``run_scenario(...,
    overrides=...)``) names no key of the file, or a run option instead of one."""

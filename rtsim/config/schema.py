"""JSON Schemas of the input files, generated from the models (``rtsim schema KIND``).

The schemas describe the TOML documents (as `tomllib.loads` returns them), so an
editor with a TOML language server (Taplo, Even Better TOML) checks a file as it is typed:
add ``#:schema <path or URL of the schema>`` as the first line of the file. The package
ships them in ``rtsim/data/schemas/`` (a test keeps them equal to the models).
"""

from __future__ import annotations

import json
import math
from importlib import resources
from typing import Any

from rtsim.config.taskset import TaskSetFile

__all__ = ["KINDS", "json_schema", "schema_text", "shipped_schema"]

#: The file kinds that have a schema.
KINDS = ("taskset", "scenario", "sweep")

_TITLES = {"taskset": "rtsim task set", "scenario": "rtsim scenario", "sweep": "rtsim sweep"}


def _model(kind: str) -> Any:
    if kind == "taskset":
        return TaskSetFile
    if kind == "scenario":
        from rtsim.config.scenario import ScenarioFile  # lazy: CLI start-up (numpy)

        return ScenarioFile
    if kind == "sweep":
        from rtsim.config.sweep import SweepFile  # lazy: CLI start-up (~4 ms)

        return SweepFile
    raise ValueError(f"no schema for {kind!r}: one of {', '.join(KINDS)}")


def _tidy(node: Any) -> Any:
    """TOML has no null: optional keys are just absent. Defaults JSON cannot write (inf) go."""
    if isinstance(node, list):
        return [_tidy(v) for v in node]
    if not isinstance(node, dict):
        return node
    out = {k: _tidy(v) for k, v in node.items()}
    if "anyOf" in out:
        kept = [s for s in out["anyOf"] if s != {"type": "null"}]
        if len(kept) == 1:
            del out["anyOf"]
            out = {**kept[0], **out}
        else:
            out["anyOf"] = kept
    if "default" in out and (
        out["default"] is None
        or (isinstance(out["default"], float) and not math.isfinite(out["default"]))
    ):
        del out["default"]
    return out


def json_schema(kind: str) -> dict[str, Any]:
    """The JSON Schema of a ``kind`` file (``taskset``, ``scenario`` or ``sweep``)."""
    schema = _tidy(_model(kind).model_json_schema())
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        **schema,
        "title": _TITLES[kind],
    }


def schema_text(kind: str) -> str:
    """`json_schema` as the text ``rtsim schema`` prints and the package ships."""
    return json.dumps(json_schema(kind), indent=2, ensure_ascii=False, allow_nan=False) + "\n"


def shipped_schema(kind: str) -> str:
    """The schema shipped in the package (``rtsim/data/schemas/<kind>.json``)."""
    return (resources.files("rtsim") / "data" / "schemas" / f"{kind}.json").read_text("utf-8")


if __name__ == "__main__":  # pragma: no cover - the test compares; this writes
    from pathlib import Path

    here = Path(__file__).resolve().parents[1] / "data" / "schemas"
    here.mkdir(exist_ok=True)
    for k in KINDS:
        (here / f"{k}.json").write_text(schema_text(k), encoding="utf-8")

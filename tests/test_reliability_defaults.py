"""Every documented default of every scenario key, and every key that takes ``inf``, runs
end to end through ``rtsim scenario`` and writes a strict ``summary.json``: a default can
never crash the summary after the whole run."""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path
from typing import Any

import pytest

from rtsim.cli import main
from rtsim.config.docs import ranges

TEST2 = Path(__file__).resolve().parents[1] / "rtsim" / "data" / "scenarios" / "test2.toml"
#: What a scenario cannot leave out (the rest has a documented default).
REQUIRED = {("name",), ("taskset",), ("leader", "speed"), ("leader", "shape"),
            ("leader", "start"), ("formation", "followers"), ("formation", "separation")}


def _leaves(tree: dict[str, Any], prefix: tuple[str, ...] = ()) -> list[tuple[str, ...]]:
    out = []
    for k, v in tree.items():
        if k == "assumptions" and not prefix:
            continue
        if isinstance(v, dict) and k not in ("shape", "start"):
            out += _leaves(v, (*prefix, k))
        else:
            out.append((*prefix, k))
    return out


def _without(tree: dict[str, Any], keys: list[tuple[str, ...]]) -> dict[str, Any]:
    tree = json.loads(json.dumps(tree))
    for key in keys:
        node = tree
        for part in key[:-1]:
            node = node[part]
        del node[key[-1]]
    return tree


def _toml(tree: dict[str, Any], prefix: str = "") -> str:
    def value(v: Any) -> str:
        if isinstance(v, float) and math.isinf(v):
            return "inf"
        if isinstance(v, dict):
            return "{" + ", ".join(f"{k} = {value(x)}" for k, x in v.items()) + "}"
        return json.dumps(v)

    flat = [f"{k} = {value(v)}" for k, v in tree.items() if not isinstance(v, dict)
            or k in ("shape", "start")]
    text = "\n".join(flat) + "\n"
    for k, v in tree.items():
        if isinstance(v, dict) and k not in ("shape", "start"):
            text += f"\n[{prefix}{k}]\n" + _toml(v, f"{prefix}{k}.")
    return text


def _run(tmp_path: Path, tree: dict[str, Any], tag: str) -> dict[str, Any]:
    tree = {k: v for k, v in tree.items() if k != "assumptions"}  # free text
    src = tmp_path / f"{tag}.toml"
    src.write_text(_toml(tree), "utf-8")
    out = tmp_path / f"out-{tag}"
    assert main(["scenario", str(src), "--duration", "1", "--no-figures",
                 "--out", str(out)]) == 0, tag

    def refuse(c: str) -> None:
        raise AssertionError(f"{tag}: {c} in summary.json")

    return json.loads((out / "summary.json").read_text("utf-8"), parse_constant=refuse)


BASE = tomllib.loads(TEST2.read_text("utf-8"))
OPTIONAL = [k for k in _leaves(BASE) if k not in REQUIRED]
INF_KEYS = sorted(r.key.removeprefix("scenario: ") for r in ranges().values()
                  if r.inf and r.key.startswith("scenario: "))


def test_every_default_at_once(tmp_path: Path) -> None:
    """Only the required keys: every other key takes its documented default."""
    minimal = _without(BASE, [*OPTIONAL, ("assumptions",)])
    s = _run(tmp_path, minimal, "minimal")
    assert s["leader_accel_max"] is None and s["leader_decel_max"] is None
    assert s["windows"] > 0


@pytest.mark.parametrize("key", OPTIONAL, ids=".".join)
def test_each_default_alone(tmp_path: Path, key: tuple[str, ...]) -> None:
    """test2 with one key left out (its default) runs and writes strict JSON."""
    s = _run(tmp_path, _without(BASE, [key]), "-".join(key))
    if key in (("leader", "accel_max"), ("leader", "decel_max")):
        assert s[f"leader_{key[1]}"] is None  # inf -> null: no limit (docs/outputs.md)


@pytest.mark.parametrize("key", INF_KEYS)
def test_each_inf_key(tmp_path: Path, key: str) -> None:
    """Every key whose range takes ``inf`` ("none") runs with ``inf``."""
    tree = json.loads(json.dumps(BASE))
    *path, last = key.split(".")
    node = tree
    for part in path:
        node = node.setdefault(part, {})
    node[last] = math.inf
    _run(tmp_path, tree, key)
    assert INF_KEYS  # the registry lists them

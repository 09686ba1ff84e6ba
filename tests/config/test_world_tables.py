"""The world's tables of a scenario file ([follower], [sensing], [ekf], [radio], [world]):
each key's default and range are declared once, on the world's spec (a frozen dataclass's
field, `rtsim.world._check.spec`); the table reads them (issue 31, item 3)."""

from __future__ import annotations

import ast
import inspect
import math
from dataclasses import MISSING, fields, replace
from typing import Annotated, Any, get_args, get_origin

import pytest

from rtsim.config import scenario as sc
from rtsim.config.fields import range_of
from rtsim.errors import ScenarioError
from rtsim.io.limits import Range
from rtsim.world.config import RadioParams, SensingParams, WorldConfig
from rtsim.world.ekf import EkfParams
from rtsim.world.follower import FollowerParams

#: Each world table and the spec it feeds.
PAIRS = [
    (sc.FollowerTable, FollowerParams),
    (sc.SensingTable, SensingParams),
    (sc.EkfTable, EkfParams),
    (sc.RadioTable, RadioParams),
    (sc.WorldTable, WorldConfig),
]


def _range(info: Any) -> Range | None:
    """The range among a field's metadata, also inside ``Annotated[...] | None``."""
    found = range_of(info.metadata)
    stack = [info.annotation]
    while found is None and stack:
        ann = stack.pop()
        if get_origin(ann) is Annotated:
            found = range_of(get_args(ann)[1:])
        else:
            stack += get_args(ann)
    return found


def _shared(table: type, spec: type) -> list[str]:
    return [f.name for f in fields(spec) if f.name in table.model_fields]


@pytest.mark.parametrize(("table", "spec"), PAIRS, ids=lambda x: x.__name__)
def test_a_table_key_has_the_specs_default_and_range(table: type, spec: type) -> None:
    """Every key the table shares with its spec: the same default, the same range."""
    shared = _shared(table, spec)
    assert shared, "no shared keys: the pairing is wrong"
    for f in fields(spec):
        if f.name not in table.model_fields:
            continue
        info = table.model_fields[f.name]
        assert f.default is not MISSING, f.name
        assert info.default == f.default or (
            isinstance(f.default, float) and math.isnan(f.default)
        ), f"{table.__name__}.{f.name}: default {info.default!r} != spec's {f.default!r}"
        rng = f.metadata.get("range")
        twin = table.model_fields.get(f"{f.name}_deg")
        for name, got in ((f.name, info), (f"{f.name}_deg", twin)):
            if rng is not None and got is not None:
                assert _range(got) == rng, f"{table.__name__}.{name}: range differs"


def _class_body(name: str) -> ast.ClassDef:
    tree = ast.parse(inspect.getsource(sc))
    return next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == name)


@pytest.mark.parametrize(("table", "spec"), PAIRS, ids=lambda x: x.__name__)
def test_a_world_key_is_declared_once(table: type, spec: type) -> None:
    """In the scenario model's source a shared key is not written in the table (the
    ``_of`` decorator makes it from the spec), or its default is the spec's attribute
    (``= WorldConfig.step_ms``) and its range is read with ``_spec``: a literal default or
    a range written again fails here, even if equal today."""
    shared = set(_shared(table, spec))
    assert shared
    for node in _class_body(table.__name__).body:
        if not (isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name)):
            continue
        key = node.target.id.removesuffix("_deg")
        if key not in shared:
            continue
        field = spec.__dataclass_fields__[key]
        src = ast.unparse(node.annotation)
        if "range" in field.metadata:
            assert "_spec(" in src and f"'{key}'" in src, f"{table.__name__}.{key}: {src}"
        if node.target.id.endswith("_deg") or field.default is None:
            continue  # the twin defaults to None (not given), as a key without a default
        value = node.value
        assert isinstance(value, ast.Attribute) and value.attr == key, (
            f"{table.__name__}.{key} = {ast.unparse(value) if value else None}: "
            f"take the default from {spec.__name__}.{key}"
        )
        assert isinstance(value.value, ast.Name)
        assert getattr(sc, value.value.id) is spec, ast.unparse(value)


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: FollowerParams(radius=2000.0), r"^follower\.radius: must be in \(0, 1000\] cm"),
        (lambda: FollowerParams(turn_noise=-1), r"^follower\.turn_noise: must be in \[0, 100\]"),
        (lambda: SensingParams(min_points=0), r"^sensing\.min_points: must be an integer >= 1"),
        (lambda: SensingParams(min_points=400), r"^sensing\.min_points: must be in \[1, 361\]"),
        (lambda: EkfParams(heading_drift=101.0), r"^ekf\.heading_drift: must be in \[0, 100\]"),
        (lambda: RadioParams(loss=1.0), r"^radio\.loss: must be in \[0, 1\)"),
    ],
)
def test_a_spec_made_by_hand_is_held_to_the_files_range(make, message) -> None:  # type: ignore[no-untyped-def]
    """A spec made by hand is checked against the same range as the file's key, one line."""
    with pytest.raises(ScenarioError, match=message):
        make()


def test_a_spec_keeps_the_types_it_always_had() -> None:
    """Ints from a file become floats (a count stays an int) and inf passes where allowed,
    as before the ranges moved (the runs' digests depend on the values, not the types, but
    the compiled kernels are fed floats)."""
    p = FollowerParams(radius=25, max_turn_rate=math.inf)
    assert type(p.radius) is float and p.max_turn_rate == math.inf
    s = SensingParams(min_points=3, max_range=math.inf)
    assert type(s.min_points) is int and s.max_range == math.inf


#: ``[leader]``'s numeric keys and the WorldConfig fields that declare them
LEADER_KEYS = {
    "speed": "leader_speed",
    "start_s": "start_s",
    "accel_max": "leader_accel_max",
    "decel_max": "leader_decel_max",
}


def test_the_leader_keys_are_declared_once() -> None:
    """``[leader]``'s numbers: the table's range and default are WorldConfig's field's (its
    range named by the file key), read with ``_spec`` and the field's attribute, never
    written again in the table; a WorldConfig built by hand is held to the same range."""
    spec_fields = {f.name: f for f in fields(WorldConfig)}
    for key, name in LEADER_KEYS.items():
        f, info = spec_fields[name], sc.LeaderTable.model_fields[key]
        rng = f.metadata["range"]
        assert rng.key == f"leader.{key}" and _range(info) == replace(rng, key=""), key
        if f.default is MISSING:
            assert info.is_required(), key
        else:
            assert info.default == f.default, key
    for node in _class_body("LeaderTable").body:
        if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            key = node.target.id
            if key in LEADER_KEYS:
                src = ast.unparse(node)
                assert f"_spec(WorldConfig, '{LEADER_KEYS[key]}')" in src, src
                assert node.value is None or ast.unparse(node.value) == (
                    f"WorldConfig.{LEADER_KEYS[key]}"
                ), src
    base = sc.load_scenario("test2").world
    for name, bad, message in (
        ("leader_speed", 1500.0, r"^leader\.speed: must be in \(0, 1000\] cm/s"),
        ("leader_accel_max", 0.0, r"^leader\.accel_max: must be in \(0, 100000\] cm/s² or inf"),
        ("start_s", -1.0, r"^leader\.start_s: must be in \[0, 1e\+07\] cm"),
    ):
        with pytest.raises(ScenarioError, match=message):
            replace(base, **{name: bad})
    assert replace(base, leader_decel_max=math.inf).leader_decel_max == math.inf

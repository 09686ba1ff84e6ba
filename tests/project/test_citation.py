"""CITATION.cff validates against the Citation File Format 1.2.0 schema, cites the paper rtsim
reproduces, and agrees with pyproject.toml.

``tests/data/cff-schema-1.2.0.json`` is the official schema (Citation File Format project,
CC-BY-4.0), as shipped inside cffconvert 2.0.0; cffconvert itself pins an old jsonschema that
the notebook tooling cannot share, so the schema is checked here with jsonschema directly.
"""

from __future__ import annotations

import copy
import json
import tomllib
from pathlib import Path

import pytest

from rtsim._version import __version__

ROOT = Path(__file__).resolve().parents[2]
yaml = pytest.importorskip("yaml")
jsonschema = pytest.importorskip("jsonschema")


def _cff() -> dict:
    return yaml.safe_load((ROOT / "CITATION.cff").read_text(encoding="utf-8"))


def _validator():
    schema = json.loads((ROOT / "tests" / "data" / "cff-schema-1.2.0.json").read_text("utf-8"))
    return jsonschema.Draft7Validator(schema)


def test_citation_file_validates() -> None:
    errors = [e.message for e in _validator().iter_errors(_cff())]
    assert errors == []


def test_the_schema_check_can_fail() -> None:
    no_authors = copy.deepcopy(_cff())
    del no_authors["authors"]
    bad_type = copy.deepcopy(_cff())
    bad_type["references"][0]["type"] = "not-a-type"
    for bad in (no_authors, bad_type):
        assert list(_validator().iter_errors(bad))


def test_citation_cites_the_paper_and_matches_the_package() -> None:
    cff = _cff()
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text("utf-8"))["project"]
    assert "version" in meta["dynamic"]  # written once, in rtsim/_version.py
    assert cff["version"] == __version__
    assert cff["license"] == meta["license"]
    paper = cff["references"][0]
    assert paper["title"] == "Using Dynamic Processing Windows for Robot Group Control"
    assert [a["family-names"] for a in paper["authors"]] == ["Qadi", "Goddard", "Huang", "Farritor"]

"""Atomic result files: all or nothing, with ordinary permissions."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pandas as pd
import pytest

from rtsim.errors import InputError
from rtsim.io.atomic import FILE_MODE, atomic_path, write_json, write_table, write_text


def test_interrupted_write_leaves_old_file_and_no_temp(tmp_path: Path) -> None:
    target = tmp_path / "out.txt"
    write_text(target, "old")
    with pytest.raises(RuntimeError):
        with atomic_path(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("killed")
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.txt"]


def test_files_get_the_umask_mode_not_owner_only(tmp_path: Path) -> None:
    target = tmp_path / "r.json"
    write_json(target, {"a": 1})
    assert stat.S_IMODE(os.stat(target).st_mode) == FILE_MODE
    assert FILE_MODE & 0o044  # readable by others under the usual umask 022


def test_table_by_suffix(tmp_path: Path) -> None:
    df = pd.DataFrame({"x": [1.0, float("inf")], "ok": [True, False]})
    write_table(tmp_path / "t.csv", df)
    write_table(tmp_path / "t.parquet", df)
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "t.parquet"), df)
    assert (tmp_path / "t.csv").read_text().splitlines() == ["x,ok", "1.0,True", "inf,False"]
    with pytest.raises(InputError, match=r"t\.xlsx: output must end in \.csv or \.parquet"):
        write_table(tmp_path / "t.xlsx", df)

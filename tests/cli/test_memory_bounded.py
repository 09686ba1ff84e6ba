"""Long outputs keep memory flat: each is written at two horizons, in a fresh interpreter,
and the longer run's peak resident memory (``ru_maxrss``) may exceed the shorter one's by at
most :data:`MARGIN_MB`, while its output is many times larger.

Before the traces were streamed, the longer runs here grew by about 110 MB (``simulate
--trace``), 330 MB (``simulate --perfetto``) and 100 MB (``scenario --perfetto``) over the
shorter ones (the rates measured for one-hour runs: 232, 700 and 683 MB per simulated
hour); the scenario's window and job tables were already written in chunks.
``benchmarks/bench_memory.py`` measures the same at hours of simulated time.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = str(ROOT / "tasksets" / "example.toml")
MARGIN_MB = 30.0

_CHILD = """
import resource, sys
from rtsim.cli import main
rc = main(sys.argv[1:])
print("PEAK", rc, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0)
"""


def _peak_mb(argv: list[str]) -> float:
    proc = subprocess.run(
        [sys.executable, "-c", _CHILD, *argv],
        cwd=ROOT,
        text=True,
        capture_output=True,
        check=False,
        timeout=600,
    )
    line = [ln for ln in proc.stdout.splitlines() if ln.startswith("PEAK ")]
    assert proc.returncode == 0 and line, proc.stderr[-2000:]
    _, rc, peak = line[-1].split()
    assert rc == "0", proc.stderr[-2000:]
    return float(peak)


# (name, command with {h} for the horizon and {o} for the output's path, the two horizons,
#  the output whose size shows how much was written)
RUNS = [
    (
        "simulate --trace",
        ["simulate", EXAMPLE, "--horizon", "{h}", "--trace", "{o}.csv"],
        (120_000, 1_800_000),
        "{o}.csv",
    ),
    (
        "simulate --perfetto",
        ["simulate", EXAMPLE, "--horizon", "{h}", "--perfetto", "{o}.json"],
        (120_000, 1_800_000),
        "{o}.json",
    ),
    (
        "scenario --perfetto",
        [
            "scenario",
            "test2",
            "--no-figures",
            "--duration",
            "{h}",
            "--out",
            "{o}",
            "--perfetto",
            "{o}.json",
        ],
        (60, 600),
        "{o}.json",
    ),
    (
        "scenario windows and jobs",
        ["scenario", "test2", "--no-figures", "--duration", "{h}", "--out", "{o}"],
        # The chunk buffers fill in the first simulated minutes (peaks measured 261, 275,
        # 287, 292, 298, 298 MB at 60, 300, 600, 900, 3,600, 7,200 s): 60 s against 900 s
        # compared a run still filling them (+31 MB) and failed whenever the kernels came
        # from the cache; 10 minutes against 2 hours compares two full ones.
        (600, 7200),
        "{o}/jobs.csv",
    ),
]


@pytest.mark.slow
@pytest.mark.parametrize("name,argv,horizons,sized", RUNS, ids=[r[0] for r in RUNS])
def test_peak_memory_does_not_grow_with_the_horizon(
    tmp_path: Path, name: str, argv: list[str], horizons: tuple[int, int], sized: str
) -> None:
    peaks, sizes = [], []
    for h in horizons:
        o = str(tmp_path / f"run{h}")
        peaks.append(_peak_mb([a.format(h=h, o=o) for a in argv]))
        sizes.append(Path(sized.format(o=o)).stat().st_size)
    assert sizes[1] > 8 * sizes[0], f"{name}: the long run wrote {sizes}"
    assert peaks[1] - peaks[0] <= MARGIN_MB, (
        f"{name}: peak {peaks[0]:.1f} MB at {horizons[0]}, {peaks[1]:.1f} MB at "
        f"{horizons[1]} (margin {MARGIN_MB:g} MB)"
    )

"""filterpy (and scipy) load only when a filterpy-backend filter is created."""

from __future__ import annotations

import subprocess
import sys

import numpy as np

from rtsim.world.ekf import EkfParams, FastFollowerEKF, FollowerEKF


def _modules_after(code: str) -> set[str]:
    out = subprocess.run(
        [
            sys.executable,
            "-c",
            code + "\nimport sys\nprint(' '.join(sorted(m.split('.')[0] for m in sys.modules)))",
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    return set(out.stdout.split())


def test_import_world_does_not_load_filterpy() -> None:
    mods = _modules_after("import rtsim.world, rtsim.coupling")
    assert "filterpy" not in mods
    assert "scipy" not in mods


def test_filterpy_backend_loads_filterpy_on_creation() -> None:
    mods = _modules_after(
        "from rtsim.world.ekf import EkfParams, make_filter\n"
        "make_filter((0.0, 0.0, 0.0), EkfParams(backend='filterpy'))"
    )
    assert "filterpy" in mods


def test_lazy_filterpy_filter_matches_fast_filter() -> None:
    params = EkfParams(backend="filterpy")
    ref, fast = FollowerEKF((10.0, -5.0, 0.3), params), FastFollowerEKF((10.0, -5.0, 0.3), params)
    for k in range(20):
        v, w, dt = 20.0 + k, 0.1 * ((-1) ** k), 0.24
        ref.predict(v, w, dt)
        fast.predict(v, w, dt)
        z = (ref.pose[0] + 0.5, ref.pose[1] - 0.3)
        ref.update(z)
        fast.update(z)
    np.testing.assert_allclose(ref.pose, fast.pose, rtol=0, atol=1e-9)
    np.testing.assert_allclose(ref.P, fast.P, rtol=0, atol=1e-9)

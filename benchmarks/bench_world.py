"""World cost per processing window, by hand (not a test): ``python benchmarks/bench_world.py``.

One window = advance ~240 ms of truth + scan (laser, fixes, Hough windows, violations)
+ EKF predict/update for every follower + one command per follower. Followers in the
default chevron (pairs 390 cm apart), leader at 25 cm/s on a rounded rectangle with
200 cm turns, so windows cover straights and turns. Prints µs per window for each n and
the growth per added follower (best of ``--repeat`` runs; ``--cpu`` for process CPU time,
robust on a shared machine).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from rtsim.world import World, WorldConfig, chevron, rounded_rectangle


def per_window_us(n: int, windows: int, w_ms: float = 240.0, cpu: bool = False) -> dict[str, float]:
    cfg = WorldConfig(rounded_rectangle(600, 400, 200), 25.0, chevron(n, 390))
    world = World(cfg, np.random.default_rng(0))
    parts = {"advance+scan": 0.0, "estimate": 0.0, "commands": 0.0}
    t = 0.0
    pc = time.process_time if cpu else time.perf_counter
    for _ in range(windows):
        t0 = pc()
        scan = world.scan(t)
        t1 = pc()
        world.estimate(scan)
        t2 = pc()
        for i in range(1, n + 1):
            world.command(i, t + 110.0 + (w_ms - 120.0) * i / (n + 1))
        t3 = pc()
        parts["advance+scan"] += t1 - t0
        parts["estimate"] += t2 - t1
        parts["commands"] += t3 - t2
        t += w_ms
    out = {k: 1e6 * v / windows for k, v in parts.items()}
    out["total"] = sum(out.values())
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--windows", type=int, default=1000)
    ap.add_argument("--n", type=int, nargs="*", default=[1, 2, 5, 10, 20, 50])
    ap.add_argument("--w", type=float, default=240.0, help="window length (ms)")
    ap.add_argument("--cpu", action="store_true", help="CPU time instead of wall time")
    ap.add_argument("--repeat", type=int, default=3, help="best of this many runs per n")
    args = ap.parse_args()
    per_window_us(2, 50)  # warm-up
    print(
        f"{'n':>3} {'total us':>9} {'adv+scan':>9} {'estimate':>9} {'commands':>9} "
        f"{'us/follower':>11}"
    )
    prev: tuple[int, float] | None = None
    for n in args.n:
        runs = [
            per_window_us(n, max(50, args.windows // max(1, n // 5)), args.w, args.cpu)
            for _ in range(max(1, args.repeat))
        ]
        r = min(runs, key=lambda x: x["total"])
        growth = "" if prev is None else f"{(r['total'] - prev[1]) / (n - prev[0]):11.1f}"
        print(
            f"{n:>3} {r['total']:9.1f} {r['advance+scan']:9.1f} {r['estimate']:9.1f} "
            f"{r['commands']:9.1f} {growth}"
        )
        prev = (n, r["total"])


if __name__ == "__main__":
    main()

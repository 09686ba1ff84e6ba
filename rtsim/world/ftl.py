"""Follow-the-leader control: each follower tracks the path the leader drove, offset
sideways, holding its place in line by a search on its offset trace, a speed law (FTL-1)
and pure pursuit (docs/model/world.md, "The follow-the-leader law")."""

from __future__ import annotations

import math
from collections.abc import Sequence

from rtsim.world.path import LeaderPath

__all__ = ["TraceFollower", "FTL_STEP"]

#: Bracketing step (cm) of the search for the reference point along the trace.
FTL_STEP = 10.0
_BISECT = 40
_NEWTON = 8
_NEWTON_REACH = 50.0
_SCALE_MIN = 0.05


class TraceFollower:
    """Follow-the-leader references and commands for n followers on ``path``.

    ``rho_d``: each follower's separation (cm); ``lateral``: its offset from the trace (cm,
    left positive); ``gain`` k_ρ (1/s); ``lookahead`` ℓ (cm). Holds, per follower, the last
    reference and projection arc lengths (searches start there).
    """

    def __init__(
        self,
        path: LeaderPath,
        rho_d: Sequence[float],
        lateral: Sequence[float],
        gain: float,
        lookahead: float,
    ) -> None:
        self.path = path
        self.rho_d = [float(r) for r in rho_d]
        self.lateral = [float(o) for o in lateral]
        # whom each follower follows (-1: the leader) and at what distance
        self.ahead: list[int] = []
        self.spacing: list[float] = []
        for k, (r, o) in enumerate(zip(self.rho_d, self.lateral, strict=True)):
            j = k - 2
            if j >= 0 and self.rho_d[j] < r:
                aj = math.sqrt(max(0.0, self.rho_d[j] ** 2 - self.lateral[j] ** 2))
                ak = math.sqrt(max(0.0, r * r - o * o))
                self.ahead.append(j)
                self.spacing.append(math.hypot(ak - aj, o - self.lateral[j]))
            else:
                self.ahead.append(-1)
                self.spacing.append(r)
        self.gain = float(gain)
        self.lookahead = float(lookahead)
        self._s_ref: list[float | None] = [None] * len(self.rho_d)
        self._s_f: list[float | None] = [None] * len(self.rho_d)

    def clone(self) -> TraceFollower:
        """A copy with its own search starts (a rollout plays commands ahead on it without
        moving this law's)."""
        new = object.__new__(TraceFollower)
        new.__dict__.update(self.__dict__)
        new._s_ref = list(self._s_ref)
        new._s_f = list(self._s_f)
        return new

    # -- geometry --------------------------------------------------------------------
    def point(self, k: int, s: float) -> tuple[float, float, float]:
        """P_k(s) and the heading there: (x, y, heading) of follower index k's offset curve."""
        x, y, h = self.path.pose(s)
        o = self.lateral[k]
        return x - o * math.sin(h), y + o * math.cos(h), h

    def scale(self, k: int, s: float) -> float:
        """1 − κ(s)·o_k: the offset curve's length per unit of trace (floored at 0.05)."""
        return max(_SCALE_MIN, 1.0 - self.path.curvature(s) * self.lateral[k])

    def reference(
        self, k: int, s_l: float, leader: tuple[float, float, float], v_l: float
    ) -> tuple[float, float]:
        """(s_ref, V_ref) of follower index k for the leader at arc length ``s_l``, pose
        ``leader``, speed ``v_l``: the first point of its offset trace behind the point it
        follows at its spacing (module docstring), and that point's speed (FTL-1)."""
        j = self.ahead[k]
        if j < 0:
            s_t, target, v_t = s_l, leader, v_l
        else:
            s_t, v_t = self.reference(j, s_l, leader, v_l)
            target = self.point(j, s_t)
        s_ref = self._search(k, s_t, target[:2], self.spacing[k])
        return s_ref, self._speed(k, s_ref, target, v_t)

    def _search(self, k: int, s_l: float, leader_xy: tuple[float, float], rho: float) -> float:
        """The first s ≤ ``s_l`` behind ``leader_xy`` with |P_k(s) − leader_xy| = ``rho``."""
        xl, yl = leader_xy
        rho2 = rho * rho
        s = self._s_ref[k]
        if s is not None and s <= s_l:
            # Newton steps from the last reference (it moves a few cm per command); the
            # bracketing search below when they do not converge quickly on this branch
            s_n = s
            for _ in range(_NEWTON):
                x, y, h = self.point(k, s_n)
                dx, dy = x - xl, y - yl
                dg = 2.0 * (dx * math.cos(h) + dy * math.sin(h)) * self.scale(k, s_n)
                if dg > -1e-6 * rho:
                    break
                step = (dx * dx + dy * dy - rho2) / dg
                s_n -= step
                if abs(s_n - s) > _NEWTON_REACH or s_n > s_l:
                    break
                if abs(step) < 1e-9:
                    self._s_ref[k] = s_n
                    return s_n

        def g(s: float) -> float:
            x, y, _ = self.point(k, s)
            return (x - xl) ** 2 + (y - yl) ** 2 - rho2

        limit = int(self.path.lap_length / FTL_STEP) + 2
        if s is None or s > s_l:
            s = s_l
        if g(s) > 0.0:  # too far behind: walk forward to the crossing
            lo = s
            for _ in range(limit):
                hi = min(lo + FTL_STEP, s_l)
                if g(hi) <= 0.0 or hi >= s_l:
                    break
                lo = hi
        else:  # too close: walk back
            hi = s
            for _ in range(limit):
                lo = hi - FTL_STEP
                if g(lo) > 0.0:
                    break
                hi = lo
        for _ in range(_BISECT):
            mid = 0.5 * (lo + hi)
            if g(mid) > 0.0:
                lo = mid
            else:
                hi = mid
            if hi - lo < 1e-7:
                break
        s_ref = 0.5 * (lo + hi)
        self._s_ref[k] = s_ref
        return s_ref

    def _speed(self, k: int, s_ref: float, leader: tuple[float, float, float], v_l: float) -> float:
        """V_ref by (FTL-1); V_T where the reference's tangent is nearly across the line."""
        xl, yl, hl = leader
        px, py, hp = self.point(k, s_ref)
        dx, dy = xl - px, yl - py
        den = dx * math.cos(hp) + dy * math.sin(hp)
        if den <= 0.1 * math.hypot(dx, dy):
            return v_l
        return v_l * (dx * math.cos(hl) + dy * math.sin(hl)) / den

    def project(self, k: int, x: float, y: float, guess: float) -> float:
        """Arc length of the trace whose offset point is nearest (x, y), by Newton steps on
        (p − P)·t / (1 − κo) from the last projection (or ``guess``)."""
        s = self._s_f[k]
        if s is None:
            s = guess
        for _ in range(6):
            px, py, h = self.point(k, s)
            ds = ((x - px) * math.cos(h) + (y - py) * math.sin(h)) / self.scale(k, s)
            s += ds
            if abs(ds) < 1e-3:
                break
        self._s_f[k] = s
        return s

    # -- the controller --------------------------------------------------------------
    def initial(
        self, k: int, s_l: float, leader: tuple[float, float, float], v_l: float
    ) -> tuple[float, float, float, float]:
        """(x, y, heading, speed) of follower index k on its reference, moving with it."""
        s_ref, v_ref = self.reference(k, s_l, leader, v_l)
        x, y, h = self.point(k, s_ref)
        self._s_f[k] = s_ref
        return x, y, h, v_ref

    def command(
        self,
        k: int,
        s_l: float,
        leader: tuple[float, float, float],
        v_l: float,
        x: float,
        y: float,
        th: float,
    ) -> tuple[float, float]:
        """(v, ω) for follower index k at (x, y, θ) (the leader's estimate), unsaturated."""
        s_ref, v_ref = self.reference(k, s_l, leader, v_l)
        s_f = self.project(k, x, y, s_ref)
        v = max(0.0, v_ref + self.gain * (s_ref - s_f) * self.scale(k, s_f))
        gx, gy, _ = self.point(k, min(s_f + self.lookahead, s_l))
        dx, dy = gx - x, gy - y
        dist = math.hypot(dx, dy)
        if dist < 1e-9:
            return v, 0.0
        alpha = math.atan2(dy, dx) - th
        return v, v * 2.0 * math.sin(alpha) / dist

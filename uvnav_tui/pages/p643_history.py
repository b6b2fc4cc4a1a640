"""Pg 643, Statistics ▸ Position ▸ History: filtered versus least-squares positions over time.

The thesis never built this page (L7670, THEORY D46); this is the recommended track-history
view.  Over the session's history window (up to this cycle), against minutes before the current
cycle's record time:

1. LSE − MPP, grid north component (m), at the cycles that have an LSE;
2. LSE − MPP, grid east component (m);
3. the MPP's ``ConfRegion`` (95 %) semi-major axis a (m, solid) and, at cycles without an LSE,
   the Pool of Errors radius R = a_LSE + ε·Δt (m, dashed; THEORY §10), so the navigator sees
   the two measures of the dived position's precision side by side.

Offsets are differences of grid coordinates of the same cycle (the TM grid of its CM; x east,
y north), so a change of CM does not disturb them.  :func:`history_page_lines` is the pure text.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar

from engine.api import (
    CycleResult,
    RunConfig,
    Session,
    drms,
    format_time_z,
    lse_estimate,
    poe_states,
)
from uvnav_tui.pages.registry import register_page
from uvnav_tui.pages.throttled_page import ThrottledTextPage, history_upto, snapshot
from uvnav_tui.widgets.canvas import DASHED, Series, chart_lines, nice_step

PAGE_NUMBER = 643
LABEL_WIDTH = 7
"""Width of the y tick labels (characters)."""


@dataclass(frozen=True)
class HistorySeries:
    """The History page's data, one entry per cycle of the window, oldest first: ``t_min``
    minutes relative to the current cycle (≤ 0); ``north_m``/``east_m`` LSE − MPP (m, NaN without
    an LSE); ``mpp_a_m`` the MPP's semi-major axis at the ``level`` confidence (m); ``poe_m`` the
    POE radius (m, NaN at cycles with an LSE or before the first one)."""

    t_min: list[float]
    north_m: list[float]
    east_m: list[float]
    mpp_a_m: list[float]
    poe_m: list[float]
    level: float
    rate_m_h: float


CycleValues = tuple[float, float, float, float, bool, float]
"""Per-cycle values: LSE − MPP north and east (m), the MPP's semi-major axis at the level (m), the
LSE's d_rms (m), whether the cycle has an LSE, and the record time (POSIX s)."""


def cycle_values(c: CycleResult, level: float) -> CycleValues:
    """The History page's values of one cycle (NaN where there is no LSE or no ellipse)."""
    ell = c.mpp.ellipse
    a = ell.scaled(level)[0] if ell is not None else math.nan
    t = c.time.timestamp()
    lse = lse_estimate(c)
    if lse is None:
        return math.nan, math.nan, a, math.nan, False, t
    return lse.y_m - c.mpp.y_m, lse.x_m - c.mpp.x_m, a, drms(lse.cov), True, t


def history_series(history: Sequence[CycleResult], r: CycleResult, cfg: RunConfig,
                   cache: dict[int, tuple[CycleResult, float, CycleValues]] | None = None
                   ) -> HistorySeries:
    """Extract the History page's series from the cycles of ``history`` up to ``r``.

    ``cache`` (optional, owned by the caller) memoises :func:`cycle_values` per cycle object
    and level, so a redraw only computes the new cycles; entries not in ``history`` are dropped.
    """
    level = cfg.lsq.conf_region_pct / 100.0
    rate = cfg.demo.poe_expansion_m_h
    t: list[float] = []
    north: list[float] = []
    east: list[float] = []
    amp: list[float] = []
    samples: list[tuple[float, bool, float]] = []
    t_now = r.time.timestamp()
    fresh: dict[int, tuple[CycleResult, float, CycleValues]] = {}
    for c in history:
        hit = cache.get(id(c)) if cache is not None else None
        if hit is not None and hit[0] is c and hit[1] == level:
            v = hit[2]
        else:
            v = cycle_values(c, level)
        fresh[id(c)] = (c, level, v)
        t.append((v[5] - t_now) / 60.0)
        north.append(v[0])
        east.append(v[1])
        amp.append(v[2])
        samples.append((v[5], v[4], v[3]))
    if cache is not None:
        cache.clear()
        cache.update(fresh)
    poe = [math.nan if s is None or smp[1] else s.radius_m
           for s, smp in zip(poe_states(samples, rate), samples, strict=True)]
    return HistorySeries(t, north, east, amp, poe, level, rate)


def _finite(values: Sequence[float]) -> list[float]:
    return [v for v in values if math.isfinite(v)]


def _symmetric_range(values: Sequence[float], floor: float = 10.0) -> tuple[float, float]:
    """±(a nice number ≥ max |v|), at least ±``floor`` (m)."""
    top = max([abs(v) for v in _finite(values)] + [floor])
    top = nice_step(top, 1)
    return -top, top


def _last(values: Sequence[float]) -> float:
    return values[-1] if values else math.nan


def _now(v: float) -> str:
    return f"{v:+.2f} m" if math.isfinite(v) else "---"


def history_page_lines(r: CycleResult | None, history: Sequence[CycleResult],
                       cfg: RunConfig | None, width: int, height: int,
                       cache: dict[int, tuple[CycleResult, float, CycleValues]] | None = None
                       ) -> list[str]:
    """The text of Pg 643 (``height`` lines of at most ``width`` characters); ``cache`` as in
    :func:`history_series`."""
    if r is None or cfg is None:
        return ["History", "", "no cycle yet"][:max(height, 0)]
    hist = history_upto(history, r) if history else [r]
    if width < LABEL_WIDTH + 12 or height < 10:
        return [f"History {format_time_z(r.time)}"[:max(width, 0)]][:max(height, 0)]
    s = history_series(hist, r, cfg, cache)
    span = max(1.0, -s.t_min[0]) if s.t_min else 1.0
    x_range = (-span, 0.0)
    x_step = nice_step(span, max(1, (width - LABEL_WIDTH - 1) // 8))
    gap = 2.5 * cfg.demo.delta_t_s / 60.0
    pct = f"{100.0 * s.level:g} %"
    title = f"History  {format_time_z(r.time)}  last {span:.1f} min  (time axis in min)"
    # rows: title, three panel titles, x axis, x labels; the rest shared by the panels
    plot_rows = height - 6
    hs = [plot_rows // 3 + (1 if i < plot_rows % 3 else 0) for i in range(3)]
    pts_n = list(zip(s.t_min, s.north_m, strict=True))
    pts_e = list(zip(s.t_min, s.east_m, strict=True))
    radius_top = nice_step(max(_finite(s.mpp_a_m) + _finite(s.poe_m) + [10.0]), 1)
    out = [title[:width]]
    out.append(f"LSE − MPP grid north (m)   now {_now(_last(s.north_m))}"[:width])
    out += chart_lines(width, hs[0], [Series(pts_n, join=False)], x_range,
                       _symmetric_range(s.north_m), x_axis=False, label_width=LABEL_WIDTH,
                       zero_line=True, x_step=x_step)
    out.append(f"LSE − MPP grid east (m)    now {_now(_last(s.east_m))}"[:width])
    out += chart_lines(width, hs[1], [Series(pts_e, join=False)], x_range,
                       _symmetric_range(s.east_m), x_axis=False, label_width=LABEL_WIDTH,
                       zero_line=True, x_step=x_step)
    a_now, r_now = _last(s.mpp_a_m), _last(s.poe_m)
    third = f"MPP {pct} a (m) ⠤ {a_now:.2f}"
    third += f"   POE R ⠉ {r_now:.2f} (ε {s.rate_m_h:g} m/h)" if math.isfinite(r_now) else (
        f"   POE R ⠉ (no-LSE cycles, ε {s.rate_m_h:g} m/h)")
    out.append(third[:width])
    out += chart_lines(width, hs[2] + 2,
                       [Series(list(zip(s.t_min, s.mpp_a_m, strict=True)), max_gap=gap),
                        Series(list(zip(s.t_min, s.poe_m, strict=True)), dash=DASHED,
                               max_gap=gap)],
                       x_range, (0.0, radius_top), label_width=LABEL_WIDTH, x_step=x_step,
                       x_format=lambda v: f"{v:g}")
    return [ln[:width] for ln in out]


class HistoryPage(ThrottledTextPage):
    """Pg 643 body (redrawn at most once a second: a minutes-long history needs no more)."""

    min_interval_s: ClassVar[float] = 1.0

    def __init__(self) -> None:
        super().__init__()
        self._cache: dict[int, tuple[CycleResult, float, CycleValues]] = {}

    def page_lines(self, r: CycleResult | None, session: Session | None, width: int,
                   height: int) -> list[str]:
        """:func:`history_page_lines` of the session's history."""
        if session is None:
            return history_page_lines(r, [], None, width, height)
        return history_page_lines(r, snapshot(session.history), session.config, width, height,
                                  self._cache)


register_page(PAGE_NUMBER, "History", HistoryPage)

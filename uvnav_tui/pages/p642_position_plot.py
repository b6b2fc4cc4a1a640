"""Pg 642, Statistics ▸ Position ▸ Plot: the current situation (THEORY §12.6 item 6, §10, D37).

A north-up braille map on the TM grid of the current cycle's CM (x east, y north, metres), centred
on the MPP, ``[demo] plot_scale_m`` metres either side of it across and the same metres per dot
down; ``[demo] plot_size`` is the fraction of the page the map takes (at most all of it).  On it:

* the own track: the MPPs of the session's history up to this cycle (``·`` dots/line);
* the LSE (``L``) and the MPP (``M``) with their ``ConfRegion`` (95 %) ellipses;
* the used LOPs through the LSE: short dotted segments along each LOP's azimuth;
* stations in view: the Decca chain's master and slaves (when Decca is on) and the stations of
  recent manual observations (``*`` and a name); those out of view are listed with grid
  bearing and distance;
* during a dive (no LSE this cycle): the Pool of Errors circle (dashed, R = a + ε·Δt, a = d_rms of
  the last LSE, ε = ``[demo] poe_expansion_m_h``) beside the filter's 95 % ellipse, with both radii
  in the legend and a zoomed inset showing both at a legible scale;
* a scale bar.

Everything drawn comes from the :class:`CycleResult` (its record time, not the wall clock).  The
widget redraws at most every ``MIN_INTERVAL_S`` seconds (:mod:`.throttled_page`) whatever the
cycle rate (a trailing redraw shows the last cycle).  :func:`plot_page_lines` is the pure text
of the page.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from engine.api import (
    CycleResult,
    PoeSample,
    PositionEstimate,
    RunContext,
    Session,
    drms,
    format_angle_deg,
    format_lon_dm,
    format_metres,
    format_time_z,
    lse_estimate,
    poe_states,
)
from uvnav_tui.pages.registry import register_page
from uvnav_tui.pages.throttled_page import ThrottledTextPage, history_upto, snapshot
from uvnav_tui.widgets.canvas import (
    DASHED,
    DOTTED,
    BrailleCanvas,
    format_distance,
    nice_length,
)

PAGE_NUMBER = 642
LEGEND_WIDTH = 24
"""Width of the legend column right of the map (characters)."""
LOP_HALF_LENGTH = 0.3
"""Half-length of a drawn LOP segment, as a fraction of the plot's half-width."""
RECENT_MANUAL = 600
"""Manual-observation stations of the last this many cycles are drawn."""
DECCA_NAMES = ("Master", "Red", "Green", "Purple")
LOP_KEY = "⠒"
"""Legend key of the (dotted) LOP segments and LSE ellipse."""
POE_KEY = "⠉"
"""Legend key of the (dashed) Pool of Errors circle."""


# --------------------------------------------------------------------------- data
def track_xy(history: Sequence[CycleResult], context: RunContext,
             cm_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """MPP track (grid m, x east / y north) of ``history`` on the grid of ``cm_deg``: cycles on
    another CM are re-projected from their geodetic MPP."""
    n = len(history)
    x = np.empty(n)
    y = np.empty(n)
    other: list[int] = []
    for i, c in enumerate(history):
        if c.cm_deg == cm_deg:
            x[i], y[i] = c.mpp.x_m, c.mpp.y_m
        else:
            other.append(i)
    if other:
        lat = np.array([history[i].mpp.lat_deg for i in other])
        lon = np.array([history[i].mpp.lon_deg for i in other])
        xo, yo = context.grid(cm_deg).forward_array(lat, lon)
        x[other], y[other] = xo, yo
    return x, y


@dataclass(frozen=True)
class PoeView:
    """The Pool of Errors at the current cycle: radius R (m), a = d_rms of the last LSE (m), Δt
    since it (s) and ε (m/h)."""

    radius_m: float
    a_m: float
    dt_s: float
    rate_m_h: float


def current_poe(history: Sequence[CycleResult], rate_m_h: float) -> PoeView | None:
    """The expanding-circle POE at the last cycle of ``history`` (None before any LSE)."""
    start = None
    for i in range(len(history) - 1, -1, -1):
        if lse_estimate(history[i]) is not None:
            start = i
            break
    if start is None:
        return None
    samples = [PoeSample(c.time, lse_estimate(c) is not None,
                         drms(c.fix.cov) if c.fix is not None else math.nan)
               for c in history[start:]]
    state = poe_states(samples, rate_m_h)[-1]
    if state is None:
        return None
    return PoeView(state.radius_m, state.a_m, state.dt_s, rate_m_h)


@dataclass(frozen=True)
class Station:
    """A station to show: ``label`` (one or a few characters), legend ``name`` and grid x/y (m)."""

    label: str
    name: str
    x_m: float
    y_m: float


def stations(r: CycleResult, history: Sequence[CycleResult], context: RunContext) -> list[Station]:
    """Decca stations (when Decca is on this cycle) and manual-observation stations of the last
    :data:`RECENT_MANUAL` cycles, on the grid of ``r.cm_deg``."""
    out: list[Station] = []
    if r.decca_on:
        placed = context.placed_chain(r.cm_deg)
        if placed is not None:
            for name, (x, y) in zip(DECCA_NAMES, placed.station_xy_m, strict=False):
                out.append(Station(name[0], f"{name} {placed.chain_id}", float(x), float(y)))
    seen: set[tuple[str, float, float]] = set()
    grid = context.grid(r.cm_deg)
    for c in reversed(history[-RECENT_MANUAL:]):
        for obs in c.manual:
            key = (obs.station, obs.lat_deg, obs.lon_deg)
            if key in seen:
                continue
            seen.add(key)
            x, y = grid.forward(obs.lat_deg, obs.lon_deg)
            out.append(Station("*", obs.station, x, y))
    return out


def _a95(p: PositionEstimate | None, level: float) -> tuple[float, float, float] | None:
    """(a, b, Az) of an estimate's ellipse at ``level``, None if there is none or not finite."""
    if p is None or p.ellipse is None:
        return None
    a, b = p.ellipse.scaled(level)
    if not (math.isfinite(a) and math.isfinite(b)):
        return None
    return a, b, p.ellipse.az_deg


def bearing_distance(dx: float, dy: float) -> str:
    """``045° 231.4 km``: grid bearing (degrees from grid north) and distance of (dx, dy) m."""
    az = round(math.degrees(math.atan2(dx, dy))) % 360
    d = math.hypot(dx, dy)
    dist = f"{d / 1000.0:.1f} km" if d >= 10_000.0 else f"{d:.0f} m"
    return f"{az:03d}° {dist}"


# --------------------------------------------------------------------------- text
def _legend(r: CycleResult, lse: PositionEstimate | None, level: float,
            poe: PoeView | None, mpp: PositionEstimate) -> list[str]:
    """The legend's fixed part: MPP, LSE and LOPs, or (no LSE) the Pool of Errors."""
    lines = [f"M MPP {mpp.source}  {100.0 * level:g} %"]
    m = _a95(mpp, level)
    if m:
        lines += [f"  a {m[0]:.2f} b {m[1]:.2f} m", f"  Az {format_angle_deg(m[2])}"]
    else:
        lines.append("  no ellipse")
    if lse is not None:
        e = _a95(lse, level)
        rms = r.fix.rms_m if r.fix is not None else math.nan
        lines.append(f"L LSE  RMS {format_metres(rms)}" if math.isfinite(rms) else "L LSE")
        if e:
            lines.append(f"  a {e[0]:.2f} b {e[1]:.2f} m")
        used = sum(1 for lop in r.fix.lops if lop.used) if r.fix is not None else 0
        lines.append(f"{LOP_KEY} LOPs {used} used")
    else:
        lines.append("L no LSE")
        if poe is None:
            lines.append("  POE: no LSE yet")
        else:
            lines += [
                f"{POE_KEY} POE R {format_metres(poe.radius_m)}",
                f"  a {poe.a_m:.2f} m ε {poe.rate_m_h:g} m/h",
                f"  Δt {poe.dt_s / 60.0:.1f} min",
            ]
            if m and poe.radius_m > 0.0:
                lines.append(f"  MPP a = {m[0] / poe.radius_m:.2f} R")
    return [ln[:LEGEND_WIDTH] for ln in lines]


def _station_lines(far: list[Station], mpp: PositionEstimate) -> list[str]:
    """Stations off the map: grid bearing and distance from the MPP."""
    if not far:
        return []
    lines = ["off the map"]
    for s in far:
        where = bearing_distance(s.x_m - mpp.x_m, s.y_m - mpp.y_m)
        name = s.name if s.label == "*" else s.label
        lines.append(f" {name} {where}"[:LEGEND_WIDTH])
    return lines


def ceil_2digits(v: float) -> float:
    """``v`` (> 0) rounded up to two significant digits (428.1 → 430)."""
    step = 10.0 ** (math.floor(math.log10(v)) - 1)
    return math.ceil(v / step - 1e-9) * step


def _inset(width: int, height: int, mpp: PositionEstimate, lse: PositionEstimate | None,
           level: float, poe: PoeView | None) -> list[str]:
    """A zoom on the MPP: its ellipse, the LSE and its ellipse, or the POE circle."""
    reach = 1.0
    m = _a95(mpp, level)
    if m:
        reach = max(reach, m[0])
    e = _a95(lse, level)
    if lse is not None and e:
        reach = max(reach, e[0] + math.hypot(lse.x_m - mpp.x_m, lse.y_m - mpp.y_m))
    if lse is None and poe is not None:
        reach = max(reach, poe.radius_m)
    # equal scale: the half-height down (2·height·half/width) must hold the reach too
    half = ceil_2digits(reach * 1.15 * max(1.0, width / (2.0 * height)))
    cv = BrailleCanvas.map_view(width, height, (mpp.x_m, mpp.y_m), half)
    if m:
        cv.ellipse(mpp.x_m, mpp.y_m, m[0], m[1], m[2])
    if lse is not None and e:
        cv.ellipse(lse.x_m, lse.y_m, e[0], e[1], e[2], dash=DOTTED)
        cv.marker(lse.x_m, lse.y_m, "L")
    if lse is None and poe is not None:
        cv.circle(mpp.x_m, mpp.y_m, poe.radius_m, dash=DASHED)
    cv.marker(mpp.x_m, mpp.y_m, "M")
    return [f"zoom ±{format_distance(half)}", *cv.lines()]


def plot_page_lines(r: CycleResult | None, history: Sequence[CycleResult],
                    context: RunContext | None, width: int, height: int) -> list[str]:
    """The text of Pg 642, at most ``height`` lines of at most ``width`` characters: a title
    line, the map (left) and the legend column (right; dropped when narrower than 48).
    ``history`` holds the session's cycles (those after ``r`` are ignored)."""
    if width < 20 or height < 6:
        return ["Position plot"[:max(width, 0)]][:max(height, 0)]
    if r is None or context is None:
        return ["Position plot", "", "no cycle yet"]
    cfg = context.config
    demo = cfg.demo
    level = cfg.lsq.conf_region_pct / 100.0
    half_width = demo.plot_scale_m
    mpp = r.mpp
    lse = lse_estimate(r)
    hist = history_upto(history, r) if history else [r]
    poe = current_poe(hist, demo.poe_expansion_m_h) if lse is None else None
    title = (f"Position plot  {format_time_z(r.time)}  ±{format_distance(half_width)}  N up  "
             f"CM {format_lon_dm(r.cm_deg)}")
    legend_w = LEGEND_WIDTH if width >= LEGEND_WIDTH + 24 else 0
    avail_w = width - legend_w - (1 if legend_w else 0)
    avail_h = height - 1
    size = min(max(demo.plot_size, 0.05), 1.0)
    cw = max(8, min(avail_w, round(avail_w * size)))
    ch = max(4, min(avail_h, round(avail_h * size)))
    cv = BrailleCanvas.map_view(cw, ch, (mpp.x_m, mpp.y_m), half_width)
    # own track
    tx, ty = track_xy(hist, context, r.cm_deg)
    cv.polyline(zip(tx.tolist(), ty.tolist(), strict=True))
    # the LSE, its LOPs and ellipse; or the POE circle during a dive
    e = _a95(lse, level)
    if lse is not None:
        if r.fix is not None:
            half = LOP_HALF_LENGTH * half_width
            for lop in r.fix.lops:
                if lop.used and math.isfinite(lop.az_deg):
                    dx = half * math.sin(math.radians(lop.az_deg))
                    dy = half * math.cos(math.radians(lop.az_deg))
                    cv.line(lse.x_m - dx, lse.y_m - dy, lse.x_m + dx, lse.y_m + dy, dash=DOTTED)
        if e:
            cv.ellipse(lse.x_m, lse.y_m, e[0], e[1], e[2], dash=DOTTED)
    elif poe is not None:
        cv.circle(mpp.x_m, mpp.y_m, poe.radius_m, dash=DASHED)
    m = _a95(mpp, level)
    if m:
        cv.ellipse(mpp.x_m, mpp.y_m, m[0], m[1], m[2])
    # stations
    far: list[Station] = []
    for s in stations(r, hist, context):
        if cv.marker(s.x_m, s.y_m, s.label):
            cv.label(s.x_m, s.y_m, s.name)
        else:
            far.append(s)
    if lse is not None:
        cv.marker(lse.x_m, lse.y_m, "L")
    cv.marker(mpp.x_m, mpp.y_m, "M")
    bar = nice_length(half_width / 2.0)
    cv.scale_bar(bar, format_distance(bar))
    canvas = cv.lines()
    out = [title[:width]]
    if not legend_w:
        return out + [ln[:width] for ln in canvas]
    legend = _legend(r, lse, level, poe, mpp)
    more = _station_lines(far, mpp)
    room = avail_h - len(legend)
    inset_h = min(LEGEND_WIDTH // 2, max(5, (room - 2) // 2))
    if room - 2 < inset_h:
        inset_h = 0
    keep = room - (inset_h + 2 if inset_h else 0)
    if len(more) > keep:
        more = more[:max(0, keep - 1)] + [f" +{len(more) - max(0, keep - 1)} more"][:keep]
    legend += more
    if inset_h:
        legend += [""] * (avail_h - len(legend) - inset_h - 1)
        legend += _inset(LEGEND_WIDTH, inset_h, mpp, lse, level, poe)
    for i in range(avail_h):
        left = canvas[i] if i < len(canvas) else ""
        right = legend[i] if i < len(legend) else ""
        out.append((left.ljust(avail_w) + " " + right).rstrip())
    return out


class PositionPlotPage(ThrottledTextPage):
    """Pg 642 body."""

    def page_lines(self, r: CycleResult | None, session: Session | None, width: int,
                   height: int) -> list[str]:
        """:func:`plot_page_lines` of the session's history."""
        if session is None:
            return plot_page_lines(r, [], None, width, height)
        return plot_page_lines(r, snapshot(session.history), session.context, width, height)


register_page(PAGE_NUMBER, "Position plot", PositionPlotPage)

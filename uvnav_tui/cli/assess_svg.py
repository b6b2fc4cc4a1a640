"""The SVG plot of ``uvnav assess --svg``: horizontal error against time (presentation only).

The numbers come from :func:`engine.api.assess`; this module only draws them as a hand-written
SVG text (no plotting library): the LSE, filter and MPP errors (m, log scale), the filter's 95 %
semi-major axis and the POE radius against minutes since the first matched epoch, the phases
shaded (surfaced blue, submerged grey, after resurfacing green).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import numpy.typing as npt

from engine.api import ESTIMATORS, PHASES, Assessment

FloatArray = npt.NDArray[np.float64]
Scale = Callable[[float], float]

_PHASE_FILL = ("#dbeafe", "#e5e7eb", "#dcfce7")
_SERIES_STYLE: Mapping[str, tuple[str, str, str]] = {
    # key: (label, colour, extra attributes)
    "lse": ("LSE error", "#9ca3af", 'stroke-width="0.8"'),
    "kf": ("filter error", "#1d4ed8", 'stroke-width="1.4"'),
    "mpp": ("MPP error", "#dc2626", 'stroke-width="1" stroke-dasharray="4 3"'),
    "kf_a95": ("filter 95 % a-axis", "#059669", 'stroke-width="1.2" stroke-dasharray="6 3"'),
    "poe": ("POE radius", "#b45309", 'stroke-width="1.4" stroke-dasharray="10 3 2 3"'),
}
_LEFT, _RIGHT, _TOP, _BOTTOM = 70, 190, 40, 50
"""Margins (px) around the plot area; the legend sits in the right one."""


def _esc(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def _utc(t_ms: int) -> datetime:
    return datetime.fromtimestamp(t_ms / 1000.0, tz=UTC)


def _curves(a: Assessment) -> dict[str, FloatArray]:
    """The plotted series (m) by :data:`_SERIES_STYLE` key."""
    s = a.series
    curves: dict[str, FloatArray] = {
        k: np.hypot(s.error[k][:, 0], s.error[k][:, 1]) for k in ESTIMATORS
    }
    curves["kf_a95"] = s.kf_a95_m
    curves["poe"] = s.poe_m
    return curves


def _decades(curves: Mapping[str, FloatArray]) -> tuple[float, float]:
    """Whole decades (m) around every positive finite value: the log axis' ends."""
    vals = np.concatenate([v[np.isfinite(v) & (v > 0)] for v in curves.values()] or [np.ones(1)])
    if vals.size == 0:
        vals = np.ones(1)
    lo = 10.0 ** math.floor(math.log10(max(float(vals.min()), 0.1)))
    hi = 10.0 ** math.ceil(math.log10(max(float(vals.max()), lo * 10.0)))
    return lo, hi


def _phase_shading(phase: npt.NDArray[np.int64], tmin: FloatArray, px: Scale,
                   ph: int) -> list[str]:
    """One rectangle per run of epochs in the same phase."""
    out = []
    if phase.size:
        start = 0
        for i in range(1, phase.size + 1):
            if i == phase.size or phase[i] != phase[start]:
                x0, x1 = px(float(tmin[start])), px(float(tmin[i - 1]))
                out.append(f'<rect x="{x0:.1f}" y="{_TOP}" width="{max(x1 - x0, 0.5):.1f}" '
                           f'height="{ph}" fill="{_PHASE_FILL[int(phase[start])]}"/>')
                start = i
    return out


def _axes(lo: float, hi: float, t_end: float, px: Scale, py: Scale, pw: int,
          ph: int) -> list[str]:
    """Decade grid lines with labels, minute ticks with labels, and the plot frame."""
    out = []
    dec = int(round(math.log10(hi) - math.log10(lo)))
    for k in range(dec + 1):
        v = lo * 10.0**k
        y = py(v)
        out.append(f'<line x1="{_LEFT}" y1="{y:.1f}" x2="{_LEFT + pw}" y2="{y:.1f}" '
                   'stroke="#9ca3af" stroke-width="0.5"/>')
        out.append(f'<text x="{_LEFT - 6}" y="{y + 4:.1f}" text-anchor="end">{v:g}</text>')
    step = next(st for st in (1, 2, 5, 10, 15, 20, 30, 60, 120, 240, 600, 1440, 1e9)
                if t_end / st <= 12)
    t = 0.0
    while t <= t_end + 1e-9:
        x = px(t)
        out.append(f'<line x1="{x:.1f}" y1="{_TOP + ph}" x2="{x:.1f}" y2="{_TOP + ph + 5}" '
                   'stroke="black"/>')
        out.append(f'<text x="{x:.1f}" y="{_TOP + ph + 18}" text-anchor="middle">{t:g}</text>')
        t += step
    out.append(f'<rect x="{_LEFT}" y="{_TOP}" width="{pw}" height="{ph}" fill="none" '
               'stroke="black"/>')
    return out


def _polylines(curves: Mapping[str, FloatArray], t_ms: npt.NDArray[np.int64], tmin: FloatArray,
               px: Scale, py: Scale) -> list[str]:
    """Each curve as polylines, broken where a value is missing or at a gap in time (more than
    1.5 times the median epoch spacing)."""
    out = []
    dt = np.diff(t_ms)
    gap_ms = 1.5 * float(np.median(dt)) if dt.size else 0.0
    for key, (_label, colour, extra) in _SERIES_STYLE.items():
        v = curves[key]
        ok = np.isfinite(v)
        segs: list[list[str]] = []
        cur: list[str] = []
        for i in range(v.size):
            brk = not ok[i] or (i > 0 and t_ms[i] - t_ms[i - 1] > gap_ms)
            if brk and cur:
                segs.append(cur)
                cur = []
            if ok[i]:
                cur.append(f"{px(float(tmin[i])):.1f},{py(float(v[i])):.1f}")
        if cur:
            segs.append(cur)
        for seg in segs:
            if len(seg) == 1:
                seg = seg * 2
            out.append(f'<polyline fill="none" stroke="{colour}" {extra} '
                       f'points="{" ".join(seg)}"/>')
    return out


def _legend(lx: int) -> list[str]:
    """Line styles of the curves, then the phase colours, left-aligned at ``lx``."""
    out = []
    for i, (label, colour, extra) in enumerate(_SERIES_STYLE.values()):
        y = _TOP + 10 + 20 * i
        out.append(f'<line x1="{lx}" y1="{y}" x2="{lx + 30}" y2="{y}" stroke="{colour}" '
                   f'{extra}/>')
        out.append(f'<text x="{lx + 36}" y="{y + 4}">{_esc(label)}</text>')
    for i, name in enumerate(PHASES[:3]):
        y = _TOP + 125 + 20 * i
        out.append(f'<rect x="{lx}" y="{y - 7}" width="30" height="14" '
                   f'fill="{_PHASE_FILL[i]}" stroke="#9ca3af" stroke-width="0.5"/>')
        out.append(f'<text x="{lx + 36}" y="{y + 4}">{_esc(name)}</text>')
    return out


def render_svg(a: Assessment, *, width: int = 1000, height: int = 520,
               title: str | None = None) -> str:
    """A hand-written SVG of horizontal error (m, log scale) against time (minutes since the
    first matched epoch) for the LSE, the filter and the MPP, with the filter's 95 % semi-major
    axis and the POE radius; phases shaded (surfaced blue, submerged grey, after resurfacing
    green).  Lines break where an estimate is missing or epochs are further apart than 1.5 times
    the median spacing."""
    s = a.series
    pw, ph = width - _LEFT - _RIGHT, height - _TOP - _BOTTOM
    tmin = (s.t_ms - s.t_ms[0]) / 60_000.0
    t_end = float(tmin[-1]) if tmin[-1] > 0 else 1.0
    curves = _curves(a)
    lo, hi = _decades(curves)
    llo, lhi = math.log10(lo), math.log10(hi)

    def px(t: float) -> float:
        return _LEFT + pw * t / t_end

    def py(v: float) -> float:
        v = min(max(v, lo), hi)
        return _TOP + ph * (1.0 - (math.log10(v) - llo) / (lhi - llo))

    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
        f'viewBox="0 0 {width} {height}" font-family="sans-serif" font-size="12">',
        "<!-- UVNAV assess plot -->",  # how --force recognises an earlier plot (outputs.py)
        f'<rect x="0" y="0" width="{width}" height="{height}" fill="white"/>',
        *_phase_shading(s.phase, tmin, px, ph),
        *_axes(lo, hi, t_end, px, py, pw, ph),
        *_polylines(curves, s.t_ms, tmin, px, py),
        *_legend(_LEFT + pw + 15),
    ]
    head = title or f"Horizontal error vs truth: {Path(a.log_path).name}"
    out.append(f'<text x="{_LEFT}" y="{_TOP - 14}" font-size="14">{_esc(head)}</text>')
    out.append(f'<text x="{_LEFT + pw / 2:.1f}" y="{height - 12}" text-anchor="middle">'
               f'time since {_utc(int(s.t_ms[0])):%Y-%m-%d %H:%M:%S}Z [min]</text>')
    out.append(f'<text x="16" y="{_TOP + ph / 2:.1f}" text-anchor="middle" '
               f'transform="rotate(-90 16 {_TOP + ph / 2:.1f})">horizontal error [m] '
               '(log scale)</text>')
    out.append("</svg>")
    return "\n".join(out) + "\n"

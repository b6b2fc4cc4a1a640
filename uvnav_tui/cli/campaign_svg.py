"""The SVG plots of ``uvnav campaign`` (presentation only, hand-written SVG, no plotting library).

* ``coverage.svg``: per variant, a histogram of the runs' MPP 95 % ellipse coverage over all
  epochs (bins of 2.5 points from 0 to 100 %; the 95 % line marked);
* ``error_since_fix.svg``: per variant, the MPP's RMS error (m, log scale) against the time
  since the last LSE (the table's bins), median over runs with the 5–95 % band.

The numbers come from the table (:data:`engine.api.SUMMARY_COLUMNS`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from engine.api import SINCE_FIX_BINS_MIN, since_fix_column, variant_arrays

_COLOURS = ("#1d4ed8", "#dc2626", "#059669", "#b45309", "#7c3aed", "#0891b2", "#4b5563")
_W, _PANEL_H, _LEFT, _RIGHT, _TOP, _GAP = 640, 150, 60, 20, 30, 40


def _esc(text: str) -> str:
    return (text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
            .replace('"', "&quot;"))


def _svg(width: int, height: int, body: list[str]) -> str:
    return (f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
            f'viewBox="0 0 {width} {height}" font-family="sans-serif" font-size="11">\n'
            f'<rect width="{width}" height="{height}" fill="white"/>\n' + "\n".join(body)
            + "\n</svg>\n")


def coverage_svg(cols: Mapping[str, Sequence[Any]], title: str) -> str:
    """Histogram of ``all_mpp_cover95`` (%) per variant, one panel each."""
    masks = variant_arrays(cols)
    edges = np.linspace(0.0, 100.0, 41)
    pw = _W - _LEFT - _RIGHT
    height = _TOP + len(masks) * (_PANEL_H + _GAP) + 10
    body = [f'<text x="{_LEFT}" y="18" font-size="13">{_esc(title)}: MPP 95 % coverage over all '
            "epochs, runs per bin</text>"]
    cover = np.asarray(cols["all_mpp_cover95"], dtype=float) * 100.0
    for k, (variant, sel) in enumerate(masks.items()):
        top = _TOP + k * (_PANEL_H + _GAP)
        vals = cover[sel]
        vals = vals[np.isfinite(vals)]
        counts, _ = np.histogram(np.clip(vals, 0.0, 100.0), bins=edges)
        peak = max(int(counts.max()) if counts.size else 0, 1)
        colour = _COLOURS[k % len(_COLOURS)]
        bottom = top + _PANEL_H
        body.append(f'<rect x="{_LEFT}" y="{top}" width="{pw}" height="{_PANEL_H}" '
                    'fill="none" stroke="#9ca3af"/>')
        bw = pw / (edges.size - 1)
        for i, c in enumerate(counts):
            if c:
                h = _PANEL_H * c / peak
                body.append(f'<rect x="{_LEFT + i * bw:.1f}" y="{bottom - h:.1f}" '
                            f'width="{bw - 1:.1f}" height="{h:.1f}" fill="{colour}"/>')
        x95 = _LEFT + pw * 0.95
        body.append(f'<line x1="{x95:.1f}" y1="{top}" x2="{x95:.1f}" y2="{bottom}" '
                    'stroke="black" stroke-dasharray="4 3"/>')
        for pct in range(0, 101, 10):
            x = _LEFT + pw * pct / 100.0
            body.append(f'<text x="{x:.1f}" y="{bottom + 13}" text-anchor="middle">{pct}</text>')
        body.append(f'<text x="{_LEFT - 6}" y="{top + 10}" text-anchor="end">{peak}</text>')
        body.append(f'<text x="{_LEFT - 6}" y="{bottom}" text-anchor="end">0</text>')
        body.append(f'<text x="{_LEFT + 4}" y="{top + 14}" fill="{colour}">'
                    f"{_esc(variant)} ({vals.size} runs)</text>")
    return _svg(_W, height, body)


def error_since_fix_svg(cols: Mapping[str, Sequence[Any]], title: str) -> str:
    """MPP RMS error (m, log scale) per time-since-fix bin: median over runs and the 5–95 %
    band, one line per variant."""
    masks = variant_arrays(cols)
    names = [since_fix_column(lo, hi) for lo, hi in SINCE_FIX_BINS_MIN]
    labels = [f"{lo:g}–{hi:g}" if math.isfinite(hi) else f"≥ {lo:g}"
              for lo, hi in SINCE_FIX_BINS_MIN]
    stats: dict[str, list[tuple[float, float, float]]] = {}
    for variant, sel in masks.items():
        row = []
        for n in names:
            v = np.asarray(cols[n], dtype=float)[sel]
            v = v[np.isfinite(v) & (v > 0)]
            row.append(tuple(float(x) for x in np.percentile(v, [5, 50, 95]))
                       if v.size else (math.nan,) * 3)
        stats[variant] = row  # type: ignore[assignment]
    finite = [x for r in stats.values() for t in r for x in t if math.isfinite(x)]
    lo_dec = math.floor(math.log10(min(finite))) if finite else 0
    hi_dec = math.ceil(math.log10(max(finite))) if finite else 1
    hi_dec = max(hi_dec, lo_dec + 1)
    ph = 260
    pw = _W - _LEFT - _RIGHT - 120
    height = _TOP + ph + 50

    def y(v: float) -> float:
        return _TOP + ph * (hi_dec - math.log10(v)) / (hi_dec - lo_dec)

    def x(i: int) -> float:
        return _LEFT + pw * (i + 0.5) / len(names)

    body = [f'<text x="{_LEFT}" y="18" font-size="13">{_esc(title)}: MPP RMS error (m) '
            "by time since the last LSE (median, 5–95 % of runs)</text>",
            f'<rect x="{_LEFT}" y="{_TOP}" width="{pw}" height="{ph}" fill="none" '
            'stroke="#9ca3af"/>']
    for d in range(lo_dec, hi_dec + 1):
        yy = y(10.0 ** d)
        body.append(f'<line x1="{_LEFT}" y1="{yy:.1f}" x2="{_LEFT + pw}" y2="{yy:.1f}" '
                    'stroke="#e5e7eb"/>')
        body.append(f'<text x="{_LEFT - 6}" y="{yy + 4:.1f}" text-anchor="end">'
                    f"{10.0 ** d:g}</text>")
    for i, lab in enumerate(labels):
        body.append(f'<text x="{x(i):.1f}" y="{_TOP + ph + 15}" text-anchor="middle">'
                    f"{_esc(lab)}</text>")
    body.append(f'<text x="{_LEFT + pw / 2:.1f}" y="{_TOP + ph + 32}" text-anchor="middle">'
                "minutes since the last LSE</text>")
    for k, (variant, row) in enumerate(stats.items()):
        colour = _COLOURS[k % len(_COLOURS)]
        pts = [(x(i), t) for i, t in enumerate(row) if math.isfinite(t[1])]
        for xx, (p5, _p50, p95) in pts:
            body.append(f'<line x1="{xx + 3 * k:.1f}" y1="{y(p5):.1f}" x2="{xx + 3 * k:.1f}" '
                        f'y2="{y(p95):.1f}" stroke="{colour}" stroke-width="2" opacity="0.5"/>')
        if pts:
            path = " ".join(f"{xx + 3 * k:.1f},{y(t[1]):.1f}" for xx, t in pts)
            body.append(f'<polyline points="{path}" fill="none" stroke="{colour}" '
                        'stroke-width="1.6"/>')
        ly = _TOP + 14 + 16 * k
        body.append(f'<text x="{_LEFT + pw + 10}" y="{ly}" fill="{colour}">'
                    f"{_esc(variant)}</text>")
    return _svg(_W, height, body)

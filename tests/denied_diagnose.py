"""What the filter believes when a GPS-denied window of a real log starts, and how that holds up
(docs/REALDATA.md, "Where the ellipse fails").

    .venv/bin/python -m tests.denied_diagnose LOG [--set TABLE.KEY=VALUE ...] [--every S] \
        [--warmup S] [--window S] [--turn DEG]

For every window of ``tests.denied_tables`` (same log, cases and ``--set`` values), prints one
line: the filter's 1σ at the last fix for the current (East/North, m/s), log bias (m/s), gyro
bias (°) and position (m), the correlation between the current and the gyro bias, the largest
heading change inside the first 5 and 10 minutes (°), and at 5 and 10 minutes the error of the
MPP split along/across the heading at the last fix (m), the ellipse's a95 (m) and NEES
(eᵀC⁻¹e; > 5.99 = outside the 95 % ellipse). A summary splits the windows into those with a
turn (heading change > ``--turn``, default 30°) and those without.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from typing import Any

import numpy as np
from pyproj import Geod

from engine.assess.denied import K95_SQ, clean_records, hide_positions, run_records
from engine.assess.denied import window_starts as nominal_starts
from engine.filter.state import IDPSI, IDV, IVCX, IVCY, IX, IY
from engine.run.cycle import build_context, initial_state, step
from tests.denied_tables import _merge, cases, has_heading, load, parse_set

_GEOD = Geod(ellps="WGS84")


def _wrap180(d: float) -> float:
    return (d + 180.0) % 360.0 - 180.0


def diagnose(name: str, case: str, overrides: dict[str, Any], window_s: float, every_s: float,
             warmup_s: float, turn_deg: float) -> list[str]:
    """The lines of one log and case (module docstring)."""
    cfg, (datums, chains) = load(name, overrides)
    ctx = build_context(cfg, datums, chains)
    recs, _ = clean_records(run_records(cfg))
    times = [r.time for r in recs]
    starts = nominal_starts(times, window_s, every_s=every_s, warmup_s=warmup_s)
    want: dict[int, None] = {}
    for t in starts:
        i = next((k for k in range(len(recs)) if times[k] >= t
                  and recs[k].gps_lat_deg is not None), None)
        if i is not None:
            want[i] = None
    out = [f"== {name} / {case}",
           "start     σvc E/N m/s  σΔv m/s  σΔψ °  σpos m  ρ(vc,Δψ)  turn5 turn10 "
           "| 5 min: along across a95 NEES | 10 min: along across a95 NEES"]
    nav = initial_state(cfg)
    snap = {}
    for i, rec in enumerate(recs):
        nav, _res = step(ctx, nav, rec)
        if i in want:
            snap[i] = nav
        if want and i >= max(want):
            break
    summary: dict[bool, list[tuple[bool, bool]]] = {True: [], False: []}
    for i0, nav0 in snap.items():
        f = nav0.filter
        if f is None:
            continue
        P = np.asarray(f.P)
        sd = np.sqrt(np.clip(np.diag(P), 0.0, None))
        rho = [P[IVCX, IDPSI] / (sd[IVCX] * sd[IDPSI]) if sd[IVCX] * sd[IDPSI] > 0 else 0.0,
               P[IVCY, IDPSI] / (sd[IVCY] * sd[IDPSI]) if sd[IVCY] * sd[IDPSI] > 0 else 0.0]
        h0 = recs[i0].heading_deg
        if h0 is None:
            h0 = recs[i0].cog_deg
        t0 = times[i0]
        cells: dict[float, tuple[float, float, float, float]] = {}
        turns: dict[float, float] = {300.0: 0.0, 600.0: 0.0}
        j = i0
        n = nav0
        while j + 1 < len(recs) and (times[j + 1] - t0).total_seconds() <= window_s:
            j += 1
            el = (times[j] - t0).total_seconds()
            h = recs[j].heading_deg if recs[j].heading_deg is not None else recs[j].cog_deg
            if h is not None and h0 is not None:
                for cp in turns:
                    if el <= cp:
                        turns[cp] = max(turns[cp], abs(_wrap180(h - h0)))
            n, res = step(ctx, n, hide_positions(recs[j]))
            for cp in (300.0, 600.0):
                if cp in cells or el < cp or recs[j].gps_lat_deg is None:
                    continue
                az, _baz, dist = _GEOD.inv(res.mpp.lon_deg, res.mpp.lat_deg,
                                           recs[j].gps_lon_deg, recs[j].gps_lat_deg)
                rel = math.radians(az - (h0 or 0.0))
                ell = res.mpp.ellipse
                a95 = ell.scaled(0.95)[0] if ell is not None else math.nan
                fs = res.filter_state
                nees = math.nan
                if fs is not None:
                    e = np.array([dist * math.sin(math.radians(az)),
                                  dist * math.cos(math.radians(az))])
                    C = np.asarray(fs.P)[np.ix_([IX, IY], [IX, IY])]
                    nees = float(e @ np.linalg.solve(C, e))
                cells[cp] = (dist * math.cos(rel), dist * math.sin(rel), a95, nees)
        if 600.0 not in cells:
            continue
        c5, c10 = cells.get(300.0, (math.nan,) * 4), cells[600.0]
        out.append(
            f"{t0:%H:%M:%S}  {sd[IVCX]:.3f}/{sd[IVCY]:.3f}   {sd[IDV]:.3f}   "
            f"{math.degrees(sd[IDPSI]):5.2f}  {math.hypot(sd[IX], sd[IY]):6.1f}  "
            f"{rho[0]:+.2f}/{rho[1]:+.2f}  {turns[300.0]:5.0f} {turns[600.0]:6.0f} | "
            f"{c5[0]:7.0f} {c5[1]:6.0f} {c5[2]:4.0f} {c5[3]:5.1f} | "
            f"{c10[0]:7.0f} {c10[1]:6.0f} {c10[2]:4.0f} {c10[3]:5.1f}")
        summary[turns[600.0] > turn_deg].append((c5[3] <= K95_SQ, c10[3] <= K95_SQ))
    for turned, label in ((False, "no turn"), (True, f"turn > {turn_deg:g}°")):
        rows = summary[turned]
        if rows:
            out.append(f"{label}: {len(rows)} windows, inside at 5 min "
                       f"{100 * np.mean([r[0] for r in rows]):.0f} %, at 10 min "
                       f"{100 * np.mean([r[1] for r in rows]):.0f} %")
    return out


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m tests.denied_diagnose",
                                description=__doc__.splitlines()[0])
    p.add_argument("log")
    p.add_argument("--set", action="append", default=[], metavar="TABLE.KEY=VALUE")
    p.add_argument("--window", type=float, default=600.0)
    p.add_argument("--every", type=float, default=60.0)
    p.add_argument("--warmup", type=float, default=120.0)
    p.add_argument("--turn", type=float, default=30.0)
    a = p.parse_args(argv)
    extra: dict[str, Any] = {}
    for s in a.set:
        extra = _merge(extra, parse_set(s))
    for case, ov in cases(has_heading(a.log)):
        for line in diagnose(a.log, case, _merge(ov, extra), a.window, a.every, a.warmup,
                             a.turn):
            print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())

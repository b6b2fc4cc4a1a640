"""The GPS-denied coverage tables of the bundled real logs (docs/REALDATA.md, "Coverage of the
95 % ellipse on every real log").

    .venv/bin/python -m tests.denied_tables [--markdown] [--log NAME ...] \
        [--set TABLE.KEY=VALUE ...] [--every S] [--warmup S] [--window S] [--jobs N]

runs ``engine.assess.denied.denied_experiment`` on every ``data/nmea/NAME.nmea[.gz]`` that has a
``NAME.toml`` beside it (or the ``--log`` names), each in the cases the target of the
documentation names:

* ``receiver`` — the configuration as bundled (GNSS weighted by the receiver's HDOP × UERE; a
  log without HDOP keeps the receiver type's fixed weight);
* ``P fixed`` — the tight, still conservative sensitivity case: ``gps.weights = "fixed"``,
  ``gps.receiver = "P"`` (σ 8.9 m per axis before ``lsq.gps_se_sf``);
* and, for a log without a heading, both of them with the COG/SOG stand-in
  (``sensors.cog_sog = "standin"``, as ``uvnav denied --cog-sog``) instead: without it there is
  no dead reckoning and no filter ellipse at all.

Per log, case and checkpoint (1, 5, 10 minutes after the last fix) it prints the number of
windows, the share whose hidden fix lay inside the MPP's 95 % ellipse, the median and 90th
percentile of the MPP's error [m], the median semi-major axis a95 of the ellipse [m] and their
ratio (median a95 / median error), and whether the row meets the target (≥ 85 % inside and a
ratio ≤ 4). ``--set`` merges TOML values into every configuration before it is checked (e.g.
``--set filter.fix_tau_s=600``), so a changed filter is measured with the same command.

This is a measuring tool, not a test: it asserts nothing and takes minutes (``--jobs`` runs
logs × cases in parallel processes). It lives beside ``tests/denied_halves.py`` because it
reads the bundled data through ``tests.paths`` and drives the engine directly.
"""

from __future__ import annotations

import argparse
import gzip
import json
import math
import sys
import time
import tomllib
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from typing import Any

import numpy as np

from engine.assess.denied import clean_records, denied_experiment, run_records
from engine.run.config import config_from_data
from engine.run.setup import read_data_dir
from tests.paths import DATA

NMEA_DIR = DATA / "nmea"
CHECKPOINTS_S = (60.0, 300.0, 600.0)
"""1, 5 and 10 minutes after the last fix [s]: the checkpoints of the target."""
TARGET_INSIDE = 0.85
TARGET_RATIO = 4.0

P_FIXED = {"gps": {"weights": "fixed", "receiver": "P"}}
STANDIN = {"sensors": {"cog_sog": "standin"}}


@dataclass(frozen=True)
class Row:
    """One log, case and checkpoint: windows, share inside the 95 % ellipse, median and p90
    error [m], median semi-major axis [m] and median a95 / median error."""

    log: str
    case: str
    checkpoint_s: float
    n: int
    inside: float
    err_med_m: float
    err_p90_m: float
    a95_med_m: float

    @property
    def ratio(self) -> float:
        return self.a95_med_m / self.err_med_m if self.err_med_m > 0 else math.inf

    @property
    def meets(self) -> bool:
        return self.n > 0 and self.inside >= TARGET_INSIDE and self.ratio <= TARGET_RATIO


def _merge(base: dict[str, Any], extra: dict[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for k, v in extra.items():
        out[k] = _merge(out.get(k, {}), v) if isinstance(v, dict) else v
    return out


def parse_set(text: str) -> dict[str, Any]:
    """``TABLE.KEY=VALUE`` (VALUE a TOML value; a bare word is taken as a string) as a nested
    dict."""
    if "=" not in text or "." not in text.split("=", 1)[0]:
        raise SystemExit(f"--set {text!r}: TABLE.KEY=VALUE expected")
    path, value = text.split("=", 1)
    try:
        parsed = tomllib.loads(f"v = {value}")["v"]
    except tomllib.TOMLDecodeError:
        parsed = value
    out: dict[str, Any] = {}
    node = out
    keys = path.strip().split(".")
    for k in keys[:-1]:
        node = node.setdefault(k, {})
    node[keys[-1]] = parsed
    return out


def logs(names: Sequence[str] | None = None) -> list[str]:
    """The bundled real logs (a ``.nmea`` or ``.nmea.gz`` with a ``.toml`` beside it)."""
    found = sorted(p.name.removesuffix(".toml") for p in NMEA_DIR.glob("*.toml"))
    if not names:
        return found
    for n in names:
        if n not in found:
            raise SystemExit(f"--log {n}: no data/nmea/{n}.toml (known: {', '.join(found)})")
    return list(names)


def has_heading(name: str) -> bool:
    """Whether the log's records carry a heading (true or made true), read with its
    configuration as bundled."""
    cfg, _data = load(name, {})
    recs, _skipped = clean_records(run_records(cfg))
    return any(r.heading_deg is not None for r in recs)


def load(name: str, overrides: dict[str, Any]) -> tuple[Any, Any]:
    """The configuration of ``data/nmea/NAME.toml`` with ``overrides`` merged in (checked as a
    file is) and its data files."""
    path = NMEA_DIR / f"{name}.toml"
    with open(path, "rb") as f:
        raw = tomllib.load(f)
    base = config_from_data(_merge(raw, overrides), path.parent)
    datums, chains = read_data_dir(base.data_dir)
    cfg = config_from_data(_merge(raw, overrides), path.parent, datums.datums, chains)
    return cfg, (datums, chains)


def cases(heading: bool) -> list[tuple[str, dict[str, Any]]]:
    """The cases run for a log with or without a heading (module docstring)."""
    if heading:
        return [("receiver", {}), ("P fixed", P_FIXED)]
    return [("COG/SOG, receiver", STANDIN), ("COG/SOG, P fixed", _merge(STANDIN, P_FIXED))]


def run_case(name: str, case: str, overrides: dict[str, Any], window_s: float, every_s: float,
             warmup_s: float) -> tuple[list[Row], float, list[dict[str, Any]]]:
    """The rows of one log and case, the seconds it took and the per-window points (for
    diagnosis: start, checkpoint, error, a95, inside, NEES)."""
    t0 = time.time()
    cfg, data = load(name, overrides)
    rep = denied_experiment(cfg, data, run_records(cfg), [window_s], every_s=every_s,
                            warmup_s=warmup_s, checkpoints_s=CHECKPOINTS_S)
    rows = []
    points = []
    for cp in CHECKPOINTS_S:
        pts = [p for w in rep.windows for p in w.points if p.checkpoint_s == cp]
        for w in rep.windows:
            for p in w.points:
                if p.checkpoint_s == cp:
                    points.append({"start": w.start.isoformat(), "cp": cp,
                                   "err": p.filter_error_m, "a95": p.filter_a95_m,
                                   "inside": p.filter_inside95, "nees": p.filter_nees,
                                   "src": p.mpp_source})
        fin = [p for p in pts if math.isfinite(p.filter_error_m)
               and math.isfinite(p.filter_a95_m)]
        if not fin:
            rows.append(Row(name, case, cp, 0, math.nan, math.nan, math.nan, math.nan))
            continue
        err = np.array([p.filter_error_m for p in fin])
        a95 = np.array([p.filter_a95_m for p in fin])
        rows.append(Row(name, case, cp, len(fin),
                        float(np.mean([p.filter_inside95 for p in fin])),
                        float(np.median(err)), float(np.percentile(err, 90)),
                        float(np.median(a95))))
    return rows, time.time() - t0, points


def _fmt(v: float, pct: bool = False) -> str:
    if not math.isfinite(v):
        return "–"
    return f"{100 * v:.0f} %" if pct else (f"{v:.1f}" if v < 10 else f"{v:.0f}")


HEADER = ("log", "case", "after", "n", "in 95 %", "error med m", "error p90 m", "a95 med m",
          "a95/error", "target")


def table_lines(rows: Sequence[Row], markdown: bool) -> list[str]:
    """The table, Markdown or aligned text."""
    cells = [(r.log, r.case, f"{r.checkpoint_s / 60:g} min", str(r.n), _fmt(r.inside, True),
              _fmt(r.err_med_m), _fmt(r.err_p90_m), _fmt(r.a95_med_m),
              "–" if not math.isfinite(r.ratio) else f"{r.ratio:.1f}",
              "yes" if r.meets else "**no**" if markdown else "NO") for r in rows]
    if markdown:
        out = ["| " + " | ".join(HEADER) + " |", "|" + "|".join("---" for _ in HEADER) + "|"]
        out.extend("| " + " | ".join(c) + " |" for c in cells)
        return out
    widths = [max(len(h), *(len(c[i]) for c in cells)) for i, h in enumerate(HEADER)]
    out = ["  ".join(h.ljust(w) for h, w in zip(HEADER, widths, strict=True))]
    out.extend("  ".join(c.ljust(w) for c, w in zip(cell, widths, strict=True))
               for cell in cells)
    return out


def _job(args: tuple[str, str, dict[str, Any], float, float, float]
         ) -> tuple[list[Row], float, list[dict[str, Any]]]:
    return run_case(*args)


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m tests.denied_tables",
                                description=__doc__.splitlines()[0])
    p.add_argument("--log", action="append", help="a log name in data/nmea (repeatable)")
    p.add_argument("--set", action="append", default=[], metavar="TABLE.KEY=VALUE",
                   help="merge a TOML value into every configuration (repeatable)")
    p.add_argument("--window", type=float, default=600.0, help="window length [s] (600)")
    p.add_argument("--every", type=float, default=60.0, help="window spacing [s] (60)")
    p.add_argument("--warmup", type=float, default=120.0,
                   help="first window start after the first record [s] (120)")
    p.add_argument("--jobs", type=int, default=1, help="parallel processes (1)")
    p.add_argument("--markdown", action="store_true", help="print a Markdown table")
    p.add_argument("--points", metavar="JSON", help="also write every window's points here")
    a = p.parse_args(argv)
    extra: dict[str, Any] = {}
    for s in a.set:
        extra = _merge(extra, parse_set(s))
    jobs = []
    for name in logs(a.log):
        for case, ov in cases(has_heading(name)):
            jobs.append((name, case, _merge(ov, extra), a.window, a.every, a.warmup))
    if a.jobs > 1:
        with ProcessPoolExecutor(a.jobs) as ex:
            results = list(ex.map(_job, jobs))
    else:
        results = [_job(j) for j in jobs]
    rows = [r for res in results for r in res[0]]
    for line in table_lines(rows, a.markdown):
        print(line)
    secs = ", ".join(f"{j[0]} / {j[1]} {res[1]:.0f} s" for j, res in zip(jobs, results,
                                                                         strict=True))
    print(f"\n(window {a.window:g} s every {a.every:g} s from {a.warmup:g} s; "
          f"{'--set ' + ' '.join(a.set) + '; ' if a.set else ''}{secs})")
    if a.points:
        dump = {f"{j[0]} / {j[1]}": res[2] for j, res in zip(jobs, results, strict=True)}
        opener = gzip.open if a.points.endswith(".gz") else open
        with opener(a.points, "wt") as f:
            json.dump(dump, f)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""``uvnav denied``: the GPS-denied experiment on a recorded run (docs/REALDATA.md).

Hides the position fixes of the run for windows of the given lengths, dead-reckons through
each with the navigation filter and prints how the error grows after 1, 5, 10 and 30 minutes,
against the hidden fixes (or a simulator truth) and against a straight "last fix + COG/SOG"
extrapolation and a heading + water-speed dead reckoning. Statistics are over all windows
(median, 90th percentile, maximum); ``coverage`` is the fraction of windows whose reference lay
inside the console's 95 % ellipse.

Exit status: 0 report printed; 2 bad input (arguments, configuration, data files, an
unreadable run file), nothing run; 3 no window fits in the run; 130 interrupted (Ctrl-C).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from datetime import UTC, datetime, time, timedelta
from pathlib import Path

from engine.api import (
    CHECKPOINTS_S,
    DeniedReport,
    InputError,
    NmeaLog,
    clean_records,
    denied_experiment,
    derive_nmea_config,
    load_data,
    load_run_config,
    not_nmea_message,
    read_error,
    read_truth,
    run_records,
    sniff_log,
    truth_reference,
)
from uvnav_tui.cli.replay import bundled_data_dir

PROG = "uvnav denied"
EXIT_OK = 0
EXIT_BAD_INPUT = 2
EXIT_NO_WINDOW = 3
NO_CONFIG_MESSAGE = ("No configuration beside the run file: give --config FILE (without one "
                     "every system would be off and the run would have no fix) !")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``uvnav denied``."""
    p = argparse.ArgumentParser(prog=PROG, description=__doc__.splitlines()[0])
    p.add_argument("run", help="run file to replay: a .RUN or an NMEA 0183 log")
    p.add_argument("--config", help="run configuration TOML (default: NAME.toml next to RUN; "
                   "for an NMEA log without either, one is derived from the log)")
    p.add_argument("--window", type=float, action="append", metavar="S",
                   help="length of the GPS-denied window in seconds (repeatable; default 600 "
                        "and 1800)")
    p.add_argument("--start", action="append", metavar="T",
                   help="window start: HH:MM:SS (UTC, on the run's first day) or an ISO 8601 "
                        "time (repeatable; default every --every seconds after --warmup)")
    p.add_argument("--every", type=float, default=300.0, metavar="S",
                   help="spacing of the default window starts [s] (default 300)")
    p.add_argument("--warmup", type=float, default=300.0, metavar="S",
                   help="time from the first record to the first default start [s] (default "
                        "300: the filter learns the current first)")
    p.add_argument("--checkpoint", type=float, action="append", metavar="S",
                   help="time after the last fix to measure the error at [s] (repeatable; "
                        "default 60 300 600 1800)")
    p.add_argument("--truth", metavar="CSV",
                   help="measure against this simulator truth instead of the hidden fixes")
    p.add_argument("--cog-sog", action="store_true",
                   help="course/speed over ground stand in for a missing gyro heading / log "
                   'speed (sets sensors.cog_sog = "standin", as uvnav replay --cog-sog)')
    p.add_argument("--windows", action="store_true", help="also print every window's errors")
    p.add_argument("--markdown", action="store_true",
                   help="print the table as Markdown (for docs/REALDATA.md)")
    return p


def _m(v: float) -> str:
    return "–" if not math.isfinite(v) else f"{v:.0f}"


def _triple(v: tuple[float, float, float]) -> str:
    return "–" if not math.isfinite(v[0]) else "/".join(_m(x) for x in v)


def _pct(v: float) -> str:
    return "–" if not math.isfinite(v) else f"{100.0 * v:.0f} %"


HEADER = ("window", "after", "n", "filter MPP m med/p90/max", "COG/SOG m med/p90/max",
          "HDG/STW m med/p90/max", "in 95 %", "a95 med m")


def report_lines(rep: DeniedReport, run: str, markdown: bool = False) -> list[str]:
    """The printed report: a header and one row per (window length, checkpoint)."""
    span = ""
    if rep.first_time is not None and rep.last_time is not None:
        span = (f"{rep.first_time:%Y-%m-%d %H:%M:%S}Z – {rep.last_time:%H:%M:%S}Z "
                f"({(rep.last_time - rep.first_time).total_seconds() / 60.0:.1f} min)")
    lines = [
        f"run {run}: {rep.records} records {span}, skipped {rep.skipped_records}",
        f"reference: {rep.reference}; heading and water speed in the run: "
        f"{'yes' if rep.has_heading_speed else 'no (HDG/STW column empty)'}; windows run "
        f"{len(rep.windows)}",
    ]
    rows = [(f"{r.window_s / 60:.0f} min", f"{r.checkpoint_s / 60:g} min", str(r.n),
             _triple(r.filter_m), _triple(r.cogsog_m), _triple(r.hdgstw_m), _pct(r.coverage),
             _m(r.a95_median_m)) for r in rep.rows]
    if markdown:
        lines.append("")
        lines.append("| " + " | ".join(HEADER) + " |")
        lines.append("|" + "|".join("---" for _ in HEADER) + "|")
        lines.extend("| " + " | ".join(row) + " |" for row in rows)
        return lines
    widths = [max(len(h), *(len(row[i]) for row in rows)) if rows else len(h)
              for i, h in enumerate(HEADER)]
    lines.append("  ".join(h.rjust(w) for h, w in zip(HEADER, widths, strict=True)))
    lines.extend("  ".join(c.rjust(w) for c, w in zip(row, widths, strict=True)) for row in rows)
    return lines


def window_lines(rep: DeniedReport) -> list[str]:
    """One line per window and checkpoint (``--windows``)."""
    out = []
    for w in rep.windows:
        out.append(f"window {w.start:%H:%M:%S}Z  last fix {w.last_fix_lat_deg:.6f} "
                   f"{w.last_fix_lon_deg:.6f}  COG {w.cog_deg:.1f}° SOG {w.sog_kn:.2f} kn "
                   f"({w.cogsog_source})  run {w.length_s:.0f} s")
        for p in w.points:
            out.append(f"  +{p.elapsed_s:5.0f} s  filter {_m(p.filter_error_m)} m "
                       f"({'in' if p.filter_inside95 else 'OUT'} 95 %, a95 "
                       f"{_m(p.filter_a95_m)} m, {p.mpp_source})  COG/SOG "
                       f"{_m(p.cogsog_error_m)} m  HDG/STW {_m(p.hdgstw_error_m)} m")
    return out


def parse_start(text: str, day: datetime | None) -> datetime:
    """``HH:MM:SS`` on ``day`` (the run's first record, UTC) or an ISO 8601 time (UTC when it
    has no zone); InputError naming ``--start`` otherwise."""
    try:
        if len(text) <= 8 and ":" in text:
            if day is None:
                raise ValueError
            t = time.fromisoformat(text)
            out = datetime.combine(day.date(), t, tzinfo=UTC)
            return out + timedelta(days=1) if out < day - timedelta(hours=12) else out
        d = datetime.fromisoformat(text)
        return d if d.tzinfo is not None else d.replace(tzinfo=UTC)
    except ValueError:
        raise InputError("Wrong start time: HH:MM:SS or ISO 8601 expected !", field="--start",
                         text=text) from None


def _positive(values: list[float] | None, default: tuple[float, ...], name: str) -> list[float]:
    out = list(default) if not values else values
    for v in out:
        if not (math.isfinite(v) and 0 < v <= 86400 * 30):
            raise InputError("Must be a number of seconds > 0 and at most 30 days (2592000) !",
                             field=name, text=str(v))
    return out


def run_denied(argv: list[str]) -> int:
    """Entry point of ``uvnav denied``; returns the exit status."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse has printed its message
        return int(exc.code or 0)
    run = Path(args.run)
    try:
        windows = _positive(args.window, (600.0, 1800.0), "--window")
        checkpoints = _positive(args.checkpoint, CHECKPOINTS_S, "--checkpoint")
        _positive([args.every], (), "--every")
        if not (math.isfinite(args.warmup) and args.warmup >= 0):
            raise InputError("Must be a number of seconds >= 0 !", field="--warmup",
                             text=str(args.warmup))
        try:
            with open(run, "rb"):
                pass
        except OSError as exc:
            raise read_error(exc, str(run)) from None
        config_path = Path(args.config) if args.config else run.with_suffix(".toml")
        if args.config or config_path.exists():
            cfg, data = load_run_config(config_path)
            cfg = cfg.replace(run_file=str(run.resolve()))
        elif (sniff := sniff_log(run)).nmea:
            cfg, _scan = derive_nmea_config(run, bundled_data_dir())
            data = load_data(cfg)
        elif not sniff.text:  # neither a log nor a .RUN: say what it is
            raise InputError(not_nmea_message(sniff), file=str(run))
        else:
            raise InputError(NO_CONFIG_MESSAGE, file=str(config_path), field="configuration")
        if args.cog_sog:
            cfg = cfg.replace(sensors=dataclasses.replace(cfg.sensors, cog_sog="standin"))
        reader = run_records(cfg)
        records, skipped = clean_records(reader)  # bad records counted, never kept
        first = records[0].time if records else None
        starts = None if not args.start else [parse_start(s, first) for s in args.start]
        truth = None
        if args.truth:
            truth = truth_reference(read_truth(args.truth), data[0])
        rep = denied_experiment(cfg, data, records, windows, starts=starts, every_s=args.every,
                                warmup_s=args.warmup, checkpoints_s=checkpoints, truth=truth,
                                skipped=skipped)
    except InputError as exc:
        print(f"{PROG}: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    if isinstance(reader, NmeaLog):  # sentences used/skipped (docs/NMEA.md)
        for line in reader.stats.summary_lines():
            print(f"nmea: {line}")
    for line in report_lines(rep, str(run), markdown=args.markdown):
        print(line)
    if args.windows:
        for line in window_lines(rep):
            print(line)
    if not rep.windows:
        print(f"{PROG}: no window fits in the run (shorter --window or --warmup?)",
              file=sys.stderr)
        return EXIT_NO_WINDOW
    return EXIT_OK


if __name__ == "__main__":
    raise SystemExit(run_denied(sys.argv[1:]))

"""``uvnav replay``: run a whole ``.RUN`` file headless, writing the ``.OUT`` log and JSON lines.

Shows a rich progress bar on a terminal (silent when not a TTY) and prints a closing summary.
Never a traceback for bad input: file, line and field are named and the exit status is 2.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from engine.errors import InputError
from engine.formatting import format_lat_dms, format_lon_dms
from engine.records import position_json
from engine.runconfig import RunConfig, default_config, load_config
from engine.session import RunSummary, Session


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``uvnav replay``."""
    p = argparse.ArgumentParser(prog="uvnav replay", description=__doc__.splitlines()[0])
    p.add_argument("run", help=".RUN file to replay (its config: --config, or NAME.toml beside it)")
    p.add_argument("--config", help="run configuration TOML (default: NAME.toml next to RUN)")
    p.add_argument("--out", help=".OUT log to write (default: NAME.OUT next to RUN; an existing "
                   "log is never overwritten: a free NAME_N.OUT is chosen)")
    p.add_argument("--no-out", action="store_true", help="write no .OUT log")
    p.add_argument("--jsonl", help="also write one JSON object per cycle to this file")
    p.add_argument("--smooth", nargs="?", const="", metavar="FILE",
                   help="run the RTS smoother over the whole run afterwards and write the smoothed "
                   "positions as JSON lines to FILE (default NAME.smooth.jsonl next to RUN)")
    p.add_argument("--force", action="store_true", help="overwrite existing output files")
    return p


def _config_for(run: Path, config: str | None) -> RunConfig:
    if config is not None:
        cfg = load_config(config)
    else:
        beside = run.with_suffix(".toml")
        cfg = load_config(beside) if beside.exists() else default_config()
    # The RUN given on the command line wins over the configuration's run_file.
    return cfg.replace(run_file=str(run.resolve()))


def _summary_lines(s: RunSummary, smoothed: int | None) -> list[str]:
    lines = [
        f"epochs {s.epochs}  fixes {s.fixes}  rejected LOPs {s.rejected_lops}  "
        f"skipped records {s.skipped_records}",
    ]
    r = s.last
    if r is not None:
        m = r.mpp
        ell = ""
        if m.ellipse is not None:
            a, b = m.ellipse.scaled(0.95)
            ell = f"  95% a/b {a:.2f} m {b:.2f} m  Az {m.ellipse.az_deg:.1f}°"
        lines.append(
            f"final MPP ({m.source}, filter {r.filter_status}) {r.time:%H:%M:%S}Z  "
            f"{format_lat_dms(m.lat_deg)} {format_lon_dms(m.lon_deg)} {r.datum}{ell}"
        )
    if s.out_path is not None:
        lines.append(f"log {s.out_path}")
    if s.jsonl_path is not None:
        lines.append(f"json lines {s.jsonl_path}")
    if smoothed is not None:
        lines.append(f"smoothed epochs {smoothed}")
    return lines


def run_replay(argv: list[str]) -> int:
    """Entry point of ``uvnav replay``; returns the exit status (0 ok, 2 bad input)."""
    args = build_parser().parse_args(argv)
    err = Console(stderr=True)
    run = Path(args.run)
    try:
        if not run.exists():
            raise InputError("File not found !", file=str(run), field="run file")
        cfg = _config_for(run, args.config)
        out = None if args.no_out else (args.out or str(run.with_suffix(".OUT")))
        session = Session(cfg, out_path=out, force=args.force, jsonl_path=args.jsonl,
                          collect_smoother=args.smooth is not None, history=1)
    except InputError as exc:
        print(f"uvnav replay: {exc}", file=sys.stderr)
        return 2
    except FileExistsError as exc:
        print(f"uvnav replay: {exc.filename} exists (use --force to overwrite)", file=sys.stderr)
        return 2
    smoothed: int | None = None
    with session:
        if sys.stderr.isatty():
            with Progress(TextColumn("replay"), BarColumn(), MofNCompleteColumn(),
                          TimeElapsedColumn(), console=err, transient=True) as bar:
                task = bar.add_task("replay", total=None)
                summary = session.run(progress=lambda _r: bar.advance(task))
        else:
            summary = session.run()
        if args.smooth is not None:
            path = Path(args.smooth) if args.smooth else run.with_suffix(".smooth.jsonl")
            smoothed_positions = session.smooth()
            with open(path, "w" if args.force else "x", encoding="utf-8") as fh:
                for p in smoothed_positions:
                    fh.write(json.dumps(position_json(p), separators=(",", ":")) + "\n")
            smoothed = len(smoothed_positions)
    for line in _summary_lines(summary, smoothed):
        print(line)
    for bad in session.bad_records:
        print(f"skipped: {bad.error}", file=sys.stderr)
    return 0

"""``uvnav replay``: run a whole ``.RUN`` file headless, writing the ``.OUT`` log and JSON lines.

The run file may also be an NMEA 0183 log (recognised by its content, docs/NMEA.md); without
``--config`` and without ``NAME.toml`` beside it, its configuration is derived from the log and
printed.

Shows a rich progress bar on a terminal (silent when not a TTY) and prints a closing summary.
Never a traceback for bad input: file, line and field are named.

Output files (the ``.OUT`` log, ``--jsonl``, ``--smooth``) all follow the ``.OUT`` rule
(engine/io/outputs.py, docs/CLI.md "Output files"): never the same file (device and inode) as an
input or another output; an existing file is never overwritten, the first free ``NAME_N.suffix`` is
used instead; ``--force`` replaces only an earlier UVNAV output of the same kind; devices,
pipes and directories are refused. Every output is checked, then created, before the replay
starts; if one cannot be, the ones already created are removed again and nothing runs.

``--nmea-out udp://HOST:PORT`` or ``--nmea-out FILE`` also sends the integrated position (MPP)
of every cycle as NMEA 0183 (GGA, RMC, GST, HDT; ``--nmea-gll`` adds GLL) on WGS84, e.g. to a
chart plotter (docs/NMEA_OUT.md); the file follows the same ``.OUT`` rule.

Exit status: 0 the run processed at least one epoch (bad records are reported and skipped);
1 an output file cannot be written (the message names it); 2 bad input (arguments,
configuration, data files, an unreadable run file, refused output names), nothing run; 3 the
run file gave no epoch at all (every record bad, or none), the logs of the attempt are kept;
4 internal error: the engine failed on a record that passed every input check (a bug, not bad
input: the traceback and the record are printed, the logs keep every cycle completed before
it); 130 interrupted (Ctrl-C): the logs keep every cycle completed before it.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import gzip
import json
import math
import os
import sys
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from engine.api import (
    AdaptState,
    CycleResult,
    DatumFile,
    DeccaChain,
    DrAdaptState,
    InputError,
    MotionState,
    NmeaConfig,
    NmeaOutOptions,
    NmeaPositionOut,
    NmeaStats,
    OutputFile,
    OutputGuard,
    RunConfig,
    RunSummary,
    Session,
    derive_nmea_config,
    derived_config_lines,
    format_lat_dms,
    format_lon_dms,
    load_data,
    load_run_config,
    not_nmea_message,
    open_nmea_sender,
    parse_nmea_destination,
    position_json,
    read_error,
    remove_created,
    run_inputs,
    sniff_log,
)
from uvnav_tui.cli.stdout import unfiltered_stderr

if TYPE_CHECKING:
    from engine.api import NmeaSender

EXIT_OK = 0
EXIT_CANNOT_WRITE = 1
EXIT_BAD_INPUT = 2
EXIT_NO_EPOCH = 3
EXIT_INTERNAL = 4


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``uvnav replay``."""
    p = argparse.ArgumentParser(prog="uvnav replay", description=__doc__.splitlines()[0])
    p.add_argument("run", help=".RUN file or NMEA 0183 log to replay (its config: --config, or "
                   "NAME.toml beside it; for an NMEA log without either, one is derived)")
    p.add_argument("--config", help="run configuration TOML (default: NAME.toml next to RUN)")
    out = p.add_mutually_exclusive_group()
    out.add_argument("--out", help=".OUT log to write (default: NAME.OUT next to RUN; an existing "
                   "log is never overwritten: a free NAME_N.OUT is chosen)")
    out.add_argument("--no-out", action="store_true", help="write no .OUT log")
    p.add_argument("--jsonl", help="also write one JSON object per cycle to this file (an "
                   "existing file is kept: a free NAME_N.jsonl is chosen)")
    p.add_argument("--smooth", nargs="?", const="", metavar="FILE",
                   help="run the RTS smoother over the whole run afterwards and write the smoothed "
                   "positions as JSON lines to FILE (default NAME.smooth.jsonl next to RUN; an "
                   "existing file is kept: a free name is chosen)")
    p.add_argument("--force", action="store_true",
                   help="replace existing outputs of an earlier run (never an input, never a "
                   "file UVNAV did not write)")
    p.add_argument("--nmea-out", metavar="DEST",
                   help="send the MPP of every cycle as NMEA 0183 (GGA, RMC, GST, HDT on WGS84) "
                   "to udp://HOST:PORT (e.g. a chart plotter on udp://127.0.0.1:10110) or to a "
                   "file (an existing file is kept: a free NAME_N is chosen)")
    p.add_argument("--nmea-gll", action="store_true", help="with --nmea-out: add GLL")
    p.add_argument("--date", metavar="YYYY-MM-DD",
                   help="UTC date of an NMEA log whose first sentences (or all) carry no date "
                   "(no RMC, no ZDA with a date); overrides nmea.date (docs/NMEA.md)")
    p.add_argument("--lop-reject", choices=("Y", "N", "y", "n"), metavar="Y|N",
                   help="what to do with an LOP that fails the w-test when lsq.lop_reject is "
                   '"A" (ask: there is no operator here): Y reject it, N keep it flagged '
                   "(default N, said in the summary); overrides lsq.lop_reject")
    p.add_argument("--cog-sog", action="store_true",
                   help="let course/speed over ground stand in for a missing gyro heading / "
                   'log speed (sets sensors.cog_sog = "standin"; docs/GNSS_WEIGHTS.md)')
    return p


NO_CONFIG_MESSAGE = ("No configuration beside the run file: give --config FILE (without one "
                     "every system would be off and the run would have no fix) !")


def headless_lop_policy(cfg: RunConfig, option: str | None) -> tuple[RunConfig, str]:
    """The configuration with an LOPReject policy a run without an operator can follow, and
    the summary's words for it (issue 11, docs/CONFIG.md ``lop_reject``): ``--lop-reject``
    wins; ``"A"`` (ask) without it becomes ``"N"`` (keep the LOP, flagged)."""
    asked = cfg.lsq.lop_reject
    policy = option.upper() if option else ("N" if asked == "A" else asked)
    words = {"Y": "rejected", "N": "kept"}[policy]
    source = "--lop-reject" if option else (
        'lsq.lop_reject "A" with no operator' if asked == "A" else "lsq.lop_reject")
    if policy != asked:
        cfg = cfg.replace(lsq=dataclasses.replace(cfg.lsq, lop_reject=policy))
    return cfg, f"{words} ({source} = {policy})"


def integrity_summary_line(s: RunSummary, policy: str) -> str:
    """The summary line of what the tests flagged and what was done (issue 11)."""
    return (f"w-test: {s.flagged_lops + s.rejected_lops} LOPs flagged, {policy}  "
            f"gross-error fixes kept out {s.gated_fixes}  innovation-test fails "
            f"{s.innovation_rejects}  Decca lane slips corrected {s.lane_slips}"
            + (f"  divergence remedies {s.recoveries}" if s.recoveries else ""))


def _config_path(run: Path, config: str | None) -> Path | None:
    if config is not None:
        return Path(config)
    beside = run.with_suffix(".toml")
    return beside if beside.exists() else None


def bundled_data_dir() -> Path:
    """The bundled ``data/`` directory (TO_WGS84.DAT, DECCA.CHN) for a derived configuration:
    the one next to the installed package (the checkout), else ``./data``."""
    for path in (Path(__file__).resolve().parents[2] / "data", Path.cwd() / "data"):
        if (path / "TO_WGS84.DAT").is_file():
            return path
    raise InputError("File not found !", file="data/TO_WGS84.DAT", field="data_dir")


def _with_date(nmea: NmeaConfig, date: str | None) -> NmeaConfig:
    """``[nmea]`` with ``--date`` applied (checked as the key is; the message names --date)."""
    if date is None:
        return nmea
    try:
        return dataclasses.replace(nmea, date=date)
    except InputError as exc:
        raise InputError(exc.message, field="--date", text=date) from None


def _config_for(
    run: Path, config_path: Path | None, date: str | None = None
) -> tuple[RunConfig, tuple[DatumFile, dict[str, DeccaChain]], NmeaStats | None]:
    """The configuration (every name checked against the data files), the data files and,
    for a configuration derived from an NMEA log (none given, none beside it), what the log
    gave. ``date`` (``--date``) overrides ``nmea.date``."""
    if config_path is None:
        sniff = sniff_log(run)
        if not sniff.nmea and not sniff.text:  # neither a log nor a .RUN: say what it is
            raise InputError(not_nmea_message(sniff), file=str(run))
        if not sniff.nmea:
            raise InputError(NO_CONFIG_MESSAGE, file=str(run.with_suffix(".toml")),
                             field="configuration")
        cfg, stats = derive_nmea_config(run, bundled_data_dir(), _with_date(NmeaConfig(), date))
        return cfg, load_data(cfg), stats
    cfg, data = load_run_config(config_path)
    # The RUN given on the command line wins over the configuration's run_file.
    return cfg.replace(run_file=str(run.resolve()), nmea=_with_date(cfg.nmea, date)), data, None


def _check_run_file(run: Path) -> None:
    """The run file must be a readable regular file (InputError naming why, not "cannot
    write" after the outputs exist)."""
    if "\0" in str(run):
        raise InputError("A path cannot contain a NUL character !", file=str(run))
    if run.exists() and not run.is_dir() and not run.is_file():  # a FIFO would block open()
        raise InputError("Not a regular file (a device or pipe) !", file=str(run))
    try:
        with open(run, "rb"):
            pass
    except OSError as exc:
        raise read_error(exc, str(run)) from None


def _guard_outputs(run: Path, config_path: Path | None, cfg: RunConfig, force: bool,
                   outputs: list[tuple[str, Path, str]]) -> OutputGuard:
    """Check every output (label, path, kind) against the inputs (run file, configuration,
    data files) and each other before any is created (engine/io/outputs.py)."""
    guard = OutputGuard()
    guard.protect_all([("the run file", run), ("the configuration", config_path),
                       *run_inputs(cfg)])
    for label, path, kind in outputs:
        guard.check(path, label, kind=kind, force=force)
    return guard


def count_lines(path: Path) -> int:
    """Number of lines of a file by a byte scan (a last line without newline counts), as the
    log reader counts them: LF, CR LF and CR alone each end a line; a gzip file's content."""
    n = 0
    last = b"\n"
    prev_cr = False
    with open(path, "rb") as raw:
        packed = raw.read(2) == b"\x1f\x8b"
    with (gzip.open(path, "rb") if packed else open(path, "rb")) as fh:
        try:
            while chunk := fh.read(1 << 20):
                n += chunk.count(b"\n") + chunk.count(b"\r") - chunk.count(b"\r\n")
                n -= prev_cr and chunk[:1] == b"\n"  # a CR LF split between two chunks
                prev_cr = chunk[-1:] == b"\r"
                last = chunk[-1:]
        except (EOFError, OSError, zlib.error):  # a cut .gz: the reader reports it
            pass
    return n + (last not in (b"\n", b"\r"))


def _failed_fixes_line(s: RunSummary) -> str:
    """The summary's count of fixes that failed their tests (engine.run.cycle.fix_fit)."""
    return (f"fixes failing their tests {s.failed_fixes} of {s.fixes} (unit-variance or every "
            "w-test rejected; used with VCV × S²)")


def adapt_line(a: AdaptState) -> str:
    """The learnt fix-VCV factor (``[filter] adapt``, THEORY §8.17) in one line."""
    return (f"learnt fix VCV factor {a.fix_factor:.3g} (σ × {math.sqrt(a.fix_factor):.3g}; "
            f"from S² {math.exp(a.log_s2):.3g}, NIS {math.exp(a.log_nis):.3g}) over {a.n} "
            f"fix epochs, {a.clipped} clipped")


def dr_adapt_line(d: DrAdaptState) -> str:
    """The learnt dead-reckoning noise factor (``[filter] adapt_dr``, THEORY §8.19)."""
    return (f"learnt dead-reckoning noise factor {d.mu:.3g} (current, log and gyro bias random "
            f"walks; σ × {math.sqrt(d.mu):.3g}) from {d.n} {h_checks(d.n)}, mean NEES "
            f"{d.nees_mean:.3g} (2 when right), {d.clipped} clipped")


def h_checks(n: int) -> str:
    """"check" or "checks"."""
    return "check" if n == 1 else "checks"


def motion_line(m: MotionState) -> str:
    """The COG/SOG stand-in's learnt process noise (engine.filter.motion) in one line."""
    return (f"learnt stand-in motion noise: rate of turn {m.turn_rate_max_deg_s:.3g}°/s "
            f"(σ ½), σ_a² {m.sigma_a2:.3g} m²/s⁴ over {m.seconds / 60.0:.0f} min "
            f"({m.n} lags, {m.clipped} clipped, {m.skipped} COG samples skipped)")


def _summary_lines(s: RunSummary, smoothed: tuple[int, Path] | None) -> list[str]:
    lines = [
        f"epochs {s.epochs}  fixes {s.fixes}  rejected LOPs {s.rejected_lops}  "
        f"skipped records {s.skipped_records}",
    ]
    if s.failed_fixes:
        lines.append(_failed_fixes_line(s))
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
        if r.adapt is not None:
            lines.append(adapt_line(r.adapt))
        if r.dr_adapt is not None:
            lines.append(dr_adapt_line(r.dr_adapt))
        if r.motion is not None:
            lines.append(motion_line(r.motion))
    if s.out_path is not None:
        lines.append(f"log {s.out_path}")
    if s.jsonl_path is not None:
        lines.append(f"json lines {s.jsonl_path}")
    if smoothed is not None:
        lines.append(f"smoothed epochs {smoothed[0]}")
        lines.append(f"smoothed positions {smoothed[1]}")
    return lines


def _run(session: Session, run: Path,
         on_cycle: Callable[[CycleResult], None] | None = None) -> RunSummary:
    """Replay to the end, with a progress bar over the file's lines on a terminal; ``on_cycle``
    sees every cycle (the NMEA output)."""
    if not sys.stderr.isatty():
        return session.run(progress=on_cycle)
    from rich.console import Console  # only on a terminal (start-up time)
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    total = count_lines(run)
    with Progress(TextColumn("replay"), BarColumn(), MofNCompleteColumn(), TextColumn("lines"),
                  TimeElapsedColumn(), console=Console(file=unfiltered_stderr()),
                  transient=True) as bar:
        task = bar.add_task("replay", total=total)
        def progress(r: CycleResult) -> None:
            if on_cycle is not None:
                on_cycle(r)
            bar.update(task, completed=r.record)

        summary = session.run(progress=progress)
        bar.update(task, completed=total)
    return summary


def _cannot_write(exc: OSError, run: Path) -> int:
    """Report an OSError while running: reading the run file is bad input (2), anything else
    is an output that cannot be written (1); the message names the file."""
    name = exc.filename if exc.filename is not None else run
    if exc.filename is not None and os.path.abspath(exc.filename) == os.path.abspath(run):
        print(f"uvnav replay: {name}: cannot read: {exc.strerror or exc} !", file=sys.stderr)
        return EXIT_BAD_INPUT
    print(f"uvnav replay: {name}: cannot write: {exc.strerror or exc} !", file=sys.stderr)
    return EXIT_CANNOT_WRITE


def _more_skipped(summary: RunSummary, shown: int, nmea: bool = False) -> None:
    """One line for the bad records beyond the first ones kept in memory (session.py)."""
    more = summary.skipped_records - shown
    if more > 0:
        where = (f"every one is a BAD line of {summary.out_path}" if summary.out_path is not None
                 else "not shown: no .OUT log (--no-out)")
        if nmea:  # beyond the first of each kind, a log's damaged lines are counted only
            where = ("all counted per kind in the nmea: lines; the first of each kind are BAD "
                     f"lines of {summary.out_path}" if summary.out_path is not None else
                     "all counted per kind in the nmea: lines")
        print(f"skipped: … and {more} more ({where})", file=sys.stderr)


def nmea_summary_line(sender: NmeaSender) -> str:
    """The summary line of ``--nmea-out``: sentences sent and where, failed UDP sends."""
    line = f"nmea out {sender.sent} sentences to {sender.description}"
    errors = getattr(sender, "errors", 0)
    if errors:
        line += f" ({errors} sends failed, first: {getattr(sender, 'first_error', '')})"
    return line


def _drop_nmea(sender: NmeaSender | None, force: bool) -> None:
    """Close the NMEA output of a run that could not start; remove a new NMEA file again."""
    if sender is None:
        return
    with contextlib.suppress(OSError):
        sender.close()
    path = getattr(sender, "path", None)
    if path is not None and not force:
        path.unlink(missing_ok=True)


def run_replay(argv: list[str]) -> int:
    """Entry point of ``uvnav replay``; returns the exit status (module docstring)."""
    args = build_parser().parse_args(argv)
    run = Path(args.run)
    smooth_fh: OutputFile | None = None
    nmea_sender: NmeaSender | None = None
    try:
        _check_run_file(run)
        config_path = _config_path(run, args.config)
        cfg, data, derived = _config_for(run, config_path, args.date)
        if derived is not None:
            print(f"config: none given and no {run.with_suffix('.toml').name} beside the log: "
                  "derived from the NMEA log (docs/NMEA.md):")
            for line in derived_config_lines(cfg):
                print(f"config: {line}")
        cfg, lop_policy = headless_lop_policy(cfg, args.lop_reject)
        if args.cog_sog:
            cfg = cfg.replace(sensors=dataclasses.replace(cfg.sensors, cog_sog="standin"))
        out = None if args.no_out else Path(args.out or run.with_suffix(".OUT"))
        jsonl = Path(args.jsonl) if args.jsonl else None
        smooth = None
        if args.smooth is not None:
            smooth = Path(args.smooth) if args.smooth else run.with_suffix(".smooth.jsonl")
        nmea_dest = None if args.nmea_out is None else parse_nmea_destination(args.nmea_out)
        nmea_file = None if nmea_dest is None else nmea_dest.path
        guard = _guard_outputs(run, config_path, cfg, args.force, [
            (label, p, kind) for label, p, kind in
            (("--out", out, "out"), ("--jsonl", jsonl, "jsonl"), ("--smooth", smooth, "positions"),
             ("--nmea-out", nmea_file, "nmea"))
            if p is not None])
        if smooth is not None:
            smooth_fh = guard.open(smooth, label="--smooth", kind="positions", force=args.force)
        if nmea_dest is not None:
            nmea_sender = open_nmea_sender(nmea_dest, guard, force=args.force)
        session = Session(cfg, out_path=out, force=args.force, jsonl_path=jsonl,
                          collect_smoother=smooth is not None, history=1, data=data, guard=guard,
                          nmea_scan=derived)
    except (InputError, OSError) as exc:
        remove_created([smooth_fh], args.force)
        _drop_nmea(nmea_sender, args.force)
        if isinstance(exc, InputError):
            print(f"uvnav replay: {exc}", file=sys.stderr)
            return EXIT_BAD_INPUT
        return _cannot_write(exc, run)
    for warning in session.data_warnings:  # a modified data file (docs/DATAFILES.md)
        print(f"uvnav replay: warning: {warning}", file=sys.stderr)
    smoothed: tuple[int, Path] | None = None
    on_cycle = None
    if nmea_sender is not None:
        nmea = NmeaPositionOut(session.datums, NmeaOutOptions(gll=args.nmea_gll))
        sender = nmea_sender

        def on_cycle(r: CycleResult) -> None:
            sender.send(nmea.sentences(r))
    try:
        with session:
            summary = _run(session, run, on_cycle)
            if smooth_fh is not None:
                n_smoothed = 0  # streamed: memory flat in the run length (issue 15 item 9)
                for p in session.iter_smoothed():
                    smooth_fh.write(json.dumps(position_json(p), separators=(",", ":")) + "\n")
                    n_smoothed += 1
                smooth_fh.close(sync=True)
                smoothed = (n_smoothed, smooth_fh.path)
    except OSError as exc:  # e.g. the disk filled up: every completed cycle is on disk
        return _cannot_write(exc, run)
    except Exception as exc:  # an engine bug (engine/run/session.py: never a bad record)
        import traceback  # only here (start-up time: nothing else in a replay imports it)

        traceback.print_exc()
        print(f"uvnav replay: internal error ({type(exc).__name__}: {exc}): this is a bug, "
              "please report it with the record above", file=sys.stderr)
        return EXIT_INTERNAL
    finally:
        if smooth_fh is not None:
            with contextlib.suppress(OSError):  # already reported, or closed above
                smooth_fh.close()
        if nmea_sender is not None:
            with contextlib.suppress(OSError):
                nmea_sender.close()
    for line in _summary_lines(summary, smoothed):
        print(line)
    print(integrity_summary_line(summary, lop_policy))
    if session.config.sensors.standin:
        print("dead reckoning: COG/SOG stand in where the gyro heading / log speed is missing "
              '(sensors.cog_sog = "standin"; .OUT SENS ref=ground)')
    if nmea_sender is not None:
        print(nmea_summary_line(nmea_sender))
    if session.nmea_stats is not None:  # an NMEA log: sentences used/skipped (docs/NMEA.md)
        for line in session.nmea_stats.summary_lines():
            print(f"nmea: {line}")
    for bad in session.bad_records:
        print(f"skipped: {bad.error}", file=sys.stderr)
    _more_skipped(summary, len(session.bad_records), session.nmea_stats is not None)
    if summary.epochs == 0:
        print(f"uvnav replay: {run}: no record could be processed "
              f"({summary.skipped_records} skipped) !", file=sys.stderr)
        return EXIT_NO_EPOCH
    return EXIT_OK

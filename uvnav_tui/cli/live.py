"""``uvnav live URL``: run headless on a live NMEA 0183 source (docs/LIVE.md).

The source is ``udp://ADDRESS:PORT`` (receive datagrams), ``tcp://HOST:PORT`` (client,
reconnecting), ``gpsd://HOST:PORT`` (a gpsd, asked to stream NMEA) or
``serial:///dev/DEVICE?baud=N``. The run goes at the pace the data arrive.
It prints one line per cycle (time, MPP, 95 % ellipse, latency from the line that closed the
epoch to the position) and a line for each change of the source's state (``source lost …``,
``reconnected …``), and ends on Ctrl-C (exit 130), ``--cycles N`` or ``--seconds S`` (exit
0) with every completed cycle in the ``.OUT`` log and every received line in the raw log
``NAME.raw.nmea`` (+ ``NAME.raw.times.csv``) beside it. ``--seconds`` counts from the start,
the wait for a first fix without ``--config`` included. Under overload it says how many lines
were dropped (``source overloaded: …``, at most every 10 s; ``, N DROPPED`` on the cycle
lines), and when the stream's clock went back and its sentences are skipped, that
(``CLOCK BEHIND …``, every 30 s while it lasts); the summary ends with what overload cost
(docs/LIVE.md "Under overload").

With ``--config`` the run uses that configuration (working datum, DR position, systems,
``[nmea]``). Without it the configuration is derived from the stream as ``uvnav replay`` derives
one from a log (docs/NMEA.md): WGS84, DR position = the first fix, GPS on, Decca off, each
sensor on when its sentences came in the first ``--learn`` seconds (10) after that fix; it is
printed before the first cycle. Outputs follow the ``.OUT`` rule (docs/CLI.md "Output files"); the
default ``.OUT`` is ``live-YYYYMMDDTHHMMSSZ.OUT`` in the current directory.

Exit status: 0 ended by ``--cycles``/``--seconds``; 1 an output cannot be written; 2 bad input
(arguments, URL, configuration, a UDP port in use), nothing run; 3 without ``--config``, no fix
came before ``--seconds`` ended the run (nothing run; the raw log keeps the lines received); 4
internal error; 130 Ctrl-C.
"""

from __future__ import annotations

import argparse
import sys
import time
import traceback
from datetime import UTC, datetime
from pathlib import Path

from engine.api import (
    LEARN_S,
    CycleResult,
    InputError,
    LiveRun,
    LiveStep,
    NoFixInTime,
    OutputGuard,
    RunConfig,
    SourceState,
    derived_config_lines,
    format_lat_dms,
    format_lon_dms,
    load_run_config,
    open_live_run,
    parse_source_url,
)
from uvnav_tui.cli.replay import bundled_data_dir, headless_lop_policy, integrity_summary_line

EXIT_OK = 0
EXIT_CANNOT_WRITE = 1
EXIT_BAD_INPUT = 2
EXIT_NO_FIX = 3
EXIT_INTERNAL = 4
EXIT_INTERRUPTED = 130
POLL_S = 0.25
"""Longest wait for data between two checks of the state and the stop conditions [s]."""
STILL_LOST_EVERY_S = 30.0
"""While the source is lost (or the stream's clock stalls the run), a reminder line this
often [s]."""
DROPS_EVERY_S = 10.0
"""While lines are being dropped (overload), a line saying how many at most this often [s]."""


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``uvnav live``."""
    p = argparse.ArgumentParser(prog="uvnav live", description=__doc__.splitlines()[0])
    p.add_argument("url", help="udp://0.0.0.0:10110, tcp://HOST:10110, gpsd://HOST:2947 or "
                   "serial:///dev/ttyUSB0?baud=4800")
    p.add_argument("--config", help="run configuration TOML (default: derived from the stream: "
                   "first fix, sensors seen in the first --learn seconds)")
    p.add_argument("--learn", type=float, default=LEARN_S, metavar="S",
                   help="without --config: seconds of data after the first fix from which the "
                   f"sensors are learned (default {LEARN_S:g})")
    out = p.add_mutually_exclusive_group()
    out.add_argument("--out", help=".OUT log (default live-YYYYMMDDTHHMMSSZ.OUT here; never "
                   "overwritten: a free NAME_N.OUT is chosen); the raw log NAME.raw.nmea and "
                   "NAME.raw.times.csv go beside it")
    out.add_argument("--no-out", action="store_true", help="write no .OUT log and no raw log")
    p.add_argument("--jsonl", help="also write one JSON object per cycle to this file")
    p.add_argument("--force", action="store_true",
                   help="replace earlier outputs (.OUT, --jsonl; a raw log is never replaced)")
    p.add_argument("--lop-reject", choices=("Y", "N", "y", "n"), metavar="Y|N",
                   help='what to do with an LOP failing the w-test when lsq.lop_reject is "A"')
    p.add_argument("--lost-after", type=float, default=5.0, metavar="S",
                   help="seconds without data before the source is reported lost (default 5)")
    p.add_argument("--cycles", type=int, metavar="N", help="stop after N cycles")
    p.add_argument("--seconds", type=float, metavar="S", help="stop after S seconds")
    p.add_argument("--quiet", action="store_true",
                   help="no line per cycle: only the source's state and the summary")
    return p


def cycle_line(r: CycleResult, latency_s: float, state: SourceState) -> str:
    """One line per cycle: ``#12 08:35:47Z 52°50'31.882" N 004°31'47.977" E ED50 KF 95% a/b
    30.7/12.0 m  latency 0.004 s  receiving``."""
    m = r.mpp
    ell = ""
    if m.ellipse is not None:
        a, b = m.ellipse.scaled(0.95)
        ell = f"  95% a/b {a:.1f}/{b:.1f} m"
    return (f"#{r.n} {r.time:%H:%M:%S}Z  {format_lat_dms(m.lat_deg)} "
            f"{format_lon_dms(m.lon_deg)} {r.datum} {m.source}{ell}  latency {latency_s:.3f} s"
            f"  {state.describe()}")


def state_line(old: SourceState | None, new: SourceState, url: str) -> str | None:
    """The line for a change of the source's state (None for one not worth a line)."""
    now = datetime.now(UTC).strftime("%H:%M:%SZ")
    if new.status == "receiving":
        if old is not None and old.is_lost:
            lost_s = new.since_mono_s - old.since_mono_s
            return f"{now} reconnected: {url} receiving again after {lost_s:.0f} s"
        return f"{now} receiving from {url}"
    if new.status == "lost" and (old is None or not old.is_lost):
        return f"{now} source lost: {url} ({new.detail})"
    if new.status == "connecting":
        return f"{now} connecting to {url} ({new.detail})" if new.detail else None
    return None


def _out_path(args: argparse.Namespace) -> Path | None:
    if args.no_out:
        return None
    if args.out:
        return Path(args.out)
    return Path(f"live-{datetime.now(UTC):%Y%m%dT%H%M%SZ}.OUT")


def _open(args: argparse.Namespace, start_mono_s: float) -> tuple[LiveRun, str]:
    """The live run (raises InputError / OSError before anything runs; NoFixInTime when
    ``--seconds`` from ``start_mono_s`` ended the wait for a first fix)."""
    spec = parse_source_url(args.url)
    guard = OutputGuard()
    if spec.kind == "serial":
        guard.protect("the serial device", spec.device)
    out = _out_path(args)
    jsonl = Path(args.jsonl) if args.jsonl else None
    if args.config is not None:
        cfg, data = load_run_config(args.config)
        cfg, words = headless_lop_policy(cfg, args.lop_reject)
        guard.protect("the configuration", args.config)
        return open_live_run(spec.url, cfg, data, out_path=out, force=args.force,
                             jsonl_path=jsonl, guard=guard, lost_after_s=args.lost_after,
                             history=1), words
    print(f"no --config: waiting for the first fix from {spec.url}, then {args.learn:g} s to "
          "learn the sensors (docs/LIVE.md)", flush=True)
    state: list[SourceState | None] = [None]

    def on_state(new: SourceState) -> None:
        line = state_line(state[0], new, spec.url)
        if line is not None:
            print(line, flush=True)
        state[0] = new

    policy: list[str] = []

    def prepare(derived: RunConfig) -> RunConfig:
        cfg, words = headless_lop_policy(derived, args.lop_reject)
        policy.append(words)
        return cfg

    run = open_live_run(spec.url, None, None, out_path=out, force=args.force, jsonl_path=jsonl,
                        guard=guard, lost_after_s=args.lost_after, history=1,
                        data_dir=bundled_data_dir(), learn_s=args.learn, on_state=on_state,
                        prepare=prepare, deadline_mono_s=_deadline(args, start_mono_s))
    print("configuration derived from the stream (docs/NMEA.md):")
    for line in derived_config_lines(run.session.config):
        print(f"  {line}")
    return run, policy[0]


def _print_cycles(step: LiveStep, run: LiveRun, args: argparse.Namespace) -> None:
    if not args.quiet:
        for c in step.cycles:
            print(cycle_line(c.result, c.latency_s, run.state), flush=True)


def _deadline(args: argparse.Namespace, start_mono_s: float) -> float | None:
    """When ``--seconds`` ends the run (``time.monotonic()`` s), or None."""
    return None if args.seconds is None else start_mono_s + args.seconds


def _loop(run: LiveRun, args: argparse.Namespace, start_mono_s: float) -> None:
    """Cycles until --cycles / --seconds from ``start_mono_s`` (or Ctrl-C, raised through)."""
    deadline = _deadline(args, start_mono_s)
    state: SourceState | None = None
    reminded = 0.0
    watch = _Watch()
    while True:
        if args.cycles is not None and run.cycles >= args.cycles:
            return
        if deadline is not None and time.monotonic() >= deadline:
            _print_cycles(run.finish(), run, args)  # the epoch still open
            return
        step = run.poll(POLL_S)
        for new in step.states:
            line = state_line(state, new, run.url)
            if line is not None:
                print(line, flush=True)
            state = new
        current = run.state
        watch.check(current, run.url)
        if current.is_lost and time.monotonic() - reminded >= STILL_LOST_EVERY_S:
            if reminded:
                print(f"{datetime.now(UTC):%H:%M:%SZ} {current.describe()}", flush=True)
            reminded = time.monotonic()
        elif not current.is_lost:
            reminded = 0.0
        for c in step.cycles:
            if not args.quiet:
                print(cycle_line(c.result, c.latency_s, current), flush=True)
            if args.cycles is not None and run.cycles >= args.cycles:
                return


class _Watch:
    """Lines for what the source's state does not queue: lines dropped under overload (at most
    every :data:`DROPS_EVERY_S`) and the stream's clock stalling the run (when it starts, every
    :data:`STILL_LOST_EVERY_S` while it lasts, when it ends)."""

    def __init__(self) -> None:
        self.drops = 0
        self.drops_said_at = -DROPS_EVERY_S
        self.clock = ""
        self.clock_said_at = 0.0

    def check(self, state: SourceState, url: str) -> None:
        now = time.monotonic()
        stamp = f"{datetime.now(UTC):%H:%M:%SZ}"
        if state.drops > self.drops and now - self.drops_said_at >= DROPS_EVERY_S:
            print(f"{stamp} source overloaded: {url}: {state.drops - self.drops} more lines "
                  f"dropped ({state.dropped} by UVNAV, {state.sys_dropped} datagrams by the "
                  "system, in all; the raw log's times file says where)", flush=True)
            self.drops, self.drops_said_at = state.drops, now
        stalled = state.clock.startswith("CLOCK BEHIND")
        if stalled and (not self.clock or now - self.clock_said_at >= STILL_LOST_EVERY_S):
            print(f"{stamp} {state.clock}: the stream's time went back, its sentences are "
                  "skipped until it passes the last epoch (no cycles meanwhile)", flush=True)
            self.clock, self.clock_said_at = state.clock, now
        elif not stalled and self.clock:
            print(f"{stamp} clock: the stream's time passes the last epoch again", flush=True)
            self.clock = ""


def _summary(run: LiveRun, policy: str) -> None:
    s = run.session.summary()
    print(f"epochs {s.epochs}  fixes {s.fixes}  rejected LOPs {s.rejected_lops}  "
          f"skipped records {s.skipped_records}  lines received {run.feed.lines}")
    print(overload_summary(run))
    print(integrity_summary_line(s, policy))
    for line in run.nmea_stats.summary_lines():
        print(f"nmea: {line}")
    if s.out_path is not None:
        print(f"log {s.out_path}")
    if run.raw_path is not None:
        print(f"raw log {run.raw_path} (receive times {run.raw_times_path})")
    if s.jsonl_path is not None:
        print(f"json lines {s.jsonl_path}")


def overload_summary(run: LiveRun) -> str:
    """What overload cost: ``lines dropped 0 (by UVNAV 0, datagrams by the system 0), received
    after the end 0 (raw log only), over-long lines 0 (0 bytes not kept)``."""
    feed = run.feed
    st = feed.source.state
    return (f"lines dropped {feed.dropped + feed.sys_dropped} (by UVNAV {feed.dropped} when "
            f"waiting lines were full, datagrams by the system {feed.sys_dropped}), received "
            f"after the end {feed.unrun} (raw log only), over-long lines {st.overlong} "
            f"({st.cut_bytes} bytes not kept)")


def run_live(argv: list[str]) -> int:
    """Entry point of ``uvnav live``; returns the exit status (module docstring)."""
    args = build_parser().parse_args(argv)
    start = time.monotonic()
    try:
        run, policy = _open(args, start)
    except NoFixInTime as exc:
        kept = f"; raw log {exc.raw_path}" if exc.raw_path is not None else ""
        print(f"uvnav live: {exc.url}: no position fix within --seconds {args.seconds:g} "
              f"({exc.lines} lines received): no configuration could be derived, nothing "
              f"run{kept}", file=sys.stderr)
        return EXIT_NO_FIX
    except InputError as exc:
        print(f"uvnav live: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as exc:
        name = exc.filename if exc.filename is not None else args.url
        print(f"uvnav live: {name}: {exc.strerror or exc} !", file=sys.stderr)
        return EXIT_BAD_INPUT if exc.filename is None else EXIT_CANNOT_WRITE
    for warning in run.session.data_warnings:
        print(f"uvnav live: warning: {warning}", file=sys.stderr)
    status = EXIT_OK
    try:
        try:
            _loop(run, args, start)
        except KeyboardInterrupt:
            status = EXIT_INTERRUPTED
            _print_cycles(run.finish(), run, args)  # the epoch still open
            print("uvnav live: interrupted (Ctrl-C); the logs keep every cycle completed and "
                  "every line received before it", file=sys.stderr)
        finally:
            run.close()
    except OSError as exc:
        print(f"uvnav live: {exc.filename}: cannot write: {exc.strerror or exc} !",
              file=sys.stderr)
        return EXIT_CANNOT_WRITE
    except Exception as exc:  # an engine bug (engine/run/session.py: never a bad record)
        traceback.print_exc()
        print(f"uvnav live: internal error ({type(exc).__name__}: {exc}): this is a bug, "
              "please report it with the raw log", file=sys.stderr)
        return EXIT_INTERNAL
    _summary(run, policy)
    return status

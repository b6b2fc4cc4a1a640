"""A run on a live NMEA source (docs/LIVE.md): source → raw log → epochs → session.

:func:`open_live_run` opens everything a live run needs, in an order that leaves nothing behind
when a step fails: the session with its ``.OUT`` log (by the ``.OUT`` rule), the raw log
beside it (``NAME.raw.nmea`` + ``NAME.raw.times.csv``, :mod:`engine.io.live_log`), the epoch
builder (``engine.io.nmea_epochs``) and the source's reader thread. :class:`LiveRun` then
turns what arrives into cycles, one :meth:`LiveRun.poll` at a time, at the pace the data
arrive (real time: nothing is paced here). Every completed cycle is on disk when
:meth:`LiveRun.poll` returns (the session flushes each one).

The ``.OUT`` header names the source's URL (``run udp://…``), and the configuration logged in it
has the raw log as its ``run_file``, so ``uvnav replay NAME.raw.nmea`` with that configuration
reproduces the run (without a raw log, the URL). The log time comes from the sentences; the UTC
date of today is the date of sentences that come before any RMC/ZDA (a live stream is today's).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path

from engine.io.datumfile import DatumFile
from engine.io.deccafile import DeccaChain
from engine.io.live_feed import LiveBatch, LiveFeed
from engine.io.live_log import RawLog, raw_log_stem
from engine.io.live_sources import LiveSource, SourceState, parse_source_url
from engine.io.nmea_epochs import EpochBuilder, NmeaOptions, NmeaStats
from engine.io.outputs import OutputGuard, free_name
from engine.run.config import RunConfig
from engine.run.cycle import CycleResult
from engine.run.session import Session


@dataclass(frozen=True)
class LiveCycle:
    """A cycle of a live run with its timing (monotonic seconds): ``received_mono_s`` when the
    line that closed its epoch was received, ``done_mono_s`` when the cycle's result was
    ready (logged)."""

    result: CycleResult
    received_mono_s: float
    done_mono_s: float

    @property
    def latency_s(self) -> float:
        """Seconds from the closing line received to the position available."""
        return self.done_mono_s - self.received_mono_s


@dataclass
class LiveStep:
    """What one :meth:`LiveRun.poll` did: the cycles, the source's changes of state and the
    lines received."""

    cycles: list[LiveCycle] = field(default_factory=list)
    states: list[SourceState] = field(default_factory=list)
    lines: int = 0


class LiveRun:
    """A session fed by a live source (module docstring)."""

    def __init__(self, session: Session, feed: LiveFeed, builder: EpochBuilder) -> None:
        self.session = session
        self.feed = feed
        self.builder = builder
        self.cycles = 0

    @property
    def url(self) -> str:
        """The source's URL."""
        return self.feed.source.url

    @property
    def state(self) -> SourceState:
        """The source's current state."""
        return self.feed.state

    @property
    def raw_path(self) -> Path | None:
        """``NAME.raw.nmea`` (None without a raw log)."""
        return self.feed.raw.path if self.feed.raw is not None else None

    @property
    def raw_times_path(self) -> Path | None:
        """``NAME.raw.times.csv`` (None without a raw log)."""
        return self.feed.raw.times_path if self.feed.raw is not None else None

    @property
    def nmea_stats(self) -> NmeaStats:
        """Sentences used and skipped so far (engine.io.nmea_epochs)."""
        return self.builder.stats

    def poll(self, timeout_s: float) -> LiveStep:
        """Take what arrived (waiting up to ``timeout_s`` s for something) and run a cycle for
        each epoch it completed: :meth:`receive` then :meth:`process`."""
        return self.process(self.receive(timeout_s))

    def receive(self, timeout_s: float) -> LiveBatch:
        """Take what arrived (raw log written, epochs formed) without running the cycles: a
        caller that shares the session with other threads runs :meth:`process` under its
        lock, and does not hold the lock while this waits."""
        return self.feed.poll(timeout_s)

    def finish(self) -> LiveStep:
        """Run the epoch the builder still holds (at the end of the run)."""
        return self.process(self.feed.finish())

    def process(self, batch: LiveBatch) -> LiveStep:
        """Run a cycle for each record of ``batch``."""
        out = LiveStep(states=batch.states, lines=batch.lines)
        for rec in batch.records:
            result = self.session.process(rec.item)
            if result is not None:
                self.cycles += 1
                out.cycles.append(LiveCycle(result, rec.received_mono_s, time.monotonic()))
        return out

    def close(self) -> None:
        """Stop the source (thread joined), close the raw log and the session's logs
        (idempotent)."""
        try:
            self.feed.close()
        finally:
            self.session.close()

    def __enter__(self) -> LiveRun:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def live_nmea_options(options: NmeaOptions | None = None,
                      today: datetime | None = None) -> NmeaOptions:
    """``options`` with today's UTC date when they give none (module docstring)."""
    options = options if options is not None else NmeaOptions()
    if options.date is not None:
        return options
    return replace(options, date=(today or datetime.now(UTC)).date())


def open_live_run(
    url: str,
    config: RunConfig,
    data: tuple[DatumFile, dict[str, DeccaChain]],
    *,
    out_path: Path | None,
    force: bool = False,
    jsonl_path: Path | None = None,
    guard: OutputGuard | None = None,
    nmea_options: NmeaOptions | None = None,
    lost_after_s: float = 5.0,
    backoff_s: tuple[float, float] = (0.5, 8.0),
    history: int = 3600,
    collect_smoother: bool = False,
) -> LiveRun:
    """Open a live run on ``url`` (module docstring). ``out_path`` None writes no ``.OUT`` and
    no raw log; ``nmea_options`` default to the configuration's ``[nmea]`` table. A bad URL is
    an :class:`~engine.errors.InputError` (field ``source …``) before anything is created; a
    UDP port in use is an :class:`OSError`, and the files already created are removed again."""
    spec = parse_source_url(url)
    guard = guard if guard is not None else OutputGuard()
    raw: RawLog | None = None
    if out_path is not None:
        # The raw log is named after the .OUT name the session will take (the first free one
        # unless --force), and made first, so the configuration in the .OUT header can name
        # it as the run file: replaying it reproduces the run.
        guard.check(out_path, "--out")
        stem = raw_log_stem(out_path if force else free_name(Path(out_path)))
        raw = RawLog.create(stem, source_url=spec.url, origin_mono_s=time.monotonic(),
                            guard=guard)
    source = LiveSource(spec, lost_after_s=lost_after_s, backoff_s=backoff_s)
    session: Session | None = None
    try:
        cfg = config.replace(run_file=str(raw.path) if raw is not None else spec.url)
        session = Session(cfg, out_path=out_path, force=force, jsonl_path=jsonl_path,
                          history=history, collect_smoother=collect_smoother, data=data,
                          guard=guard, records=(), source_name=spec.url)
        name = str(raw.path) if raw is not None else spec.url
        builder = EpochBuilder(live_nmea_options(
            nmea_options if nmea_options is not None else config.nmea.options), source=name)
        source.start()
    except BaseException:
        source.close()
        created: list[Path] = []
        if session is not None:
            if not force:
                created += [p for p in (session.out_path, session.jsonl_path) if p is not None]
            session.close()
        if raw is not None:  # always a new file (never replaced)
            raw.close()
            created += [raw.path, raw.times_path]
        for p in created:
            p.unlink(missing_ok=True)
        raise
    return LiveRun(session, LiveFeed(source, builder, raw), builder)


__all__ = ["LiveCycle", "LiveRun", "LiveStep", "live_nmea_options", "open_live_run"]

"""A run on a live NMEA source (docs/LIVE.md): source → raw log → epochs → session.

:func:`open_live_run` opens everything a live run needs, in an order that leaves nothing behind
when a step fails: the session with its ``.OUT`` log (by the ``.OUT`` rule), the raw log
beside it (``NAME.raw.nmea`` + ``NAME.raw.times.csv``, :mod:`engine.io.live_log`), the epoch
builder (``engine.io.nmea_epochs``) and the source's reader thread. :class:`LiveRun` then
turns what arrives into cycles, one :meth:`LiveRun.poll` at a time, at the pace the data
arrive (real time: nothing is paced here). Every completed cycle is on disk when
:meth:`LiveRun.poll` returns (the session flushes each one).

The ``.OUT`` header names the source's URL (``run udp://…``), and the configuration logged in it
has the raw log (its absolute path) as its ``run_file``, so ``uvnav replay NAME.raw.nmea`` with
that configuration reproduces the run (without a raw log, the URL).

:attr:`LiveRun.state` is the source's state with what the epoch builder says of the stream's
clock (``CLOCK BEHIND …`` while sentences are skipped because its time went back), so a stalled
run never looks merely "receiving". Lines dropped under overload are counted there, and the
next cycle carries a message saying how many (its ``MSG`` line in the ``.OUT``).

The log time comes from the sentences; the date from the stream's RMC/ZDA, or today's UTC date
when none arrives within :data:`LIVE_DATE_HOLD_LINES` sentences (a live stream is today's).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path

from engine.io.datumfile import DatumFile
from engine.io.deccafile import DeccaChain
from engine.io.live_feed import LiveBatch, LiveFeed, LiveRecord
from engine.io.live_log import RAW_PART_BYTES, RawLog, raw_log_stem
from engine.io.live_sources import QUEUE_BYTES, LiveSource, SourceState, parse_source_url
from engine.io.nmea_epochs import EpochBuilder, NmeaOptions, NmeaStats
from engine.io.outputs import OutputGuard, free_name
from engine.run.config import NmeaConfig, RunConfig
from engine.run.cycle import CycleResult
from engine.run.nmea_config import config_from_stats
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
        self.drops_noted = 0
        """Drops (lines and datagrams) already said in a cycle's message."""
        self.backlog: list[LiveRecord] = []
        """Records received before the session existed (a derived configuration): the next
        :meth:`receive` returns them first."""

    @property
    def url(self) -> str:
        """The source's URL."""
        return self.feed.source.url

    @property
    def state(self) -> SourceState:
        """The source's current state, with what is wrong with the stream's clock (module
        docstring)."""
        state = self.feed.state
        clock = self.builder.clock_trouble()
        return replace(state, clock=clock) if clock else state

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
        if self.backlog:
            batch, self.backlog = LiveBatch(records=self.backlog), []
            return batch
        return self.feed.poll(timeout_s)

    def finish(self) -> LiveStep:
        """Run what is still waiting at the end of the run: the learning seconds' records if
        no poll took them yet, then the epoch the builder still holds."""
        batch = self.feed.finish()
        if self.backlog:
            batch, self.backlog = replace(batch, records=[*self.backlog, *batch.records]), []
        return self.process(batch)

    def process(self, batch: LiveBatch) -> LiveStep:
        """Run a cycle for each record of ``batch``."""
        out = LiveStep(states=batch.states, lines=batch.lines)
        self._note_drops()
        for rec in batch.records:
            result = self.session.process(rec.item)
            if result is not None:
                self.cycles += 1
                out.cycles.append(LiveCycle(result, rec.received_mono_s, time.monotonic()))
        return out

    def _note_drops(self) -> None:
        """New drops since the last message: a message for the next cycle (one waits at a
        time; it counts all drops until that cycle)."""
        st = self.feed.source.state
        if st.drops > self.drops_noted and not self.session.pending_messages:
            self.session.add_message(
                f"Live source overloaded: {st.drops - self.drops_noted} lines dropped since "
                f"the last such message ({st.dropped} lines dropped by UVNAV, "
                f"{st.sys_dropped} datagrams by the system, in all; the raw log's times file "
                "says where)")
            self.drops_noted = st.drops

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
    hold = min(options.date_hold_lines, LIVE_DATE_HOLD_LINES)
    if options.date is not None:
        return replace(options, date_hold_lines=hold)
    return replace(options, date=(today or datetime.now(UTC)).date(), date_hold_lines=hold)


LIVE_DATE_HOLD_LINES = 100
"""Sentences a live run holds while waiting for a date (RMC/ZDA) in the stream before it takes
today's: a few seconds of a typical stream, so one without RMC/ZDA starts at once while a
stream that has them (an old log replayed into the port included) keeps its own date."""


class NoFixInTime(Exception):
    """A live run without a configuration reached its deadline before the stream gave a fix
    (nothing to derive the configuration from; nothing was run). ``lines``: lines received;
    ``raw_path``: the raw log that keeps them (None: no raw log, or no line to keep)."""

    def __init__(self, url: str, lines: int, raw_path: Path | None) -> None:
        super().__init__(f"{url}: no position fix in time ({lines} lines received): "
                         "no configuration could be derived, nothing run")
        self.url = url
        self.lines = lines
        self.raw_path = raw_path


LEARN_S = 10.0
"""Without a configuration: seconds of data after the first fix from which the sensors are
learned (docs/LIVE.md)."""


def open_live_run(
    url: str,
    config: RunConfig | None,
    data: tuple[DatumFile, dict[str, DeccaChain]] | None,
    *,
    out_path: Path | None,
    force: bool = False,
    jsonl_path: Path | None = None,
    guard: OutputGuard | None = None,
    nmea_options: NmeaOptions | None = None,
    lost_after_s: float = 5.0,
    backoff_s: tuple[float, float] = (0.5, 8.0),
    raw_part_bytes: int = RAW_PART_BYTES,
    queue_bytes: int = QUEUE_BYTES,
    history: int = 3600,
    collect_smoother: bool = False,
    data_dir: Path | None = None,
    learn_s: float = LEARN_S,
    on_state: Callable[[SourceState], None] | None = None,
    prepare: Callable[[RunConfig], RunConfig] | None = None,
    deadline_mono_s: float | None = None,
) -> LiveRun:
    """Open a live run on ``url`` (module docstring). ``out_path`` None writes no ``.OUT`` and
    no raw log; ``raw_part_bytes`` is the size of a raw log's part (engine/io/live_log.py),
    ``queue_bytes`` the bound of the lines waiting (engine/io/live_sources.py);
    ``nmea_options`` default to the configuration's ``[nmea]`` table. A bad URL is
    an :class:`~engine.errors.InputError` (field ``source …``) before anything is created; a
    UDP port in use is an :class:`OSError`, and the files already created are removed again.

    ``config`` None: the configuration is derived from the stream as from a log
    (engine/run/nmea_config.py: WGS84, DR position = the first fix, GPS on, Decca off, each
    sensor on when its sentences came) after ``learn_s`` seconds of data following the first
    fix; this waits for them (``on_state`` hears of the source's changes meanwhile) and needs
    ``data_dir`` (TO_WGS84.DAT, DECCA.CHN). The records of those seconds are run first.
    ``prepare`` adjusts the configuration (given or derived) before the session is made (a
    headless run's LOPReject policy). ``deadline_mono_s`` (``time.monotonic()`` seconds; the
    end of a run limited in time) ends that wait: the learning seconds are cut short there, and
    with no fix by then :class:`NoFixInTime` is raised (the raw log kept if it has lines).
    """
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
                            guard=guard, part_bytes=raw_part_bytes)
    source = LiveSource(spec, lost_after_s=lost_after_s, backoff_s=backoff_s,
                        queue_bytes=queue_bytes)
    feed: LiveFeed | None = None
    session: Session | None = None
    try:
        nmea = config.nmea if config is not None else NmeaConfig()
        options = nmea_options if nmea_options is not None else nmea.options
        builder = EpochBuilder(live_nmea_options(options),
                               source=str(raw.path) if raw is not None else spec.url)
        feed = LiveFeed(source, builder, raw)
        source.start()
        backlog: list[LiveRecord] = []
        # Absolute: the configuration resolves a relative run_file against its own directory,
        # not the current one a relative --out was given in.
        run_file = os.path.abspath(raw.path) if raw is not None else spec.url
        if config is None:
            if data_dir is None:
                raise ValueError("a live run without a configuration needs data_dir")
            _learn(feed, builder, backlog, learn_s, on_state, deadline_mono_s)
            if builder.stats.first_fix is None:
                raise NoFixInTime(spec.url, feed.lines,
                                  raw.path if raw is not None and raw.lines else None)
            config = config_from_stats(builder.stats, data_dir, nmea, run_file=run_file,
                                       config_dir=Path.cwd())
            data = None
        if prepare is not None:
            config = prepare(config)
        session = Session(config.replace(run_file=run_file), out_path=out_path, force=force,
                          jsonl_path=jsonl_path, history=history,
                          collect_smoother=collect_smoother, data=data, guard=guard,
                          records=(), source_name=spec.url)
    except BaseException as exc:
        created: list[Path] = []
        if session is not None:
            if not force:
                created += [p for p in (session.out_path, session.jsonl_path) if p is not None]
            session.close()
        if feed is not None:
            feed.close()
        else:
            source.close()
            if raw is not None:
                raw.close()
        ended_wait = isinstance(exc, (KeyboardInterrupt, NoFixInTime))
        if raw is not None and not (ended_wait and raw.lines):
            created += [raw.path, raw.times_path]  # always new files (never replaced); kept
            # when Ctrl-C or the deadline ended the wait for a derived configuration: lines
            # were received
        for p in created:
            p.unlink(missing_ok=True)
        raise
    run = LiveRun(session, feed, builder)
    run.backlog = backlog
    return run


def _learn(feed: LiveFeed, builder: EpochBuilder, backlog: list[LiveRecord], learn_s: float,
           on_state: Callable[[SourceState], None] | None,
           deadline_mono_s: float | None = None) -> None:
    """Receive until ``learn_s`` seconds after the first fix, or until ``deadline_mono_s``
    (``time.monotonic()`` s) comes first (records kept in ``backlog``)."""
    fixed_at: float | None = None
    while fixed_at is None or time.monotonic() - fixed_at < learn_s:
        if deadline_mono_s is not None and time.monotonic() >= deadline_mono_s:
            return
        batch = feed.poll(0.25)
        backlog += batch.records
        if on_state is not None:
            for state in batch.states:
                on_state(state)
        if fixed_at is None and builder.stats.first_fix is not None:
            fixed_at = time.monotonic()


__all__ = ["LEARN_S", "LiveCycle", "LiveRun", "LiveStep", "NoFixInTime", "live_nmea_options",
           "open_live_run"]

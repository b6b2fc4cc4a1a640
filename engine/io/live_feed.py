"""A live source turned into run records: lines → raw log → epoch builder (docs/LIVE.md).

:class:`LiveFeed` polls a :class:`~engine.io.live_sources.LiveSource`, writes every line to the
raw log (:mod:`engine.io.live_log`) and feeds it to an epoch builder (helper A's
``engine.io.nmea_epochs.EpochBuilder``: ``feed(line, line_no)`` → records), numbering the lines
as the raw log does, so a bad line is reported as ``NAME.raw.nmea:LINE``. Each record comes
with the receive time of the line that completed it, which is what the live latency is
measured from (bench/bench_live.py).

Under overload the source drops lines (engine/io/live_sources.py "Overload"); each gap is noted
in the raw log's times file where it happened, and :attr:`LiveFeed.dropped` counts them. A poll
takes at most :data:`~engine.io.live_sources.POLL_LINES` lines, so the caller gets back to its
checks often however much waits. At :meth:`LiveFeed.close` the lines received but not yet
polled are written to the raw log (not run: the run has ended), counted in
:attr:`LiveFeed.unrun`.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Protocol

from engine.io.live_log import RawLog
from engine.io.live_sources import LiveSource, ReceivedLine, SourceState
from engine.io.runfile import BadRecord, RunRecord

RECEIVE_TIMES_KEPT = 4096
"""Receive times of the most recent lines kept for :meth:`LiveFeed.received_mono_s`."""


class EpochSink(Protocol):
    """What the feed needs of an epoch builder (``engine.io.nmea_epochs.EpochBuilder``)."""

    def feed(self, line: str, line_no: int) -> list[RunRecord | BadRecord]:
        """One line in; the epochs (and bad lines) it completes out."""

    def finish(self) -> list[RunRecord | BadRecord]:
        """The epoch still open at the end."""


@dataclass(frozen=True)
class LiveRecord:
    """A record of the live stream and the monotonic receive time [s] of the line that
    completed it (the line whose ``feed`` returned it)."""

    item: RunRecord | BadRecord
    received_mono_s: float


@dataclass
class LiveBatch:
    """What one :meth:`LiveFeed.poll` brought: records, state changes (in order) and the
    number of lines received."""

    records: list[LiveRecord] = field(default_factory=list)
    states: list[SourceState] = field(default_factory=list)
    lines: int = 0


class LiveFeed:
    """Source → raw log → epoch builder; one per live run (module docstring)."""

    def __init__(self, source: LiveSource, epochs: EpochSink, raw: RawLog | None = None) -> None:
        self.source = source
        self.epochs = epochs
        self.raw = raw
        self.lines = 0
        self.dropped = 0
        """Lines dropped (the source's waiting lines full) before the lines polled so far."""
        self.sys_dropped = 0
        """Datagrams the system dropped before the lines polled so far (UDP, Linux)."""
        self.unrun = 0
        """Lines received but not run: still waiting when the feed was closed (in the raw
        log)."""
        self.closed = False
        self._gpsd = source.spec.kind == "gpsd"
        self._times: deque[tuple[int, float]] = deque(maxlen=RECEIVE_TIMES_KEPT)
        self._lock = threading.Lock()
        """Held by :meth:`poll` and :meth:`close`: a poll never writes to a closed raw log."""

    @property
    def state(self) -> SourceState:
        """The source's current state."""
        return self.source.state

    def received_mono_s(self, line_no: int) -> float | None:
        """Monotonic receive time [s] of line ``line_no`` if it is among the last
        :data:`RECEIVE_TIMES_KEPT` lines."""
        for number, mono in reversed(self._times):
            if number == line_no:
                return mono
            if number < line_no:
                break
        return None

    def poll(self, timeout_s: float) -> LiveBatch:
        """Take what the source received (waiting up to ``timeout_s`` s for something): every
        line goes to the raw log and the builder; the raw log is flushed once per poll. After
        :meth:`close`, an empty batch at once."""
        with self._lock:
            if self.closed:
                return LiveBatch()
            return self._poll(timeout_s)

    def _poll(self, timeout_s: float) -> LiveBatch:
        batch = LiveBatch()
        for item in self.source.poll(timeout_s):
            if isinstance(item, ReceivedLine):
                self._line(item, batch)
            else:
                batch.states.append(item)
                if self.raw is not None:
                    self.raw.write_state(item, time.time())
        if self.raw is not None:
            self.raw.flush()
        return batch

    def _line(self, line: ReceivedLine, batch: LiveBatch) -> None:
        self.dropped += line.dropped_before
        self.sys_dropped += line.sys_dropped_before
        number = self.raw.write_line(line) if self.raw is not None else line.number
        self.lines += 1
        batch.lines += 1
        self._times.append((number, line.mono_s))
        if self._gpsd and line.text.startswith("{"):
            return  # gpsd's JSON replies: in the raw log, not NMEA
        for item in self.epochs.feed(line.text, number):
            batch.records.append(LiveRecord(item, line.mono_s))

    def finish(self) -> LiveBatch:
        """The epoch the builder still holds (at the end of a live run)."""
        now = time.monotonic()
        return LiveBatch(records=[LiveRecord(i, now) for i in self.epochs.finish()])

    def close(self) -> None:
        """Close the source (thread joined) and the raw log (waits for a poll in progress):
        the lines still waiting go to the raw log (not run, counted in :attr:`unrun`), and the
        drops after the last of them are noted. Idempotent."""
        with self._lock:
            if self.closed:
                return
            self.closed = True
            try:
                self.source.close()
                self._drain()
            finally:
                if self.raw is not None:
                    self.raw.close()

    def _drain(self) -> None:
        """Lines and states still waiting after the source closed: into the raw log."""
        while True:
            items = self.source.poll(0.0)
            if not items:
                break
            for item in items:
                if isinstance(item, ReceivedLine):
                    self.dropped += item.dropped_before
                    self.sys_dropped += item.sys_dropped_before
                    self.unrun += 1
                    if self.raw is not None:
                        self.raw.write_line(item)
                elif self.raw is not None:
                    self.raw.write_state(item, time.time())
        lines, datagrams = self.source.trailing_drops
        self.dropped += lines
        self.sys_dropped += datagrams
        if self.raw is not None and (lines or datagrams):
            self.raw.write_drops(lines, datagrams, time.time(), time.monotonic(),
                                 f"after line {self.raw.lines} (at the end)")


__all__ = ["EpochSink", "LiveBatch", "LiveFeed", "LiveRecord"]

"""Run states and cycle pacing of the console (THEORY §12.2, D43–D44); no widgets.

``working``: cycles advance at the sample interval divided by the playback pace;
``interrupted``: a menu or dialog is open, cycles pause and resume when it closes;
``suspended``: frozen until Run ▸ Continue (also at the end of the data file).

The cycle worker thread and the UI thread share one :class:`RunController`; every use of the
session goes through :attr:`RunController.lock`, so an operator command is never applied while
a cycle is being computed.
"""

from __future__ import annotations

import asyncio
import math
import os
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import replace
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING

from engine import api
from engine.api import DatumFile, DeccaChain, InputError, RunConfig, format_time_z, pace_factor
from uvnav_tui.widgets.message_log import MessageLog

if TYPE_CHECKING:
    from engine.api import BadRecord, Command, CycleResult, LiveRun, RunRecord, Session, SourceState

STATE_WORDS = {
    "working": "Working...",
    "interrupted": "Interrupted...",
    "suspended": "Suspended...",
}

BATCH_S = 0.01
"""At pace fast the worker computes cycles in batches of up to this long under one hold of the
lock (one wake-up of the display per batch, not per cycle; a menu, a question, the end of the
data or an operator command stop a batch at the next cycle)."""
PACE_SLICE_S = 0.02
"""Longest single sleep while waiting for the next cycle (so a pause takes effect at once)."""
LIVE_POLL_S = 0.1
"""Longest wait for a live source's data in one turn of the worker [s]."""
LIVE_LOST_AFTER_S = 5.0
"""Seconds without data before a live source shows ``SOURCE LOST`` (docs/LIVE.md)."""
LIVE_TICK_S = 1.0
"""While a live source is lost, the state line is repainted this often (its counter) [s]."""
ALARM_BELL_REPEAT_S = 30.0
"""An unacknowledged alarm rings the terminal bell again after this many seconds [s]: a bridge
alarm sounds until it is acknowledged (IMO MSC.302(87), bridge alert management; IEC 62923-1),
and a terminal bell is a single beep."""


def bad_record_text(error: InputError, line_no: int) -> str:
    """``Bad record skipped: DEMO.RUN:12 heading: Not a number ! (got 'x')``: file name, line
    and field, literal (the raw text may hold anything)."""
    name = Path(error.file).name if error.file else "run file"
    where = f"{name}:{error.line if error.line is not None else line_no}"
    field = f" {error.field}:" if error.field else ""
    got = f" (got {error.text!r})" if error.text is not None else ""
    return f"Bad record skipped: {where}{field} {error.message}{got}"


def out_folder(folder: Path, out_dir: Path | None) -> Path:
    """Where a run's ``.OUT`` goes: ``out_dir`` if given, else ``folder`` (the run file's)
    when it is writable, else the current directory."""
    if out_dir is not None:
        return out_dir
    return folder if os.access(folder, os.W_OK) else Path.cwd()


def open_session(cfg: RunConfig, data: tuple[DatumFile, dict[str, DeccaChain]], *,
                 write_out: bool, out_dir: Path | None = None) -> Session | LiveRun | str:
    """A session for ``cfg`` (if ``write_out``, its ``.OUT`` under a free name in
    :func:`out_folder` of the run file's folder), or the message saying why it cannot be
    opened. A ``run_file`` that is a live-source URL (``udp://…``, ``tcp://…``,
    ``serial://…``) opens a live run instead: its ``.OUT`` ``live-YYYYMMDDTHHMMSSZ.OUT`` and the
    raw log beside it go to :func:`out_folder` of the configuration's directory
    (docs/LIVE.md)."""
    from engine.api import is_source_url

    try:
        if is_source_url(cfg.run_file):
            from engine.api import open_live_run

            out = (out_folder(cfg.config_dir, out_dir)
                   / f"live-{datetime.now(UTC):%Y%m%dT%H%M%SZ}.OUT" if write_out else None)
            return open_live_run(cfg.run_file, cfg, data, out_path=out, collect_smoother=True,
                                 lost_after_s=LIVE_LOST_AFTER_S)
        out = (out_folder(cfg.run_path.parent, out_dir) / cfg.run_path.with_suffix(".OUT").name
               if write_out else None)
        return api.Session(cfg, out_path=out, collect_smoother=True, data=data)
    except InputError as exc:
        return exc.message if exc.field is None or not exc.field.startswith("source") else (
            f"{exc.field}: {exc.message}")
    except OSError as exc:
        return f"File error: {exc.strerror or exc}"


class RunController:
    """One run's state flags, cycle budget, pacing and the lock around its session."""

    def __init__(self, session: Session | LiveRun, *, pace_override: str | None = None,
                 log: MessageLog | None = None,
                 on_cycle: Callable[[CycleResult], None] | None = None) -> None:
        self.live: LiveRun | None = None
        """The live source feeding the session (None: a run file)."""
        if not isinstance(session, api.Session):
            self.live, session = session, session.session
        self.session = session
        self.started_wall_s = time.time()
        """Wall-clock time (s) the run started: the message line shows nothing older (the
        message log, F2, keeps every run's)."""
        self.on_cycle = on_cycle
        """Called with every new cycle (worker thread): the console's NMEA output."""
        self.source_state: SourceState | None = None
        """The live source's state at the last turn of the worker."""
        self.pending: deque[RunRecord | BadRecord] = deque()
        """Live records received but not yet processed (the run may not advance now)."""
        self._logged_state: SourceState | None = None
        self.log = log if log is not None else MessageLog()
        """Where every engine message and bad record of the run goes (with its record time)."""
        self._bad_seen = 0
        self.lock = threading.RLock()
        self.pace_override = pace_override
        self.suspended = False
        self.interrupted = False
        self.awaiting_answer = False
        self.eof = False
        self.budget: int | None = None
        self.cycles = 0
        self.latest: CycleResult | None = None
        self.note = ""
        self.stopped = False
        self.error: BaseException | None = None
        self.worker_active = False
        self._worker_lock = threading.Lock()
        self._last_step = -math.inf
        self.last_fix_time: datetime | None = None
        """Record time of the last cycle with a position fix (LSE), or None."""
        self.alarm_acked = False
        """The operator acknowledged the present source-lost alarm (:meth:`acknowledge`)."""
        self._bell_mono = -math.inf
        if self.live is not None:  # Pg 620 labels the heading by the stream's sentences
            from uvnav_tui.pages.input_kind import LIVE_STATS

            LIVE_STATS[session] = self.live.nmea_stats
        name = self.live.url if self.live is not None else Path(session.config.run_file).name
        self.log.mark(f"Run started: {name}")
        self._closed = False

    # ------------------------------------------------------------------ state
    @property
    def state(self) -> str:
        """``working``, ``interrupted`` or ``suspended``."""
        if self.suspended:
            return "suspended"
        if self.interrupted or self.awaiting_answer:
            return "interrupted"
        return "working"

    @property
    def state_word(self) -> str:
        """The word at the top left of every page (``Working...`` …)."""
        return STATE_WORDS[self.state]

    @property
    def pace(self) -> str:
        """The pace in force: the override (headless scripts) or ``config.demo.pace``;
        ``live`` on a live source (the data's own pace)."""
        if self.live is not None:
            return "live"
        return self.pace_override or self.session.config.demo.pace

    @property
    def live_text(self) -> str:
        """``LIVE receiving udp://0.0.0.0:10110`` / ``(no data for 5 s) udp://…`` while lost
        (the alarm, :attr:`alarm_text`, says ``SOURCE LOST 12 s``) for the state line ("" for a
        run file)."""
        if self.live is None:
            return ""
        state = self.live.state
        if state.is_lost:
            why = f"({state.detail}) " if state.detail else ""
            again = "reconnecting " if state.status == "reconnecting" else ""
            return f"{why}{again}{self.live.url}"
        trouble = state.trouble()
        if trouble:  # drops or a stalled clock first: a long URL cut at 80 columns cannot hide
            return f"{trouble[2:]} {self.live.url}"  # them
        # the state before the URL, so that a long URL cut at 80 columns cannot hide it
        return f"LIVE {state.describe()} {self.live.url}"

    @property
    def source_lost(self) -> bool:
        """True while the live source is lost (never for a run file)."""
        return self.live is not None and self.live.state.is_lost

    @property
    def alarm_text(self) -> str:
        """``SOURCE LOST 12 s`` while the live source is lost, else ""."""
        if not self.source_lost:
            return ""
        assert self.live is not None
        lost_s = max(0.0, time.monotonic() - self.live.state.since_mono_s)
        return f"SOURCE LOST {lost_s:.0f} s"

    def acknowledge(self) -> bool:
        """The operator acknowledges the source-lost alarm: the bell stops (the alarm stays
        shown until the source receives again). False if there is no unacknowledged alarm."""
        if not self.source_lost or self.alarm_acked:
            return False
        self.alarm_acked = True
        assert self.live is not None
        self.log.add(f"Alarm acknowledged: source lost {self.live.url}",
                     self.latest.time if self.latest is not None else None, "console")
        return True

    def bell_due(self, now_mono_s: float | None = None) -> bool:
        """True when the bell should ring now: an unacknowledged alarm, at its onset and every
        :data:`ALARM_BELL_REPEAT_S` after (the call counts as the ring)."""
        if not self.source_lost or self.alarm_acked:
            return False
        now = time.monotonic() if now_mono_s is None else now_mono_s
        if now - self._bell_mono < ALARM_BELL_REPEAT_S:
            return False
        self._bell_mono = now
        return True

    def fix_age_s(self) -> float | None:
        """Seconds since the last position fix: record time from that fix to the latest
        cycle, plus on a live source the wall-clock seconds since that cycle (no record comes
        while the source is lost). None before the first fix."""
        if self.last_fix_time is None or self.latest is None:
            return None
        age = (self.latest.time - self.last_fix_time).total_seconds()
        if self.live is not None:
            age += self.wall_since_cycle_s()
        return max(age, 0.0)

    def wall_since_cycle_s(self) -> float:
        """Wall-clock seconds since the last cycle was computed (0 before the first)."""
        if self._last_step == -math.inf:
            return 0.0
        return max(0.0, time.monotonic() - self._last_step)

    def dead_reckoned(self) -> CycleResult | None:
        """While the live source is lost: the latest cycle with its MPP dead-reckoned to the
        wall clock (:meth:`Session.dead_reckon`: last heading, speed and current carried on,
        the ellipse grown), else None."""
        r = self.latest
        if not self.source_lost or r is None:
            return None
        with self.lock:
            mpp = self.session.dead_reckon(self.wall_since_cycle_s())
        return replace(r, mpp=mpp) if mpp is not None else None

    @property
    def status_note(self) -> str:
        """The state line's note: the run's note (end of data, engine error) or the live
        source's state."""
        return self.note or self.live_text

    def can_run(self) -> bool:
        """True if the worker may compute the next cycle now."""
        return (
            self.state == "working"
            and not self.eof
            and not self.stopped
            and (self.budget is None or self.budget > 0)
        )

    def interval_s(self) -> float:
        """Wall-clock seconds between cycles at the current pace (0 = as fast as possible)."""
        if self.live is not None:
            return 0.0  # the data come at their own pace
        factor = pace_factor(self.pace)
        if math.isinf(factor):
            return 0.0
        dt = self.latest.dt_s if self.latest is not None else self.session.config.demo.delta_t_s
        return max(dt, 0.0) / factor

    def grant(self, cycles: int) -> None:
        """Allow ``cycles`` more cycles (scripted runs hold the run between their lines)."""
        self.budget = (self.budget or 0) + cycles

    # ------------------------------------------------------------------ worker bookkeeping
    def begin_worker(self) -> bool:
        """True (and marked active) if a new worker should start now."""
        with self._worker_lock:
            if self.worker_active or not (self.can_run() or self._live_open()):
                return False
            self.worker_active = True
            return True

    def _live_open(self) -> bool:
        """A live run that has not been stopped: its worker keeps receiving (raw log written)
        even while the run may not advance."""
        return self.live is not None and not self.stopped

    def worker_may_continue(self) -> bool:
        """Checked by the worker before each cycle; it ends (inactive) when False."""
        with self._worker_lock:
            if self.can_run():
                return True
            self.worker_active = False
            return False

    def end_worker(self) -> None:
        """The worker has ended."""
        with self._worker_lock:
            self.worker_active = False

    def fail(self, exc: BaseException) -> None:
        """An engine error: keep it, suspend the run and say so."""
        self.error = exc
        self.suspended = True
        self.note = f"Engine error: {exc}"

    # ------------------------------------------------------------------ cycles
    def wait_due(self, stop: Callable[[], bool]) -> bool:
        """Sleep until the next cycle is due; False if ``stop()`` became true meanwhile."""
        while True:
            if stop():
                return False
            remaining = self._last_step + self.interval_s() - time.monotonic()
            if remaining <= 0.0:
                return True
            time.sleep(min(remaining, PACE_SLICE_S))

    def step(self) -> CycleResult | None:
        """Compute one cycle (caller holds :attr:`lock`); None and ``eof`` at the end."""
        result = self.session.step()
        self._last_step = time.monotonic()
        self._log_bad_records(result.time if result is not None else None)
        if result is None:
            self.eof = True
            self.suspended = True
            self.note = self._end_note()
            self.log.add(self.note, self.latest.time if self.latest is not None else None,
                         "data")
            return None
        return self._count(result)

    def run_cycles(self, cancelled: Callable[[], bool], *, advanced: Callable[[], None],
                   ended: Callable[[], None], question: Callable[[CycleResult], None]) -> None:
        """The cycle worker's loop (worker thread): compute cycles while the run may advance,
        at its pace, until ``cancelled()``.  Calls ``advanced()`` after each cycle,
        ``question(result)`` when a cycle flags an LOP for rejection and ``ended()`` at the end
        of the data or on an engine error (the run is then suspended with a note)."""
        try:
            if self.live is not None:
                self._run_live(cancelled, advanced, question)
                return
            while self.worker_may_continue() and not cancelled():
                if not self.wait_due(lambda: cancelled() or not self.can_run()):
                    continue
                with self.lock:
                    if not self.can_run():
                        continue
                    result = self.step()
                    if result is not None and self.interval_s() == 0.0:
                        result = self._batch(result, cancelled)
                if result is None:
                    ended()
                    continue
                advanced()
                if self.awaiting_answer:
                    question(result)
        except Exception as exc:  # noqa: BLE001 - an engine failure must not kill the console
            self.fail(exc)
            ended()
        finally:
            self.end_worker()

    def _batch(self, result: CycleResult, cancelled: Callable[[], bool]) -> CycleResult | None:
        """More cycles after ``result`` (caller holds :attr:`lock`, pace fast) while the run may
        advance, for up to :data:`BATCH_S`; the last one (None at the end of the data). Each
        cycle is counted, logged and written to the ``.OUT`` by :meth:`step` as one at a time."""
        deadline = time.monotonic() + BATCH_S
        while (not self.awaiting_answer and self.can_run() and not cancelled()
               and time.monotonic() < deadline):
            nxt = self.step()
            if nxt is None:
                return None
            result = nxt
        return result

    def _run_live(self, cancelled: Callable[[], bool], advanced: Callable[[], None],
                  question: Callable[[CycleResult], None]) -> None:
        """The worker's loop on a live source, until the run is stopped: receive (without the
        lock, so operator commands are never kept waiting by the network; the raw log is
        written), then run the cycles under the lock while the run may advance. Records that
        arrive while it may not (a menu open, suspended, an LOP question) wait in
        :attr:`pending`. A change of the source's state, and every :data:`LIVE_TICK_S` while it
        is lost, repaints."""
        live = self.live
        assert live is not None
        ticked = time.monotonic()
        while not self.stopped and not cancelled():
            if not self.pending or not self.can_run():
                batch = live.receive(LIVE_POLL_S)
                self.pending.extend(r.item for r in batch.records)
                for s in batch.states:
                    self._log_state(s)
            result: CycleResult | None = None
            with self.lock:
                if self.stopped:
                    return
                while self.pending and self.can_run():
                    r = self.session.process(self.pending.popleft())
                    self._log_bad_records(r.time if r is not None else None)
                    if r is not None:
                        result = self._count(r)
            state = live.state
            changed = state != self.source_state
            self.source_state = state
            now = time.monotonic()
            if result is not None or changed or (state.is_lost and now - ticked >= LIVE_TICK_S):
                ticked = now
                advanced()
            if result is not None and self.awaiting_answer:
                question(result)

    def _count(self, result: CycleResult) -> CycleResult:
        """Book a computed cycle (from :meth:`step`, or from a live source): count it, keep it,
        log its messages, hand it on, and note an LOP question."""
        self._last_step = time.monotonic()
        self.cycles += 1
        if self.budget is not None:
            self.budget -= 1
        self.latest = result
        if result.fix is not None and result.fix.ok:
            self.last_fix_time = result.time
        self._log_messages(result)
        if self.on_cycle is not None:
            self.on_cycle(result)
        if result.fix is not None and result.fix.candidate_slot is not None:
            self.awaiting_answer = True
        return result

    def _log_state(self, state: SourceState) -> None:
        """A live source's change of state, in the message log."""
        assert self.live is not None
        when = self.latest.time if self.latest is not None else None
        was_lost = self._logged_state is not None and self._logged_state.is_lost
        if state.status == "lost" and not was_lost:
            self.alarm_acked = False
            self._bell_mono = -math.inf
            self.log.add(f"Source lost: {self.live.url} ({state.detail})", when, "data")
        elif state.status == "receiving":
            again = "again " if was_lost else ""
            self.log.add(f"Source receiving {again}from {self.live.url}", when, "data")
        self._logged_state = state

    async def wait_cycles(self, n: int, kick: Callable[[], None], timeout_s: float) -> int:
        """Let ``n`` more cycles run (granting them when the run is held; ``kick()`` starts the
        worker) and wait for them (scripts, tests).

        Returns the number of cycles done; stops early at the end of the data file or when the
        run is suspended. Raises ``TimeoutError`` after ``timeout_s``.
        """
        start = self.cycles
        if self.budget is not None:
            self.grant(n)
        kick()
        deadline = time.monotonic() + timeout_s
        while self.cycles < start + n and not self.eof and not self.suspended:
            if time.monotonic() > deadline:
                raise TimeoutError(f"{self.cycles - start} of {n} cycles after {timeout_s} s")
            await asyncio.sleep(0.005)
        return self.cycles - start

    def recompute(self, excluded: tuple[int, ...]) -> CycleResult | None:
        """Redo the last cycle without the ``excluded`` LOP slots (LOPReject 'A', yes)."""
        with self.lock:
            result = self.session.recompute_last(excluded)
            if result is not None:
                self.latest = result
                self._log_messages(result)
            return result

    def keep(self, slot: int) -> None:
        """The operator kept the flagged LOP in ``slot`` (LOPReject 'A', no): logged."""
        with self.lock:
            self.session.record_lop_kept(slot)

    @property
    def bad_records(self) -> int:
        """Records of the ``.RUN`` file skipped as bad so far."""
        return len(self.session.bad_records)

    def _log_messages(self, result: CycleResult) -> None:
        for text in result.messages:
            self.log.add(text, result.time, "engine")

    def _log_bad_records(self, when: datetime | None) -> None:
        """Put the records skipped since the last cycle in the log, one message each."""
        bad = self.session.bad_records
        if when is None and self.latest is not None:
            when = self.latest.time
        for item in bad[self._bad_seen:]:
            self.log.add(bad_record_text(item.error, item.line_no), when, "data")
        self._bad_seen = len(bad)

    def _end_note(self) -> str:
        """``End of data file``, saying how many records were bad (all of them: no cycle)."""
        n_bad = len(self.session.bad_records)
        if self.cycles == 0 and n_bad:
            return f"End of data file: no valid record ({n_bad} bad, none used)"
        if self.cycles == 0:
            return "End of data file: no records"
        if n_bad:
            return f"End of data file ({n_bad} bad record{'s' if n_bad > 1 else ''} skipped)"
        return "End of data file"

    def apply(self, cmd: Command) -> str:
        """Apply an operator command between cycles; returns the log text."""
        with self.lock:
            return self.session.apply(cmd)

    def close(self) -> None:
        """Close the session's logs (and a live source: its thread joined, its raw log); the
        end of the run is marked in the message log."""
        if self.live is not None:
            self.live.feed.close()  # not under the lock: a receive in progress ends first
        with self.lock:
            self.session.close()
        if not self._closed:
            self._closed = True
            last = (f", last record {format_time_z(self.latest.time)}"
                    if self.latest is not None else "")
            self.log.mark(f"Run ended: {self.cycles} cycles{last}")

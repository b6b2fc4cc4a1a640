"""Run states and cycle pacing of the console (program.md §2.1, A21, A22); no widgets.

``working``: cycles advance at the sample interval divided by the playback pace;
``interrupted``: a menu or dialog is open, cycles pause and resume when it closes;
``suspended``: frozen until Run ▸ Continue (also at the end of the data file).

The cycle worker thread and the UI thread share one :class:`RunController`; every use of the
session goes through :attr:`RunController.lock`, so an operator command is never applied while
a cycle is being computed.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable

from engine.commands import Command
from engine.cycle import CycleResult
from engine.session import Session

STATE_WORDS = {
    "working": "Working...",
    "interrupted": "Interrupted...",
    "suspended": "Suspended...",
}

PACE_SLICE_S = 0.02
"""Longest single sleep while waiting for the next cycle (so a pause takes effect at once)."""


def pace_factor(pace: str) -> float:
    """Playback speed relative to real time for a pace word (``real``, ``fast``, ``xN``)."""
    if pace == "real":
        return 1.0
    if pace == "fast":
        return math.inf
    return float(pace[1:])


class RunController:
    """One run's state flags, cycle budget, pacing and the lock around its session."""

    def __init__(self, session: Session, *, pace_override: str | None = None) -> None:
        self.session = session
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
        """The pace in force: the override (headless scripts) or ``config.demo.pace``."""
        return self.pace_override or self.session.config.demo.pace

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
            if self.worker_active or not self.can_run():
                return False
            self.worker_active = True
            return True

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
        if result is None:
            self.eof = True
            self.suspended = True
            self.note = "End of data file"
            return None
        self.cycles += 1
        if self.budget is not None:
            self.budget -= 1
        self.latest = result
        if result.fix is not None and result.fix.candidate_slot is not None:
            self.awaiting_answer = True
        return result

    def recompute(self, excluded: tuple[int, ...]) -> CycleResult | None:
        """Redo the last cycle without the ``excluded`` LOP slots (LOPReject 'A', yes)."""
        with self.lock:
            result = self.session.recompute_last(excluded)
            if result is not None:
                self.latest = result
            return result

    def apply(self, cmd: Command) -> str:
        """Apply an operator command between cycles; returns the log text."""
        with self.lock:
            return self.session.apply(cmd)

    def close(self) -> None:
        """Close the session's logs."""
        with self.lock:
            self.session.close()

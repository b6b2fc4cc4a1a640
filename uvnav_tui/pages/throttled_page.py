"""Shared pieces of the plot pages (Pg 642, 643, 710): a throttled text body and safe copies of
the session's history (the cycle worker may append to it while a page reads it)."""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import ClassVar

from textual.content import Content
from textual.timer import Timer
from textual.widget import Widget

from engine.api import CycleResult, Session

MIN_INTERVAL_S = 0.25
"""Minimum wall-clock time between two redraws of a plot page (s)."""


def history_upto(history: Sequence[CycleResult], r: CycleResult) -> list[CycleResult]:
    """The cycles of ``history`` up to and including ``r`` (the console's worker may already
    have appended newer ones), oldest first."""
    items = list(history)
    while items and items[-1].n > r.n:
        items.pop()
    return items


def snapshot(history: Sequence[CycleResult]) -> list[CycleResult]:
    """A copy of the session's history deque, retried if the worker thread appends meanwhile."""
    for _ in range(3):
        try:
            return list(history)
        except RuntimeError:  # deque mutated during iteration
            continue
    return list(history)


class ThrottledTextPage(Widget):
    """Base of the plot pages: a text body redrawn at most every :data:`MIN_INTERVAL_S`.

    :meth:`show` keeps the latest cycle; if the last redraw was less than ``MIN_INTERVAL_S`` ago
    (wall clock; :attr:`min_interval_s`) it only arms a timer for the trailing redraw, unless
    ``force``.  The text comes
    from :meth:`page_lines` at the widget's size (subclasses implement it).
    """

    min_interval_s: ClassVar[float] = MIN_INTERVAL_S
    """Minimum wall-clock time between two redraws of this page (s)."""

    DEFAULT_CSS = """
    ThrottledTextPage {
        width: 1fr;
        height: 1fr;
        text-wrap: nowrap;
        text-overflow: clip;
    }
    """

    def __init__(self) -> None:
        super().__init__()
        self._pending: tuple[CycleResult | None, Session | None] = (None, None)
        self._shown: tuple[CycleResult | None, Session | None] = (None, None)
        self._last_redraw_s: float | None = None
        self._timer: Timer | None = None
        self._key: tuple[tuple[int, int], tuple[object, ...]] | None = None
        self._text = ""
        self.redraws = 0
        """How many times the text was rebuilt (for tests and the bench)."""

    def show(self, r: CycleResult | None, session: Session | None, *, force: bool = False) -> None:
        """Render cycle ``r`` of ``session`` (throttled unless ``force``)."""
        self._pending = (r, session)
        now = time.monotonic()
        last = self._last_redraw_s
        if force or last is None or now - last >= self.min_interval_s or not self.is_mounted:
            self._redraw(now)
        elif self._timer is None:
            self._timer = self.set_timer(self.min_interval_s - (now - last), self._trailing)

    def _trailing(self) -> None:
        self._timer = None
        self._redraw(time.monotonic())

    def _redraw(self, now: float) -> None:
        if self._timer is not None:
            self._timer.stop()
            self._timer = None
        self._last_redraw_s = now
        self._shown = self._pending
        self.refresh()

    def page_lines(self, r: CycleResult | None, session: Session | None, width: int,
                   height: int) -> list[str]:
        """The page text at ``width`` × ``height`` (override)."""
        return []

    def page_key(self, r: CycleResult | None, session: Session | None) -> tuple[object, ...]:
        """The objects the text depends on besides the size, compared by identity (override to
        add more)."""
        return (r, session, None if session is None else session.config)

    def render(self) -> Content:
        """The text of the shown cycle at the current size (rebuilt only when either changed)."""
        r, session = self._shown
        w, h = self.content_size
        objs = self.page_key(r, session)
        old = self._key
        if (old is None or old[0] != (w, h) or len(old[1]) != len(objs)
                or any(a is not b for a, b in zip(old[1], objs, strict=True))):
            self._key = ((w, h), objs)
            self._text = "\n".join(self.page_lines(r, session, w, h))
            self.redraws += 1
        return Content(self._text)

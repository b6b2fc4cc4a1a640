"""The message line above the key hints: the newest message of the log, with its record time.

A message stays :data:`MESSAGE_TTL_S` seconds of wall time and then clears, so an old message
never hides the state of the run ("LOP Decca Red discarded" is not still shown 40 minutes
later); every message stays in the log (Statistics ▸ Messages, F2). Text is always literal.
"""

from __future__ import annotations

import time

from rich.cells import cell_len
from textual.content import Content
from textual.widget import Widget

from uvnav_tui.widgets.message_log import ALARM, LogEntry, MessageLog, classify

MESSAGE_TTL_S = 30.0
"""Wall-clock seconds a message stays on the message line."""
MESSAGE_LINES_MAX = 3
"""A long message wraps onto at most this many lines (80×24: one stays cut only past 3 × 78)."""


class MessageLine(Widget):
    """``HH:MM:SSZ text`` of the newest entry while fresh (wrapped, up to 3 lines), else blank."""

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self._log: MessageLog | None = None
        self._entry: LogEntry | None = None
        self._since_s = 0.0
        self._text = ""

    def on_mount(self) -> None:
        """Re-check the age of the message once a second (also while nothing runs)."""
        self.set_interval(1.0, self._age, name="message-age")

    @property
    def text(self) -> str:
        """What the line shows now."""
        return self._text

    def show(self, log: MessageLog, now_s: float | None = None,
             since_s: float | None = None) -> None:
        """Show the newest entry of ``log`` unless it is older than :data:`MESSAGE_TTL_S`, or
        was logged before ``since_s`` (wall-clock s: the start of the current run, so that
        the last run's message does not stand on the new run's screen; kept when None)."""
        self._log = log
        if since_s is not None:
            self._since_s = since_s
        entry = log.newest()
        self._entry = entry if entry is not None and entry.wall_s >= self._since_s else None
        self._update(time.time() if now_s is None else now_s)

    def _age(self) -> None:
        if self._log is not None:
            self.show(self._log)

    def _update(self, now_s: float) -> None:
        e = self._entry
        text = e.line() if e is not None and now_s - e.wall_s <= MESSAGE_TTL_S else ""
        if text != self._text:
            width = self.content_region.width
            # one line before and after: same height, no layout of the whole screen needed
            same = 0 < cell_len(self._text) <= width and 0 < cell_len(text) <= width
            self._text = text
            self.refresh(layout=not same)

    def render(self) -> Content:
        """The text as literal content, wrapped; cut with an ellipsis past three lines; an
        alarm (:func:`~uvnav_tui.widgets.message_log.classify`) in reverse video."""
        width = self.content_region.width or self.size.width
        text = self._text
        limit = width * MESSAGE_LINES_MAX
        if width > 1 and len(text) > limit:
            text = text[: limit - 1] + "…"
        e = self._entry
        if text and e is not None and classify(e.text)[0] == ALARM:
            return Content.styled(text, "reverse")
        return Content(text)

"""The message line above the key hints: the newest message of the log, with its record time.

A message stays :data:`MESSAGE_TTL_S` seconds of wall time and then clears, so an old message
never hides the state of the run ("LOP Decca Red discarded" is not still shown 40 minutes
later); every message stays in the log (Statistics ▸ Messages, F2). Text is always literal.
"""

from __future__ import annotations

import time

from textual.content import Content
from textual.widget import Widget

from uvnav_tui.message_log import LogEntry, MessageLog

MESSAGE_TTL_S = 30.0
"""Wall-clock seconds a message stays on the message line."""


class MessageLine(Widget):
    """One line: ``HH:MM:SSZ text`` of the newest entry while it is fresh, else blank."""

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self._log: MessageLog | None = None
        self._entry: LogEntry | None = None
        self._text = ""

    def on_mount(self) -> None:
        """Re-check the age of the message once a second (also while nothing runs)."""
        self.set_interval(1.0, self._age, name="message-age")

    @property
    def text(self) -> str:
        """What the line shows now."""
        return self._text

    def show(self, log: MessageLog, now_s: float | None = None) -> None:
        """Show the newest entry of ``log`` unless it is older than :data:`MESSAGE_TTL_S`."""
        self._log = log
        self._entry = log.newest()
        self._update(time.time() if now_s is None else now_s)

    def _age(self) -> None:
        if self._log is not None:
            self.show(self._log)

    def _update(self, now_s: float) -> None:
        e = self._entry
        text = e.line() if e is not None and now_s - e.wall_s <= MESSAGE_TTL_S else ""
        if text != self._text:
            self._text = text
            self.refresh()

    def render(self) -> Content:
        """The text as literal content, cut with an ellipsis when wider than the line."""
        width = self.content_region.width or self.size.width
        text = self._text
        if width > 1 and len(text) > width:
            text = text[: width - 1] + "…"
        return Content(text)

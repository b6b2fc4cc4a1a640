"""The help screen (F1 everywhere, ``?`` where it types nothing): first the help on where F1 was
pressed (the dialog's fields, the highlighted menu item, the table, the page), then the keys of
every context, the topics (MPP, LSE, ``999.99``, opening a log or a live source, where files
go), the menus with their hot-keys and the page map.  Esc, F1, ``?`` or ``q`` close it; the text
is wrapped to the screen's width and scrolls with the cursor keys, so it is whole at 80×24."""

from __future__ import annotations

from textual import events
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import VerticalScroll
from textual.screen import ModalScreen
from textual.widgets import Static

from uvnav_tui.keys_help import help_text, wrap_help

TEXT_MARGIN = 6
"""Columns of the screen the help text does not use: the frame, its padding and the scroll
bar."""


class HelpScroll(VerticalScroll):
    """The focusable, scrolling body of the help screen."""


class HelpScreen(ModalScreen[None]):
    """Full-screen help over the console (the run stays interrupted while it is open)."""

    CSS_PATH = "help_screen.tcss"

    BINDINGS = [
        Binding("escape", "close", "Close", show=False, priority=True),
        Binding("f1", "close", "Close", show=False, priority=True),
        Binding("question_mark", "close", "Close", show=False, priority=True),
        Binding("q", "close", "Close", show=False, priority=True),
    ]

    def __init__(self, topic: str | None = None) -> None:
        """``topic``: the help on where F1 was pressed, shown first (None: none)."""
        super().__init__()
        self.topic = topic

    def full_text(self) -> str:
        """The help as plain, unwrapped text: the topic, then the general help."""
        general = help_text()
        if not self.topic:
            return general
        return f"Here: {self.topic.strip()}\n\n{'─' * 40}\n\n{general}"

    def compose(self) -> ComposeResult:
        """A framed, scrolling text."""
        with HelpScroll(id="help-body") as body:
            body.border_title = "Help"
            body.border_subtitle = "Esc closes  ↑↓ PgUp PgDn scroll"
            yield Static(self._wrapped(self.app.size.width), markup=False, id="help-text")

    def _wrapped(self, screen_width: int) -> str:
        return wrap_help(self.full_text(), screen_width - TEXT_MARGIN)

    def on_mount(self) -> None:
        """Keys go to the scrolling body."""
        self.query_one(HelpScroll).focus()

    def on_resize(self, event: events.Resize) -> None:
        """Wrap the text to the new width."""
        self.query_one("#help-text", Static).update(self._wrapped(event.size.width))

    def action_close(self) -> None:
        """Back to where F1 was pressed."""
        self.dismiss(None)

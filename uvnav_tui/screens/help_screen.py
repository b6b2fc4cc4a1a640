"""The help screen (F1 or ``?``): keys of every context, the menus with their hot-keys and the
page map.  Esc, F1, ``?`` or ``q`` close it; the text scrolls with the cursor keys, so it is
usable at 80×24."""

from __future__ import annotations

from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import VerticalScroll
from textual.screen import ModalScreen
from textual.widgets import Static

from uvnav_tui.keys_help import help_text


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

    def compose(self) -> ComposeResult:
        """A framed, scrolling text."""
        with HelpScroll(id="help-body") as body:
            body.border_title = "Help"
            body.border_subtitle = "Esc closes  ↑↓ PgUp PgDn scroll"
            yield Static(help_text(), markup=False, id="help-text")

    def on_mount(self) -> None:
        """Keys go to the scrolling body."""
        self.query_one(HelpScroll).focus()

    def action_close(self) -> None:
        """Back to where F1 was pressed."""
        self.dismiss(None)

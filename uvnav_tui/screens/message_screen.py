"""Statistics ▸ Messages (F2): the whole message log, scrollable, closed with Esc.

Every message of the engine (per cycle, with the cycle's record time), the data checks (bad
``.RUN`` records) and the console (commands, hardcopies) since the console started, grouped
(alarm, warning, information; repeats as ``×37 in 10 min``; what to do under each; the start and
end of each run marked); the run is interrupted while it is open, as for any menu or dialog.
↑ ↓ PgUp PgDn Home End scroll; W shows only alarms and warnings, A everything again.
"""

from __future__ import annotations

from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Vertical
from textual.screen import ModalScreen
from textual.widgets import Static

from uvnav_tui.widgets.message_log import ALARM, LOG_LIMIT, WARNING, MessageLog
from uvnav_tui.widgets.message_panel import MessageLogView


class MessageScreen(ModalScreen[None]):
    """The log in a frame over the page; Esc, F2 or Q closes it."""

    CSS_PATH = ["message_screen.tcss", "../widgets/message_panel.tcss"]
    BINDINGS = [
        Binding("escape", "close", "Close"),
        Binding("f2", "close", "Close", show=False),
        Binding("q", "close", "Close", show=False),
        Binding("w", "levels('warning')", "Alarms and warnings", show=False),
        Binding("a", "levels('all')", "All", show=False),
    ]

    def __init__(self, log: MessageLog) -> None:
        super().__init__()
        self.log_data = log

    def compose(self) -> ComposeResult:
        """Frame, log view and a key line."""
        with Vertical(id="message-frame") as frame:
            frame.border_title = "Statistics ▸ Messages"
            yield MessageLogView(id="message-log", grouped=True, mark_times=True)
            yield Static(self._keys_text(), id="message-keys", markup=False)

    def _keys_text(self, only: bool = False) -> str:
        """The line under the log: counts, what is shown and the keys."""
        shown = "alarms and warnings (A: all)" if only else "all (W: alarms and warnings only)"
        return (f"{len(self.log_data)} messages (the last {LOG_LIMIT} kept), repeats grouped; "
                f"{shown}   ↑ ↓ PgUp PgDn Home End   Esc closes")

    def action_levels(self, which: str) -> None:
        """W: only alarms and warnings; A: everything."""
        only = which == "warning"
        self.query_one(MessageLogView).show_levels(
            frozenset((ALARM, WARNING)) if only else None)
        self.query_one("#message-keys", Static).update(self._keys_text(only))

    def on_mount(self) -> None:
        """Fill the view and give it the keyboard (scrolled to the newest line)."""
        view = self.query_one(MessageLogView)
        view.sync(self.log_data)
        view.focus()
        self.set_interval(0.5, lambda: view.sync(self.log_data), name="message-sync")

    def action_close(self) -> None:
        """Back to the page."""
        self.dismiss(None)

"""Statistics ▸ Messages (F2): the whole message log, scrollable, closed with Esc.

Every message of the engine (per cycle, with the cycle's record time), the data checks (bad
``.RUN`` records) and the console (commands, hardcopies) since the console started, grouped
(alarm, warning, information; repeats as ``×37 in 10 min``; what to do under each; the start and
end of each run marked); the run is interrupted while it is open, as for any menu or dialog.
↑ ↓ PgUp PgDn Home End scroll.
"""

from __future__ import annotations

from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Vertical
from textual.screen import ModalScreen
from textual.widgets import Static

from uvnav_tui.widgets.message_log import LOG_LIMIT, MessageLog
from uvnav_tui.widgets.message_panel import MessageLogView


class MessageScreen(ModalScreen[None]):
    """The log in a frame over the page; Esc, F2 or Q closes it."""

    CSS_PATH = ["message_screen.tcss", "../widgets/message_panel.tcss"]
    BINDINGS = [
        Binding("escape", "close", "Close"),
        Binding("f2", "close", "Close", show=False),
        Binding("q", "close", "Close", show=False),
    ]

    def __init__(self, log: MessageLog) -> None:
        super().__init__()
        self.log_data = log

    def compose(self) -> ComposeResult:
        """Frame, log view and a key line."""
        with Vertical(id="message-frame") as frame:
            frame.border_title = "Statistics ▸ Messages"
            yield MessageLogView(id="message-log", grouped=True, mark_times=True)
            yield Static(f"{len(self.log_data)} messages (the last {LOG_LIMIT} are kept), "
                         "repeats grouped   ↑ ↓ PgUp PgDn Home End scroll   Esc closes",
                         id="message-keys", markup=False)

    def on_mount(self) -> None:
        """Fill the view and give it the keyboard (scrolled to the newest line)."""
        view = self.query_one(MessageLogView)
        view.sync(self.log_data)
        view.focus()
        self.set_interval(0.5, lambda: view.sync(self.log_data), name="message-sync")

    def action_close(self) -> None:
        """Back to the page."""
        self.dismiss(None)

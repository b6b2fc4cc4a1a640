"""A full-page table over the console (Kalman ▸ Predict. results, Kalman ▸ Smoothing).

Esc or Return closes it; the run stays interrupted while it is open.
"""

from __future__ import annotations

from collections.abc import Sequence

from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Vertical
from textual.screen import ModalScreen
from textual.widgets import DataTable, Static


class TableScreen(ModalScreen[None]):
    """Title, a note line and a read-only table."""

    CSS_PATH = "table_screen.tcss"

    BINDINGS = [
        Binding("escape", "close", "Close", show=False),
        Binding("enter", "close", "Close", show=False),
    ]

    def __init__(self, title: str, note: str, columns: Sequence[str],
                 rows: Sequence[Sequence[str]]) -> None:
        super().__init__()
        self.title_text = title
        self.note = note
        self.columns = list(columns)
        self.rows = [list(r) for r in rows]

    def compose(self) -> ComposeResult:
        """Frame with the table."""
        with Vertical(classes="table-frame") as frame:
            frame.border_title = self.title_text
            frame.border_subtitle = "Esc closes"
            yield Static(self.note, classes="table-note")
            yield DataTable(id="table", zebra_stripes=False, cursor_type="row")

    def on_mount(self) -> None:
        """Fill the table."""
        table = self.query_one(DataTable)
        table.add_columns(*self.columns)
        table.add_rows(self.rows)
        table.focus()

    def action_close(self) -> None:
        """Back to the page."""
        self.dismiss(None)

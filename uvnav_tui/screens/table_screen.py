"""A full-page table over the console (Kalman ▸ Predict. results, Kalman ▸ Smoothing).

Esc or Return closes it; the run stays interrupted while it is open.  The menus work over it
(F10, Alt+letter): Edit ▸ Hardcopy saves the table itself, named after what it shows
(``…_Predict``, ``…_Smoothing``); any other menu item closes the table first.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from textual.actions import SkipAction
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Vertical
from textual.screen import ModalScreen
from textual.widgets import DataTable, Static

from uvnav_tui.keys_help import menu_key_bindings
from uvnav_tui.menus import visible_bar


class TableScreen(ModalScreen[None]):
    """Title, a note line and a read-only table."""

    CSS_PATH = "table_screen.tcss"

    BINDINGS = [
        Binding("escape", "close", "Close", show=False, priority=True),
        Binding("enter", "close", "Close", show=False, priority=True),
        *menu_key_bindings(),
    ]

    def __init__(self, title: str, note: str, columns: Sequence[str],
                 rows: Sequence[Sequence[str]], *, hardcopy_name: str = "Table") -> None:
        super().__init__()
        self.hardcopy_name = hardcopy_name
        """What a hardcopy of this table is named after (``Predict``, ``Smoothing``)."""
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

    def action_open_menu(self, index: int) -> None:
        """F10: the menu bar over the table."""
        app: Any = self.app
        app.open_menu(index)

    def action_open_hot(self, key: str) -> None:
        """Alt+letter: the bar menu with that hot-key (skipped if none is visible)."""
        app: Any = self.app
        for i, item in enumerate(visible_bar(app.dev_mode)):
            if item.key == key:
                app.open_menu(i)
                return
        raise SkipAction()

    def action_close(self) -> None:
        """Back to the page."""
        self.dismiss(None)

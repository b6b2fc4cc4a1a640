"""Kalman ▸ Filtering: the navigation filter on/off (default ON; L7638–7641)."""

from __future__ import annotations

from textual.app import ComposeResult
from textual.widgets import Checkbox, Static

from uvnav_tui.dialogs.dialog import Dialog
from uvnav_tui.widgets.toggles import GlyphCheckbox


class FilteringDialog(Dialog[bool]):
    """Dismissed with the new on/off state."""

    TITLE = "Kalman ▸ Filtering"
    HELP = """
Kalman filtering on (Space toggles): the MPP is the filter's estimate; off, it is the \
least-squares fix (LSE) or the dead reckoning.
"""

    def __init__(self, on: bool) -> None:
        super().__init__()
        self.on = on

    def compose_body(self) -> ComposeResult:
        """One switch and the thesis' advice."""
        yield GlyphCheckbox("Kalman filtering on", self.on, id="filter-on", compact=True)
        yield Static("The filter combines the model and bounded-sensor prediction with the LSE;"
                     " it must be on when submerged.", classes="dialog-note")

    def on_mount(self) -> None:
        """Focus the switch."""
        self.query_one(Checkbox).focus()

    def collect(self) -> bool | None:
        """The switch state."""
        return self.query_one(Checkbox).value

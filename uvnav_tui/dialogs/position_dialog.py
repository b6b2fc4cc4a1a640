"""Setup ▸ Params ▸ DR Pos: a new dead-reckoning position (thesis L5473, L6524; §5.6 forms)."""

from __future__ import annotations

from textual.app import ComposeResult
from textual.widgets import Static

from engine.api import parse_position
from uvnav_tui.dialogs.dialog import POSITION_HELP, Dialog
from uvnav_tui.widgets.validated_field import ValidatedField


class PositionDialog(Dialog[tuple[float, float]]):
    """Dismissed with (lat, lon) in degrees on the working datum."""

    TITLE = "Setup ▸ Params ▸ DR Pos"
    HELP = f"""
A new dead-reckoning position on the working datum; the filter restarts from it.
DR position: {POSITION_HELP}
OK with the pre-filled MPP unchanged changes nothing.
"""

    def __init__(self, current: str) -> None:
        super().__init__()
        self.current = current

    def compose_body(self) -> ComposeResult:
        """One position field, pre-filled with the current MPP."""
        yield ValidatedField("DR position", self.current, parse_position, id="dr-position")
        yield Static("e.g. 52 50 00.000 N 004 30 00.000 E, 52 50.0 N 4 30.0 E, 52.8 N 4.5 E",
                     classes="dialog-note")

    def on_mount(self) -> None:
        """Cursor in the field."""
        self.query_one(ValidatedField).focus_input()

    def collect(self) -> tuple[float, float] | None:
        """(lat, lon) if the position is valid."""
        if self.first_invalid() is not None:
            return None
        lat, lon = self.query_one(ValidatedField).parsed
        return float(lat), float(lon)

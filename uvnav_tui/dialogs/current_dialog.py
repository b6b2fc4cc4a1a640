"""Setup ▸ Params ▸ Current: current speed (knots) and direction (the set, degrees; L5474)."""

from __future__ import annotations

from textual.app import ComposeResult

from engine.api import parse_direction_deg, parse_speed_kn
from uvnav_tui.dialogs.dialog import NUMBER_HELP, Dialog
from uvnav_tui.widgets.validated_field import ValidatedField, number_text


class CurrentDialog(Dialog[tuple[float, float]]):
    """Dismissed with (set in degrees, speed in knots)."""

    TITLE = "Setup ▸ Params ▸ Current"
    HELP = f"""
The current the dead reckoning assumes.
Current speed (kn): 0 to 60.   Current direction (°): the set, towards which the water flows, \
0 to 360 (360 is 0). {NUMBER_HELP}
"""

    def __init__(self, set_deg: float, speed_kn: float) -> None:
        super().__init__()
        self.set_deg = set_deg
        self.speed_kn = speed_kn

    def compose_body(self) -> ComposeResult:
        """Speed and direction fields."""
        yield ValidatedField("Current speed (kn)", number_text(self.speed_kn), parse_speed_kn,
                             id="current-speed")
        yield ValidatedField("Current direction (°)", number_text(self.set_deg),
                             parse_direction_deg, id="current-set")

    def on_mount(self) -> None:
        """Cursor in the speed field."""
        self.query_one("#current-speed", ValidatedField).focus_input()

    def collect(self) -> tuple[float, float] | None:
        """(set, speed) if both are valid."""
        if self.first_invalid() is not None:
            return None
        speed = self.query_one("#current-speed", ValidatedField).value_or(self.speed_kn)
        set_deg = self.query_one("#current-set", ValidatedField).value_or(self.set_deg)
        return float(set_deg), float(speed)

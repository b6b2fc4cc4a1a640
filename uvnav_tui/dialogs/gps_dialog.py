"""Setup ▸ Systems ▸ GPS: switch on/off and choose the receiver, C/A or P code (L5424, L8758)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from textual.app import ComposeResult
from textual.containers import Horizontal
from textual.widgets import Checkbox, Label, RadioSet

from engine import api
from engine.api import GpsConfig
from uvnav_tui.dialogs.dialog import Dialog
from uvnav_tui.widgets.toggles import GlyphCheckbox, GlyphRadioButton

if TYPE_CHECKING:
    from engine.api import SetGps

RECEIVERS = (("C/A", "C/A code (SPS)"), ("P", "P code (PPS)"))


class GpsDialog(Dialog["SetGps"]):
    """Space toggles, ←/→ choose the receiver; dismissed with the :class:`SetGps` command."""

    TITLE = "Setup ▸ Systems ▸ GPS"
    HELP = """
GPS on (Space toggles) and the receiver: C/A code or P code (← → choose); the receiver sets the \
a priori σ of the GPS LOPs.
"""

    def __init__(self, gps: GpsConfig) -> None:
        super().__init__()
        self.gps = gps

    def compose_body(self) -> ComposeResult:
        """On/off and receiver type."""
        yield GlyphCheckbox("GPS on", self.gps.on, id="gps-on", compact=True)
        with Horizontal(classes="dialog-row"):
            yield Label("Receiver", classes="row-label")
            with RadioSet(id="gps-receiver", compact=True, classes="inline-radio"):
                for code, label in RECEIVERS:
                    yield GlyphRadioButton(label, value=code == self.gps.receiver,
                                           id=f"rx-{code[0]}")

    def on_mount(self) -> None:
        """Focus the switch."""
        self.query_one("#gps-on", Checkbox).focus()

    def collect(self) -> SetGps | None:
        """The command for the chosen settings."""
        on = self.query_one("#gps-on", Checkbox).value
        index = self.query_one("#gps-receiver", RadioSet).pressed_index
        receiver = RECEIVERS[index][0] if index >= 0 else self.gps.receiver
        return api.SetGps(on=on, receiver=receiver)

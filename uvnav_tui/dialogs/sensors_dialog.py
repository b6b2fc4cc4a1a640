"""Setup ▸ Sensors: switch the bounded sensors on/off (thesis L5430–5432).

Gyro and log are assumed always on; switching either off shows the warning
``Gyro and log must stay switched on !`` (the switch is still allowed: the engine then reports
that no MPP can be computed). Sensors that are not connected are shown but cannot be switched.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from textual import on
from textual.app import ComposeResult
from textual.containers import Horizontal
from textual.widgets import Checkbox, Label

from engine import api
from engine.api import SensorsConfig
from uvnav_tui.dialogs.dialog import Dialog
from uvnav_tui.widgets.toggles import GlyphCheckbox

if TYPE_CHECKING:
    from engine.api import SetSensor

SENSORS = (
    ("gyro", "Gyro compass"),
    ("log", "Log"),
    ("rudder", "Rudder angle"),
    ("inclinometer", "Inclinometer"),
    ("pressure", "Pressure sensor"),
    ("echosounder", "Echo sounder"),
)
GYRO_LOG_MESSAGE = "Gyro and log must stay switched on !"


class SensorsDialog(Dialog["tuple[SetSensor, ...]"]):
    """Dismissed with one :class:`SetSensor` per changed sensor."""

    TITLE = "Setup ▸ Sensors"
    HELP = """
The bounded sensors on or off (Space toggles): gyro, log, rudder, inclinometer, pressure, \
echo sounder; "not connected" ones cannot be switched. Gyro and log must stay on.
"""

    def __init__(self, sensors: SensorsConfig) -> None:
        super().__init__()
        self.sensors = sensors

    def compose_body(self) -> ComposeResult:
        """One row per sensor."""
        for name, label in SENSORS:
            state = getattr(self.sensors, name)
            with Horizontal(classes="dialog-row"):
                yield Label(label, classes="row-label")
                if state == "n/a":
                    yield Label("not connected", id=f"sensor-{name}")
                else:
                    yield GlyphCheckbox("on", state == "on", id=f"sensor-{name}", compact=True)

    def on_mount(self) -> None:
        """Focus the first switch."""
        self.query(Checkbox).first().focus()

    @on(Checkbox.Changed)
    def _changed(self, event: Checkbox.Changed) -> None:
        event.stop()
        self._warn()

    def _warn(self) -> None:
        off = [box for box in self.query(Checkbox)
               if box.id in ("sensor-gyro", "sensor-log") and not box.value]
        self.set_message(GYRO_LOG_MESSAGE if off else "")

    def collect(self) -> tuple[SetSensor, ...] | None:
        """Commands for the sensors whose state changed."""
        out = []
        for name, _label in SENSORS:
            if getattr(self.sensors, name) == "n/a":
                continue
            state = "on" if self.query_one(f"#sensor-{name}", Checkbox).value else "off"
            if state != getattr(self.sensors, name):
                out.append(api.SetSensor(name, state))
        return tuple(out)

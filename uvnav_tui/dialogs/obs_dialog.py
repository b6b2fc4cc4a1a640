"""Obs ▸ Bearing / Distance / Radar: a manual observation to a charted station (L5436–5450).

Station name and coordinates (geodetic, working datum), then the bearing (degrees true) and the
sensor that took it (compass repeater, periscope or radar), the radar distance (nautical miles,
1 nm = 1852 m) or both for Radar, which enters the station only once. σ comes from the run's
``lsq.sigma_*`` settings. The observations are used in the next cycle only.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from textual.app import ComposeResult
from textual.containers import Horizontal
from textual.widgets import Label, RadioSet

from engine import api
from engine.api import InputError, LsqConfig, parse_bearing_deg, parse_distance_nm, parse_position
from uvnav_tui.dialogs.dialog import NUMBER_HELP, POSITION_HELP, Dialog
from uvnav_tui.widgets.toggles import GlyphRadioButton
from uvnav_tui.widgets.validated_field import ValidatedField

if TYPE_CHECKING:
    from engine.api import AddObservation, ManualObservation

NM_M = 1852.0
STATION_MESSAGE = "Wrong station name !"
BEARING_SENSORS = (
    ("compass repeater", "Compass repeater"),
    ("periscope", "Periscope"),
    ("radar", "Radar"),
)


def parse_station(text: str) -> str:
    """A station name: any non-blank text."""
    name = text.strip()
    if not name:
        raise InputError(STATION_MESSAGE, field="station", text=text)
    return name


def bearing_sigma(lsq: LsqConfig, sensor: str) -> float:
    """σ (degrees) of a bearing taken with ``sensor``."""
    return {
        "compass repeater": lsq.sigma_compass_deg,
        "periscope": lsq.sigma_periscope_deg,
        "radar": lsq.sigma_radar_bearing_deg,
    }[sensor]


class ObsDialog(Dialog["AddObservation"]):
    """``kind`` is "bearing", "distance" or "radar"; dismissed with :class:`AddObservation`."""

    CANCEL_IF_UNCHANGED = False

    def __init__(self, kind: str, lsq: LsqConfig) -> None:
        super().__init__()
        self.kind = kind
        self.lsq = lsq
        self.TITLE = f"Obs ▸ {kind.capitalize()}"

    def field_help(self) -> str:
        """What the fields of this kind of observation mean and accept."""
        lines = [
            "A manual observation to a charted station, used in the next cycle only.",
            "Station name: any text (shown in messages and on the position plot).",
            "Station position: the station's charted position on the working datum; "
            + POSITION_HELP,
        ]
        if self.kind in ("bearing", "radar"):
            lines.append("Bearing (° true): 0 (north) clockwise to 360.")
        if self.kind in ("distance", "radar"):
            lines.append("Distance (nm): nautical miles (1 nm = 1852 m), more than 0, at most "
                         "10800 (half the Earth's circumference).")
        if self.kind == "bearing":
            lines.append("Taken with: compass repeater, periscope or radar (← → choose); the "
                         "sensor sets the bearing's σ ([lsq] sigma_*).")
        lines.append(NUMBER_HELP)
        return "\n".join(lines)

    def compose_body(self) -> ComposeResult:
        """Station, coordinates, then the observed value(s) and the sensor."""
        yield ValidatedField("Station name", "", parse_station, id="obs-station")
        yield ValidatedField("Station position", "", parse_position, id="obs-position")
        if self.kind in ("bearing", "radar"):
            yield ValidatedField("Bearing (° true)", "", parse_bearing_deg, id="obs-bearing")
        if self.kind in ("distance", "radar"):
            yield ValidatedField("Distance (nm)", "", parse_distance_nm, id="obs-distance")
        if self.kind == "bearing":
            with Horizontal(classes="dialog-row"):
                yield Label("Taken with", classes="row-label")
                with RadioSet(id="obs-sensor", compact=True, classes="inline-radio"):
                    for i, (_name, label) in enumerate(BEARING_SENSORS):
                        yield GlyphRadioButton(label, value=i == 0)

    def on_mount(self) -> None:
        """Cursor in the station name."""
        self.query_one("#obs-station", ValidatedField).focus_input()

    def _value(self, field: str) -> object:
        return self.query_one(f"#obs-{field}", ValidatedField).parsed

    def collect(self) -> AddObservation | None:
        """The observation(s), or None if a field is wrong."""
        if self.first_invalid() is not None:
            return None
        station = str(self._value("station"))
        lat, lon = self._value("position")  # type: ignore[misc]
        obs: list[ManualObservation] = []
        if self.kind in ("bearing", "radar"):
            sensor = "radar"
            if self.kind == "bearing":
                index = self.query_one("#obs-sensor", RadioSet).pressed_index
                sensor = BEARING_SENSORS[max(index, 0)][0]
            obs.append(api.ManualObservation("bearing", station, lat, lon,
                                         float(self._value("bearing")),  # type: ignore[arg-type]
                                         bearing_sigma(self.lsq, sensor), sensor))
        if self.kind in ("distance", "radar"):
            metres = float(self._value("distance")) * NM_M  # type: ignore[arg-type]
            obs.append(api.ManualObservation("distance", station, lat, lon, metres,
                                         self.lsq.sigma_radar_range_m, "radar"))
        return api.AddObservation(tuple(obs))

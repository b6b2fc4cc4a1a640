"""Manual bearings and distances (the Obs menu) behind the systems seam.

Each observation is to a charted station (geodetic on the working datum): a bearing (degrees
true, ship → station) or a distance (metres). Both are metric rows on the TM grid (thesis ch. 5,
A5.9–A5.27; the spheroidal distance of A5.10/A5.13; THEORY §4.1): a bearing's O − C is the angle
times the distance, its σ the angular σ times the distance; a distance is spheroidal (grid
chord over the line scale factor).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from engine.geodesy.angles import wrap_pi
from engine.geodesy.ellipsoidal import line_scale_factor, mean_radius_sq
from engine.systems.base import (
    EVAL_ERRORS,
    CycleInputs,
    LopReading,
    ObservationError,
    Point,
    SystemReading,
    lop_azimuth_deg,
    set_row,
)

MAX_BRR = 5
"""Most bearing/distance observations in one fix (slots BRR1 … BRR5, Pg 821)."""


@dataclass(frozen=True, slots=True)
class ManualObservation:
    """An Obs-menu observation to a charted station (geodetic on the working datum).

    ``kind`` is "bearing" (``value`` degrees true, ship → station) or "distance" (``value``
    metres); ``sigma`` is degrees for a bearing and metres for a distance; ``sensor`` names the
    instrument (compass repeater, periscope, radar).
    """

    kind: str
    station: str
    lat_deg: float
    lon_deg: float
    value: float
    sigma: float
    sensor: str = ""


@dataclass(frozen=True, slots=True)
class _Station:
    obs: ManualObservation
    x_m: float
    y_m: float


class _ManualObservations:
    """The rows of the queued bearings and distances, one slot each in input order."""

    messages: tuple[str, ...] = ()

    def __init__(self, stations: Sequence[_Station]) -> None:
        self.stations = stations

    def available(self) -> list[bool]:
        return [True] * len(self.stations) + [False] * (MAX_BRR - len(self.stations))

    def linearise(self, p: Point, slot0: int, A: list[float], b: list[float],
                  Cl: np.ndarray) -> None:
        x0, y0 = p.x, p.y
        lat0, lon0 = p.latlon
        for i, st in enumerate(self.stations):
            slot = slot0 + i
            dxs, dys = x0 - st.x_m, y0 - st.y_m
            d0 = math.hypot(dxs, dys)
            o = st.obs
            if o.kind == "bearing":
                az, _ = p.geodesic.azimuth_distance(lat0, lon0, o.lat_deg, o.lon_deg)
                set_row(A, slot, dys / d0, -dxs / d0)
                b[slot] = d0 * wrap_pi(math.radians(o.value - az))
                Cl[slot, slot] = (math.radians(o.sigma) * d0) ** 2
            else:
                rm2 = mean_radius_sq(p.grid.ellipsoid, lat0, o.lat_deg)
                set_row(A, slot, dxs / d0, dys / d0)
                b[slot] = o.value - d0 / line_scale_factor(x0, st.x_m, rm2)
                Cl[slot, slot] = o.sigma**2

    def readings(self, p: Point) -> list[LopReading]:
        lat, lon = p.latlon
        x_hat, y_hat = p.x, p.y
        rows = []
        for i, st in enumerate(self.stations):
            o = st.obs
            if o.kind == "bearing":
                calc, _ = p.geodesic.azimuth_distance(lat, lon, o.lat_deg, o.lon_deg)
                gradient = (y_hat - st.y_m, -(x_hat - st.x_m))
                pattern = "Brg"
            else:
                rm2 = mean_radius_sq(p.grid.ellipsoid, lat, o.lat_deg)
                calc = math.hypot(x_hat - st.x_m, y_hat - st.y_m) / line_scale_factor(
                    x_hat, st.x_m, rm2
                )
                gradient = (x_hat - st.x_m, y_hat - st.y_m)
                pattern = "Dist"
            rows.append(LopReading(i, o.sensor or o.kind, pattern, o.value, 0.0, calc,
                                   lop_azimuth_deg(gradient)))
        return rows

    def nearest_station_m(self, p: Point, used: Sequence[bool]) -> float:
        near = math.inf
        for i, st in enumerate(self.stations):
            if used[i]:
                near = min(near, math.hypot(p.x - st.x_m, p.y - st.y_m))
        return near


class ManualSystem:
    """Obs-menu bearings and distances behind :class:`engine.systems.base.NavSystem` (no config
    table: the operator queues the observations for the next cycle; no systems-string letter)."""

    name = "manual"
    letter = ""
    column: int | None = None
    slot_labels = tuple(f"BRR{i + 1}" for i in range(MAX_BRR))

    def is_on(self, config: Any) -> bool:
        return False

    def fix_source(self, config: Any) -> tuple[object, ...]:
        """Never a source of its own: occasional observations, independent of each other."""
        return ()

    def read(self, inputs: CycleInputs) -> SystemReading:
        """The observations queued for this cycle (``NavState.pending_obs``)."""
        obs = tuple(inputs.nav.pending_obs)
        if not obs:
            return _NOTHING  # the usual cycle: the one (immutable) reading of nothing
        return SystemReading(obs, (), None, True)

    def observations(self, value: Sequence[ManualObservation] | None,
                     p0: Point) -> _ManualObservations | None:
        """The first :data:`MAX_BRR` observations with their stations on the grid; raises
        :class:`ObservationError` for a station that cannot be projected."""
        if not value:
            return None
        try:
            stations = [_Station(o, *p0.grid.forward(o.lat_deg, o.lon_deg))
                        for o in value[:MAX_BRR]]
        except EVAL_ERRORS as exc:
            raise ObservationError(f"station position cannot be projected: {exc}") from exc
        return _ManualObservations(stations)

    def row_name(self, index: int, value: Sequence[ManualObservation] | None) -> str | None:
        """``<sensor> Brg|Dist <station>`` as typed (``periscope Brg Heiloo``)."""
        if value is None or not 0 <= index < len(value):
            return None
        o = value[index]
        kind = "Brg" if o.kind == "bearing" else "Dist"
        return f"{o.sensor or o.kind} {kind} {o.station}"


_NOTHING = SystemReading((), (), None, False)
""":meth:`ManualSystem.read` of a cycle without observations (frozen: one for every cycle)."""

MANUAL = ManualSystem()

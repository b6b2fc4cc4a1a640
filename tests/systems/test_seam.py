"""Adding a navigation system is one module behind ``engine.systems.base.NavSystem`` plus its
entry in the registry: here a toy acoustic-range system (ranges to seabed transponders at known
grid positions, as a newcomer would write it in ``engine/systems/acoustic.py``) is registered
and the unchanged fix takes its rows, names them and shows them per system."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import pytest

from engine.geodesy.ellipsoid import Ellipsoid
from engine.geodesy.ellipsoidal import GeodesicSolver
from engine.geodesy.tmgrid import TMGrid
from engine.lsq.fix import GpsFix, compute_fix, lop_name
from engine.systems import registry
from engine.systems.base import (
    CycleInputs,
    LopReading,
    Point,
    SystemReading,
    lop_azimuth_deg,
    set_row,
)

HAYFORD = Ellipsoid("Hayford", 6378388.0, 297.0)
GRID = TMGrid(HAYFORD, 5.0)
GEOD = GeodesicSolver(HAYFORD)
Transponder = tuple[float, float, float, float]
"""Grid x, y (m) of a transponder, the measured range (m, horizontal) and its σ (m)."""


class _Ranges:
    """The toy system's rows: planar horizontal ranges, one slot each."""

    messages: tuple[str, ...] = ()

    def __init__(self, transponders: Sequence[Transponder]) -> None:
        self.transponders = transponders

    def available(self) -> list[bool]:
        return [True] * len(self.transponders) + [False] * (2 - len(self.transponders))

    def linearise(self, p: Point, slot0: int, A: list[float], b: list[float],
                  Cl: np.ndarray) -> None:
        for i, (tx, ty, rng, sigma) in enumerate(self.transponders):
            dx, dy = p.x - tx, p.y - ty
            d = math.hypot(dx, dy)
            set_row(A, slot0 + i, dx / d, dy / d)
            b[slot0 + i] = rng - d
            Cl[slot0 + i, slot0 + i] = sigma**2

    def readings(self, p: Point) -> list[LopReading]:
        return [LopReading(i, "Acoustic", "Rng", rng, 0.0, math.hypot(p.x - tx, p.y - ty),
                           lop_azimuth_deg((p.x - tx, p.y - ty)))
                for i, (tx, ty, rng, _s) in enumerate(self.transponders)]

    def nearest_station_m(self, p: Point, used: Sequence[bool]) -> float:
        return min((math.hypot(p.x - tx, p.y - ty)
                    for used_i, (tx, ty, _r, _s) in zip(used, self.transponders, strict=False)
                    if used_i), default=math.inf)


class AcousticSystem:
    name = "acoustic"
    letter = ""
    column: int | None = None
    slot_labels = ("AR1", "AR2")

    def is_on(self, config: Any) -> bool:
        return False

    def fix_source(self, config: Any) -> tuple[object, ...]:
        return ()

    def read(self, inputs: CycleInputs) -> SystemReading:
        return SystemReading()

    def observations(self, value: Sequence[Transponder] | None, p0: Point) -> _Ranges | None:
        return _Ranges(value) if value else None

    def row_name(self, index: int, value: Any) -> str | None:
        return f"Acoustic {self.slot_labels[index]}"


def _scene() -> tuple[float, float, GpsFix, list[Transponder]]:
    x, y = GRID.forward(52.8, 4.7)
    lat, lon = GRID.inverse(x, y)
    gps = GpsFix(lat, lon, x, y, 2500.0)
    ranges = [(x + 3000.0, y + 1000.0, math.hypot(3000.0, 1000.0), 2.0),
              (x - 1500.0, y + 2500.0, math.hypot(1500.0, 2500.0), 2.0)]
    return x, y, gps, ranges


def test_a_registered_system_takes_part_in_the_fix(monkeypatch: pytest.MonkeyPatch) -> None:
    x, y, gps, ranges = _scene()
    monkeypatch.setattr(registry, "SYSTEMS", (*registry.SYSTEMS, AcousticSystem()))
    assert registry.slots_of("acoustic") == range(10, 12) and registry.n_slots() == 12
    f = compute_fix(GRID, GEOD, (x + 400.0, y - 300.0), gps=gps, readings={"acoustic": ranges})
    assert f.ok and f.n_used == 4
    assert (f.x_m, f.y_m) == pytest.approx((x, y), abs=1e-3)
    rows = f.rows_of("acoustic")
    assert [r.slot for r in rows] == [10, 11] and all(r.used for r in rows)
    assert rows[0].calc == pytest.approx(ranges[0][2], abs=1e-3)
    assert lop_name(11) == "Acoustic AR2"
    assert f.tested is not None and f.tested.adjustment.Cl.shape == (12, 12)


def test_an_unregistered_system_is_not_read(monkeypatch: pytest.MonkeyPatch) -> None:
    x, y, gps, ranges = _scene()
    f = compute_fix(GRID, GEOD, (x + 400.0, y - 300.0), gps=gps, readings={"acoustic": ranges})
    assert f.ok and f.n_used == 2 and f.rows_of("gps")


def test_manual_reading_of_nothing_is_one_constant() -> None:
    """The Obs-menu system's reading of a cycle without observations is always the same frozen
    value (nothing to observe), equal to what its constructor makes; with observations queued
    it reads them."""
    from types import SimpleNamespace

    from engine.systems.manual import MANUAL, ManualObservation

    def inputs(pending: Any) -> Any:
        return SimpleNamespace(nav=SimpleNamespace(pending_obs=pending))

    empty = MANUAL.read(inputs(()))
    assert empty == SystemReading((), (), None, False) and empty.value == ()
    assert MANUAL.read(inputs([])) is empty and not empty.observes
    obs = ManualObservation("bearing", "Heiloo", 52.6, 4.7, 45.0, 1.0)
    r = MANUAL.read(inputs([obs]))
    assert r == SystemReading((obs,), (), None, True)

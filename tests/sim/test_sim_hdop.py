"""The simulator's optional per-epoch HDOP (issue 13; docs/SIMULATOR.md ``gps.hdop``): the
records carry HDOP and quality, and the GPS error per axis has σ = HDOP × UERE / √2, the
receiver weight's own formula, so truth and weights agree."""

from __future__ import annotations

import math

import numpy as np
import pytest

from engine.geodesy.ellipsoid import WGS84
from engine.geodesy.tmgrid import TMGrid
from engine.run.session import read_data_dir
from engine.sim.scenario import parse_scenario_text
from engine.sim.simulate import simulate
from tests.paths import DATA

SCENARIO = """
start_time = "2026-07-01T08:00:00Z"
datum = "WGS84"
start_position = "52 50 00 N 004 30 00 E"
[decca]
on = false
[gps]
{gps}
[[leg]]
duration_s = 4000
course_deg = 45.0
speed_kn = 6.0
"""


def _errors(gps: str, seed: int = 5) -> tuple[np.ndarray, list]:
    sc = parse_scenario_text(SCENARIO.format(gps=gps))
    data = read_data_dir(DATA)
    pairs = list(simulate(sc, *data, seed))
    # Truth and reading on one grid (WGS84 working datum and GPS datum: no shift).
    grid = TMGrid(WGS84.ellipsoid, 5.0)
    err = []
    for truth, rec in pairs:
        tx, ty = grid.forward(truth.lat_deg, truth.lon_deg)
        gx, gy = grid.forward(rec.gps_lat_deg, rec.gps_lon_deg)
        err.append((gx - tx, gy - ty))
    return np.array(err), [rec for _t, rec in pairs]


def test_hdop_records_and_error_sigma() -> None:
    """All-white errors (white_frac 1) at a constant HDOP 1.4, UERE 3 m: σ per axis should be
    1.4·3/√2 = 2.970 m; the sample σ of 4000 independent draws is within 5 % of it (its
    relative standard error is 1/√(2·4000) = 1.1 %, so 5 % is 4.5 standard errors)."""
    err, recs = _errors("hdop = 1.4\nuere_m = 3.0\nquality = 2\nwhite_frac = 1.0")
    assert {r.gps_hdop for r in recs} == {1.4} and {r.gps_quality for r in recs} == {2}
    expected = 1.4 * 3.0 / math.sqrt(2.0)
    for axis in (0, 1):
        assert float(np.std(err[:, axis])) == pytest.approx(expected, rel=0.05)


def test_hdop_swings_and_is_reported_to_a_tenth() -> None:
    _err, recs = _errors("hdop = 1.0\nhdop_swing = 0.5\nhdop_period_s = 1000.0")
    h = np.array([r.gps_hdop for r in recs])
    assert h.min() == 0.5 and h.max() == 1.5  # 1.0 × (1 ± 0.5), at least 0.5
    assert np.allclose(h * 10.0, np.round(h * 10.0))
    assert recs[250].gps_hdop == 1.5  # sin(2π·250/1000) = 1


def test_without_hdop_the_records_are_the_1993_ones() -> None:
    _err, recs = _errors("sigma_m = 35.0")
    assert all(r.gps_hdop is None and r.gps_quality is None for r in recs)

"""Decca lane integrity (issue 11): integer lanes only from a position that can settle them, a
GPS check every cycle, lane slips corrected and said, GPS never voted out silently.

The lane model is the engine's (engine.systems.decca, thesis eq. 4.9, A5.11–A5.12); the truth for
each
case is built here from it at a chosen point, so every expected total is exact: the count at
the truth is N, the reading is N mod 1, and the right total is N itself.
"""

from __future__ import annotations

import dataclasses
import math
from datetime import UTC, datetime, timedelta

import numpy as np
import pytest

from engine.geodesy.tmgrid import central_meridian_deg
from engine.io.runfile import RunRecord
from engine.run.config import load_config
from engine.run.cycle import NavState, RunContext, build_context, gps_voted_out
from engine.run.session import read_data_dir
from engine.systems.decca import (
    LANE_RULE,
    LANE_SIGMA_MAX,
    ChainOnGrid,
    LaneRule,
    LaneSource,
    decca_geometry,
    decca_totals,
    lane_sigma,
)
from tests.paths import DATA

T0 = datetime(1992, 9, 17, 11, 0, 0, tzinfo=UTC)


@pytest.fixture(scope="module")
def setup() -> tuple[RunContext, ChainOnGrid, float, float, np.ndarray, np.ndarray]:
    """DEMO.toml's context (chain 9B, ED50), the chain on the grid, a true point 20 km off the
    start, its true total lane counts and the lane gradients there (lanes/m)."""
    cfg = load_config(DATA / "DEMO.toml")
    ctx = build_context(cfg, *read_data_dir(DATA))
    cm = central_meridian_deg(cfg.dr_lon_deg)
    placed = ctx.placed_chain(cm)
    assert placed is not None
    x0, y0 = ctx.grid(cm).forward(cfg.dr_lat_deg, cfg.dr_lon_deg)
    x, y = x0 - 15_000.0, y0 - 13_000.0
    geom = decca_geometry(placed, x, y, ctx.geodesic)
    return ctx, placed, x, y, np.array(geom.n_calc), np.array(geom.row)


def _record(n_true: np.ndarray, t: datetime) -> RunRecord:
    """Red and Green readings at the truth (Purple, entered but not selected, gives none)."""
    fr = [float(v - math.floor(v)) for v in n_true]
    return RunRecord(1, t, None, None, (fr[0], fr[1], None), 250.0, 6.0, 0.0)


def _stale_nav(n_true: np.ndarray) -> NavState:
    """Tracks last updated an hour ago (a dive) at the right lanes."""
    old = T0 - timedelta(hours=1)
    return NavState(decca_track=((float(n_true[0]), old), (float(n_true[1]), old), None))


def _decca_totals(ctx: RunContext, nav: NavState, rec: RunRecord, placed: ChainOnGrid,
                  x_start: tuple[float, float], position: LaneSource | None,
                  gps: LaneSource | None, rule: LaneRule = LANE_RULE
                  ) -> tuple[tuple[float | None, ...], tuple[object, ...], list[str], int]:
    """:func:`engine.systems.decca.decca_totals` for this record and state, as a tuple."""
    lanes = decca_totals(placed, ctx.geodesic, ctx.zone_lane, nav.decca_track, rec.decca,
                         rec.time, x_start, position, gps, rule)
    return lanes.totals, lanes.track, list(lanes.notes), lanes.slips


def _along(row: np.ndarray, metres_in_lanes: float) -> np.ndarray:
    """A grid offset (m) that moves the count by ``metres_in_lanes`` lanes along ``row``."""
    return row * metres_in_lanes / float(row @ row)


def test_lane_sigma_is_the_gradient_projection() -> None:
    """√(r C rᵀ): a gradient of 1/1000 lane/m east and 1σ 100 m east, 400 m north → 0.1 lane."""
    c = np.diag([100.0**2, 400.0**2])
    assert lane_sigma(np.array([1e-3, 0.0]), c) == pytest.approx(0.1, rel=1e-12)
    assert lane_sigma(np.array([0.0, 1e-3]), c) == pytest.approx(0.4, rel=1e-12)


def test_after_a_dive_a_drifted_dr_position_settles_no_lane(setup) -> None:  # noqa: ANN001
    """The issue's failure: after a dive the DR position is 2.4 Red lanes off (~4 km) with an
    honest 1σ of 2 km. The old code identified the lanes from it (wrong by 2, the LSE km off);
    now Red and Green stay out of the fix, with a message, until something can settle them."""
    ctx, placed, x, y, n_true, rows = setup
    off = _along(rows[0], 2.4)
    dr = LaneSource("the DR position", x + off[0], y + off[1], np.eye(2) * 2000.0**2)
    totals, track, notes, slips = _decca_totals(ctx, _stale_nav(n_true), _record(n_true, T0),
                                                placed, (dr.x_m, dr.y_m), dr, None)
    assert totals == (None, None, None) and slips == 0
    assert track == _stale_nav(n_true).decca_track  # the next record tries again
    assert sum("lane not identified after the gap" in m for m in notes) == 2, notes
    assert all("kept out of the fix until GPS" in m for m in notes)


def test_after_a_dive_gps_settles_the_lanes(setup) -> None:  # noqa: ANN001
    """Same drifted DR position, but GPS (C/A σ 50 m, ≤ 0.04 lane along either gradient here)
    is in the record: the lanes come from GPS, exactly the true totals."""
    ctx, placed, x, y, n_true, rows = setup
    off = _along(rows[0], 2.4)
    dr = LaneSource("the DR position", x + off[0], y + off[1], np.eye(2) * 2000.0**2)
    gps = LaneSource("GPS", x + 40.0, y - 30.0, np.eye(2) * 2500.0)
    assert 3 * lane_sigma(rows[0], gps.cov) < 0.5 and 3 * lane_sigma(rows[1], gps.cov) < 0.5
    totals, _track, notes, slips = _decca_totals(ctx, _stale_nav(n_true), _record(n_true, T0),
                                                 placed, (dr.x_m, dr.y_m), dr, gps)
    assert totals[0] == pytest.approx(n_true[0], abs=1e-9)
    assert totals[1] == pytest.approx(n_true[1], abs=1e-9)
    assert slips == 0 and sum("identified again from GPS" in m for m in notes) == 2


def test_a_precise_dr_position_may_settle_the_lane(setup) -> None:  # noqa: ANN001
    """Without GPS a DR position 0.3 lane off whose 3σ along the gradient is below half a lane
    (σ = 0.1 lane) is good enough: it gives the nearest lane, the right one."""
    ctx, placed, x, y, n_true, rows = setup
    off = _along(rows[0], 0.3)
    sigma_m = 0.1 / float(np.linalg.norm(rows[0]))
    dr = LaneSource("the DR position", x + off[0], y + off[1], np.eye(2) * sigma_m**2)
    assert lane_sigma(rows[0], dr.cov) <= LANE_SIGMA_MAX
    totals, _t, notes, _s = _decca_totals(ctx, _stale_nav(n_true), _record(n_true, T0), placed,
                                          (dr.x_m, dr.y_m), dr, None)
    assert totals[0] == pytest.approx(n_true[0], abs=1e-9)
    assert any("red: lane identified again from the DR position" in m for m in notes)


def test_a_lane_slip_is_corrected_from_gps_and_said(setup) -> None:  # noqa: ANN001
    """A track one Red lane high and one Green lane low (a slip while tracking) against GPS in
    the same record: both corrected to the true totals, two slips counted and said (``[decca]
    lane_check = "off"``; under "dia" a track without a step that could slip it is held in
    doubt instead, tests/systems/test_lane_check.py)."""
    ctx, placed, x, y, n_true, _rows = setup
    now = T0 - timedelta(seconds=1)
    nav = NavState(decca_track=((float(n_true[0]) + 1.0, now), (float(n_true[1]) - 1.0, now),
                                None))
    gps = LaneSource("GPS", x - 25.0, y + 60.0, np.eye(2) * 2500.0)
    totals, track, notes, slips = _decca_totals(ctx, nav, _record(n_true, T0), placed, (x, y),
                                                None, gps, LaneRule(check=False))
    assert slips == 2
    assert totals[0] == pytest.approx(n_true[0], abs=1e-9)
    assert totals[1] == pytest.approx(n_true[1], abs=1e-9)
    assert track[0] is not None and track[0][0] == totals[0]
    assert any("red: lane slip of +1 lane corrected from GPS" in m for m in notes), notes
    assert any("green: lane slip of -1 lane corrected from GPS" in m for m in notes), notes


def test_no_slip_no_message(setup) -> None:  # noqa: ANN001
    """A right track with GPS present: nothing to say."""
    ctx, placed, x, y, n_true, _rows = setup
    now = T0 - timedelta(seconds=1)
    nav = NavState(decca_track=((float(n_true[0]), now), (float(n_true[1]), now), None))
    gps = LaneSource("GPS", x + 70.0, y + 70.0, np.eye(2) * 2500.0)
    _totals, _track, notes, slips = _decca_totals(ctx, nav, _record(n_true, T0), placed, (x, y),
                                                  None, gps)
    assert (notes, slips) == ([], 0)


def test_gps_voted_out_for_decca_is_said() -> None:
    """A fix whose w-test rejects a GPS LOP (or proposes to, under 'A') while Decca lanes are in
    it carries a message; without Decca, or rejecting a Decca LOP, it does not."""
    from engine.lsq.fix import FixResult

    base = FixResult(True, None, 0.0, 0.0, 52.0, 4.0, np.eye(2), None, "I", 4, 1.0, 1.0, (),
                     None, decca_observed=(44.9, 276.1, None))
    assert gps_voted_out(base) is None
    assert "GPS has no lane ambiguity" in (gps_voted_out(
        dataclasses.replace(base, rejected_slots=(1,))) or "")
    assert gps_voted_out(dataclasses.replace(base, candidate_slot=0)) is not None
    assert gps_voted_out(dataclasses.replace(base, rejected_slots=(2,))) is None
    assert gps_voted_out(dataclasses.replace(base, rejected_slots=(0,),
                                             decca_observed=(None, None, None))) is None

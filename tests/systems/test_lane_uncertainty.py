"""Decca lane identification that knows its own uncertainty (THEORY §3.3): whole lanes only as
the integer-bootstrapping success rate and the ratio test allow, with the Decca reading's own
(night) σ in the float ambiguity's VCV, conditioned on the lanes still tracked.

Independent figures: the success rate of one ambiguity is 2Φ(1/(2σ)) − 1 (Teunissen 1998), for
σ = 0.2 lane 2·0.99379033 − 1 = 0.98758067 (Φ(2.5) from the normal table); the ratio test's q
values are hand calculations. The Decca cases build their truth from the engine's lane model at a
chosen point (as tests/systems/test_lane_integrity.py): the count at the truth is N and a
reading with a sky-wave error e is (N + e) mod 1.
"""

from __future__ import annotations

import math
from datetime import timedelta

import numpy as np
import pytest

from engine.io.runfile import RunRecord
from engine.systems.decca import (
    LANE_RULE,
    LANE_SIGMA_MAX,
    LaneRule,
    LaneSource,
    decca_totals,
    fix_lanes,
    lane_sigma,
)
from tests.systems.test_lane_integrity import T0, _along, setup  # noqa: F401 (fixture)


def _reading(n: np.ndarray, err: tuple[float, float]) -> RunRecord:
    """Red and Green fractions of counts ``n`` + ``err`` (lanes; Purple not read)."""
    fr = [float((v + e) - math.floor(v + e)) for v, e in zip(n[:2], err, strict=True)]
    return RunRecord(1, T0, None, None, (fr[0], fr[1], None), 250.0, 6.0, 0.0)


def _totals(ctx, placed, track, rec, x_start, position, gps, rule):  # noqa: ANN001, ANN202
    return decca_totals(placed, ctx.geodesic, ctx.zone_lane, track, rec.decca, rec.time,
                        x_start, position, gps, rule)


def test_success_rate_of_one_lane_is_the_normal_table() -> None:
    """σ = 0.2 lane: 2Φ(2.5) − 1 = 0.98758067; taken at a required 0.98, not at 0.999."""
    a = np.array([3.1, math.nan, math.nan])
    q = np.diag([0.04, 1.0, 1.0])
    got = fix_lanes(a, q, [0], {}, LaneRule(success=0.98, ratio=1.0))
    assert got.lanes == {0: 3}
    assert got.success == pytest.approx(0.98758067, abs=1e-7)
    assert fix_lanes(a, q, [0], {}, LANE_RULE).lanes == {}


def test_ratio_test_declines_a_float_near_half_a_lane() -> None:
    """σ = 0.05 lane (success rate 1 − 2·10⁻²³) but the float 0.45 lane from a whole lane:
    q₁ = (0.45/0.05)² = 81, q₂ = (0.55/0.05)² = 121, ratio 1.494 < 3: not taken."""
    a = np.array([7.45, math.nan, math.nan])
    got = fix_lanes(a, np.diag([0.0025, 1.0, 1.0]), [0], {}, LANE_RULE)
    assert got.lanes == {} and got.ratio == pytest.approx(121.0 / 81.0, rel=1e-9)
    assert "ratio test" in (got.why or "")


def test_a_tracked_lane_settles_a_correlated_one() -> None:
    """Redundancy: the position error is common to both floats (Q = 0.25·[[1, ρ], [ρ, 1]] +
    10⁻⁴·I, ρ = 0.999, a 0.7-lane error in both). Alone pattern 1 (σ 0.5 lane) cannot be taken;
    given pattern 0's tracked lane z₀ = 4 the conditional float is 9 + 0.7 − (0.24985/0.2501)·0.7
    = 9.0007 with σ ≈ 0.017 lane: lane 9."""
    q = 0.25 * np.array([[1.0, 0.999, 0.0], [0.999, 1.0, 0.0], [0.0, 0.0, 1.0]])
    q = q + 1e-4 * np.eye(3)
    a = np.array([4.7, 9.7, math.nan])
    assert fix_lanes(a, q, [1], {}, LANE_RULE).lanes == {}
    got = fix_lanes(a, q, [1], {0: 4}, LANE_RULE)
    assert got.lanes == {1: 9}
    assert got.success > 0.999


def test_after_a_dive_a_dr_position_that_passed_the_sigma_rule_gives_no_wrong_lane(
        setup) -> None:  # noqa: ANN001, F811
    """The MPP after a dive is 0.45 Red lane (870 m) off with a P of 1σ 0.16 lane along Red's
    gradient: the old rule (σ ≤ 1/6 lane, the position alone) took the nearest lane, and with
    a sky-wave error of −0.1 lane in the reading that is one lane high. With the Decca night σ
    (0.112 lane here) in the float's VCV the success rate is 0.997 < 0.999: Red stays out of
    the fix with a "lane in doubt" note; no wrong lane is used."""
    ctx, placed, x, y, n_true, rows = setup
    off = _along(rows[0], 0.45)
    sigma_m = 0.16 / float(np.linalg.norm(rows[0]))
    dr = LaneSource("the DR position", x + off[0], y + off[1], np.eye(2) * sigma_m**2)
    assert lane_sigma(rows[0], dr.cov) <= LANE_SIGMA_MAX
    old = T0 - timedelta(hours=1)
    track = ((float(n_true[0]), old), (float(n_true[1]), old), None)
    rec = _reading(n_true, (-0.1, 0.0))
    before = _totals(ctx, placed, track, rec, (dr.x_m, dr.y_m), dr, None, None)
    assert before.totals[0] == pytest.approx(n_true[0] + 0.9, abs=1e-9)  # the old blunder
    now = _totals(ctx, placed, track, rec, (dr.x_m, dr.y_m), dr, None, LANE_RULE)
    assert now.totals[0] is None
    assert now.track[0] == track[0]  # the next record tries again
    assert any("red: lane not identified after the gap" in m and "lane in doubt" in m
               for m in now.notes), now.notes


def test_gps_does_not_flip_a_right_track_at_night(setup) -> None:  # noqa: ANN001, F811
    """A right Red track, a sky-wave error of −0.25 lane in the reading and a poor GPS fix
    (1σ 0.15 lane along Red, 0.3 lane off): the old check called it a slip of −1 and moved the
    count one lane high. Now the joint GPS identification fails (success rate 0.99 with the
    Decca night σ) and the suspect pattern is kept out of this fix; the track goes on."""
    ctx, placed, x, y, n_true, rows = setup
    now_t = T0 - timedelta(seconds=2)
    track = ((float(n_true[0]) - 0.25, now_t), (float(n_true[1]), now_t), None)
    off = _along(rows[0], 0.3)
    sigma_m = 0.15 / float(np.linalg.norm(rows[0]))
    gps = LaneSource("GPS", x + off[0], y + off[1], np.eye(2) * sigma_m**2)
    rec = _reading(n_true, (-0.25, 0.0))
    before = _totals(ctx, placed, track, rec, (x, y), None, gps, None)
    assert before.slips == 1 and before.totals[0] == pytest.approx(n_true[0] + 0.75, abs=1e-9)
    now = _totals(ctx, placed, track, rec, (x, y), None, gps, LANE_RULE)
    assert now.slips == 0 and now.totals[0] is None
    assert now.totals[1] == pytest.approx(n_true[1], abs=1e-9)
    assert now.track[0] is not None
    assert now.track[0][0] == pytest.approx(n_true[0] - 0.25, abs=1e-9)
    assert any("red: lane in doubt" in m for m in now.notes), now.notes


def test_gps_with_a_tight_vcv_identifies_as_before(setup) -> None:  # noqa: ANN001, F811
    """GPS 1σ 50 m (≤ 0.03 lane along either gradient) after a dive: both lanes taken, the
    same totals to the bit as the old rule gave, and a real slip is still corrected (``lane_check
    = "off"``: under "dia" a slip shows as a step, tests/systems/test_lane_check.py)."""
    ctx, placed, x, y, n_true, rows = setup
    gps = LaneSource("GPS", x + 40.0, y - 30.0, np.eye(2) * 2500.0)
    old = T0 - timedelta(hours=1)
    track = ((float(n_true[0]), old), (float(n_true[1]), old), None)
    rec = _reading(n_true, (0.05, -0.03))
    before = _totals(ctx, placed, track, rec, (x, y), None, gps, None)
    now = _totals(ctx, placed, track, rec, (x, y), None, gps, LANE_RULE)
    assert now.totals == before.totals
    assert now.totals[0] == pytest.approx(n_true[0] + 0.05, abs=1e-9)
    assert now.totals[1] == pytest.approx(n_true[1] - 0.03, abs=1e-9)
    now_t = T0 - timedelta(seconds=2)
    slipped = ((float(n_true[0]) + 1.05, now_t), (float(n_true[1]) - 0.03, now_t), None)
    got = _totals(ctx, placed, slipped, rec, (x, y), None, gps, LaneRule(check=False))
    assert got.slips == 1 and got.totals[0] == pytest.approx(n_true[0] + 0.05, abs=1e-9)

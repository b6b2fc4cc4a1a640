"""Decca lane checks of ``[decca] lane_check = "dia"`` (THEORY §3.3, "Checking the lanes in
use"): the start-up zone/lane entries tested against the reference position, a continuous track
never moved to another lane by GPS (a disagreement is the reading's error or GPS's: the pattern
is held in doubt until GPS confirms its lane), a step that may have slipped the count identified
again as after a gap.

Independent figures: χ²₁(0.999) = 10.828 (the chi-square table; = 3.2905², the two-sided normal
quantile of α = 0.001); the q values of :func:`check_lanes` are hand calculations with a
diagonal VCV. The Decca cases build their truth from the engine's lane model at a chosen point
(as tests/systems/test_lane_integrity.py): the count at the truth is N, and a reading with a
sky-wave error e is (N + e) mod 1.
"""

from __future__ import annotations

import math
from datetime import timedelta

import numpy as np
import pytest

from engine.io.operator_input import ZONE_LETTERS, zone_lane_of
from engine.io.runfile import RunRecord
from engine.run.config import config_from_data
from engine.systems.decca import (
    DOUBT,
    LANE_RULE,
    PATTERNS,
    LaneRule,
    LaneSource,
    check_lanes,
    decca_totals,
    lr_critical,
)
from tests.systems.test_lane_integrity import T0, setup  # noqa: F401 (fixture)

LITERAL = LaneRule(check=False)
"""The lane rule without the checks (``lane_check = "off"``, the thesis preset)."""


def _reading(n: np.ndarray, err: tuple[float, float]) -> RunRecord:
    """Red and Green fractions of counts ``n`` + ``err`` (lanes; Purple not read)."""
    fr = [float((v + e) - math.floor(v + e)) for v, e in zip(n[:2], err, strict=True)]
    return RunRecord(1, T0, None, None, (fr[0], fr[1], None), 250.0, 6.0, 0.0)


def _entry(total: float, i: int) -> tuple[int, int]:
    """The (zone index, whole lane) an operator enters for a count ``total`` of pattern i."""
    letter, lane = zone_lane_of(total, PATTERNS[i])
    return ZONE_LETTERS.index(letter), math.floor(lane)


def _totals(ctx, placed, zone_lane, track, rec, x_start, position, gps, rule):  # noqa: ANN001, ANN202
    return decca_totals(placed, ctx.geodesic, zone_lane, track, rec.decca, rec.time, x_start,
                        position, gps, rule)


def test_lr_critical_is_the_chi_square_table() -> None:
    """χ²₁ at 1 − α = 0.999: 10.828 (table); at 0.99: 6.635."""
    assert lr_critical(0.999) == pytest.approx(10.828, abs=1e-3)
    assert lr_critical(0.99) == pytest.approx(6.635, abs=1e-3)


def test_check_lanes_changes_a_clear_one_lane_error() -> None:
    """Q = 0.01·I (σ 0.1 lane), floats 3.02 and 8.05, lanes under test 3 and 7:
    q₀ = (0.02² + 1.05²)/0.01 = 110.29, pattern 1 + 1 gives (0.02² + 0.05²)/0.01 = 0.29, the
    next best (pattern 1 + 2) 90.29 ≥ 3 · 0.29: changed, likelihood ratio 110.0."""
    a = np.array([3.02, 8.05, math.nan])
    q = np.diag([0.01, 0.01, 1.0])
    got = check_lanes(a, q, {0: 3, 1: 7}, [0, 1], LANE_RULE)
    assert (got.verdict, got.pattern, got.shift) == ("changed", 1, 1)
    assert got.lr == pytest.approx(110.0, abs=1e-9)


def test_check_lanes_keeps_what_it_cannot_reject() -> None:
    """Floats 3.02 and 7.55: q₀ = (0.0004 + 0.3025)/0.01 = 30.29, the best alternative
    (pattern 1 + 1) (0.0004 + 0.2025)/0.01 = 20.29: a likelihood ratio of 10.0 < 10.83, kept."""
    a = np.array([3.02, 7.55, math.nan])
    got = check_lanes(a, np.diag([0.01, 0.01, 1.0]), {0: 3, 1: 7}, [0, 1], LANE_RULE)
    assert got.verdict == "kept"


def test_check_lanes_puts_in_doubt_what_the_ratio_cannot_separate() -> None:
    """Floats 3.0 and 8.5, lanes 3 and 7: q₀ = 1.5²/0.01 = 225 rejects them, but pattern 1 + 1
    and + 2 both give 0.5²/0.01 = 25 (ratio 1 < 3): pattern 1 in doubt, likelihood ratio 200."""
    a = np.array([3.0, 8.5, math.nan])
    got = check_lanes(a, np.diag([0.01, 0.01, 1.0]), {0: 3, 1: 7}, [0, 1], LANE_RULE)
    assert (got.verdict, got.doubt) == ("doubt", (1,))
    assert got.lr == pytest.approx(200.0, abs=1e-9)


def test_a_start_up_entry_one_lane_off_is_corrected_against_the_position(setup) -> None:  # noqa: ANN001, F811
    """The operator enters Red right and Green one lane low (the chart's lane while the reading,
    0.12 lane beyond it, already crossed the lane line); the filter's position is at the truth
    with 1σ 100 m, no GPS. Literal (thesis preset): Green is used one lane low. Checked: Green
    is moved up one lane, and a note names the pattern, the entered and the used lane."""
    ctx, placed, x, y, n_true, _rows = setup
    rec = _reading(n_true, (0.02, 0.12))
    green_read = float(n_true[1]) + 0.12
    zone_lane = (_entry(float(n_true[0]), 0), _entry(green_read - 1.0, 1), None)
    dr = LaneSource("the DR position", x, y, np.eye(2) * 100.0**2)
    track = (None, None, None)
    literal = _totals(ctx, placed, zone_lane, track, rec, (x, y), dr, None, LITERAL)
    assert literal.totals[1] == pytest.approx(green_read - 1.0, abs=1e-9)
    got = _totals(ctx, placed, zone_lane, track, rec, (x, y), dr, None, LANE_RULE)
    assert got.totals[0] == pytest.approx(float(n_true[0]) + 0.02, abs=1e-9)
    assert got.totals[1] == pytest.approx(green_read, abs=1e-9)
    assert got.track[1] is not None and got.track[1][0] == got.totals[1]
    note = [m for m in got.notes if m.startswith("Decca green: the zone/lane entered")]
    assert len(note) == 1, got.notes
    entered, used = zone_lane_of(green_read - 1.0, "green"), zone_lane_of(green_read, "green")
    assert f"{entered[0]}{math.floor(entered[1])}" in note[0]
    assert f"{used[0]}{math.floor(used[1])}" in note[0]
    assert "1 lane low" in note[0]


def test_a_right_entry_is_left_alone(setup) -> None:  # noqa: ANN001, F811
    """Both entries right, readings 0.1 lane off, the position 1σ 1 km: no note, nothing moved."""
    ctx, placed, x, y, n_true, _rows = setup
    rec = _reading(n_true, (-0.1, 0.1))
    zone_lane = (_entry(float(n_true[0]) - 0.1, 0), _entry(float(n_true[1]) + 0.1, 1), None)
    dr = LaneSource("the DR position", x + 300.0, y - 200.0, np.eye(2) * 1000.0**2)
    got = _totals(ctx, placed, zone_lane, (None, None, None), rec, (x, y), dr, None, LANE_RULE)
    assert got.totals[0] == pytest.approx(float(n_true[0]) - 0.1, abs=1e-9)
    assert got.totals[1] == pytest.approx(float(n_true[1]) + 0.1, abs=1e-9)
    assert list(got.notes) == []


def test_gps_does_not_move_a_continuous_track(setup) -> None:  # noqa: ANN001, F811
    """A right Red track whose reading has a night sky-wave error of −0.3 lane (the last record
    2 s ago read the same), and a GPS fix 0.45 Red lane the other way (Green's count unchanged)
    with a stated 1σ of 10 m:
    GPS puts the count 0.75 lane above its float and the next lane 0.25 below, so the lane rule
    settles the 'slip' (ratio 9) and the literal rule moves the right count one lane up. Checked:
    the track cannot have slipped (no step), so Red is held in doubt — left out of the fix, its
    count tracked on — and back once GPS confirms its lane."""
    ctx, placed, x, y, n_true, rows = setup
    err = (-0.3, 0.0)
    rec = _reading(n_true, err)
    before = T0 - timedelta(seconds=2)
    track = ((float(n_true[0]) - 0.3, before), (float(n_true[1]), before), None)
    off = np.linalg.solve(rows[:2], [0.45, 0.0])  # Red +0.45 lane, Green unchanged
    gps = LaneSource("GPS", x + float(off[0]), y + float(off[1]), np.eye(2) * 100.0)
    zl = ctx.zone_lane
    literal = _totals(ctx, placed, zl, track, rec, (x, y), None, gps, LITERAL)
    assert literal.slips == 1
    assert literal.totals[0] == pytest.approx(float(n_true[0]) + 0.7, abs=1e-9)  # the blunder
    got = _totals(ctx, placed, zl, track, rec, (x, y), None, gps, LANE_RULE)
    assert got.slips == 0 and got.totals[0] is None
    assert got.totals[1] == pytest.approx(float(n_true[1]), abs=1e-9)
    assert got.track[0] is not None and got.track[0][2] == DOUBT
    assert got.track[0][0] == pytest.approx(float(n_true[0]) - 0.3, abs=1e-9)
    assert any(m.startswith("Decca red: lane in doubt") for m in got.notes), got.notes
    # GPS far off again: still in doubt; GPS at the truth: confirmed, back in the fix.
    later = T0 + timedelta(seconds=2)
    rec2 = RunRecord(2, later, None, None, rec.decca, 250.0, 6.0, 0.0)
    again = _totals(ctx, placed, zl, got.track, rec2, (x, y), None, gps, LANE_RULE)
    assert again.totals[0] is None and again.track[0][2] == DOUBT  # type: ignore[index]
    good = LaneSource("GPS", x, y, np.eye(2) * 100.0)
    back = _totals(ctx, placed, zl, again.track, rec2, (x, y), None, good, LANE_RULE)
    assert back.totals[0] == pytest.approx(float(n_true[0]) - 0.3, abs=1e-9)
    assert back.track[0] is not None and len(back.track[0]) == 2
    assert any("red: lane in doubt confirmed from GPS" in m for m in back.notes), back.notes


def test_a_step_that_may_have_slipped_is_identified_again(setup) -> None:  # noqa: ANN001, F811
    """The reading moves 0.6 lane down between two records (a sky-wave phase jump at twilight);
    the tracker takes the nearer wrap, 0.4 lane up, and counts one lane too many. Literal: used
    one lane high. Checked: a step of more than a quarter lane may have slipped the count, so the
    lane is identified again as after a gap — from the filter's position (1σ 20 m) here."""
    ctx, placed, x, y, n_true, _rows = setup
    rec = _reading(n_true, (0.0, 0.0))
    before = T0 - timedelta(seconds=2)
    track = ((float(n_true[0]) + 0.6, before), (float(n_true[1]), before), None)
    dr = LaneSource("the DR position", x, y, np.eye(2) * 400.0)
    zl = ctx.zone_lane
    literal = _totals(ctx, placed, zl, track, rec, (x, y), dr, None, LITERAL)
    assert literal.totals[0] == pytest.approx(float(n_true[0]) + 1.0, abs=1e-9)
    got = _totals(ctx, placed, zl, track, rec, (x, y), dr, None, LANE_RULE)
    assert got.totals[0] == pytest.approx(float(n_true[0]), abs=1e-9)
    assert got.totals[1] == pytest.approx(float(n_true[1]), abs=1e-9)
    assert any("red: lane identified again from the DR position" in m for m in got.notes)


def test_lane_check_defaults_and_the_thesis_preset() -> None:
    """``[decca] lane_check`` is "dia" by default, "off" under ``filter.preset = "thesis"``
    unless the file sets it."""
    base = {"decca": {"on": False}}
    assert config_from_data(base).decca.lane_check == "dia"
    thesis = {**base, "filter": {"preset": "thesis"}}
    assert config_from_data(thesis).decca.lane_check == "off"
    both = {"decca": {"on": False, "lane_check": "dia"}, "filter": {"preset": "thesis"}}
    assert config_from_data(both).decca.lane_check == "dia"


def test_the_compiled_tracking_declines_a_step_that_may_slip() -> None:
    """The compiled tracking (engine.fast.decca) tracks every count it is given, so it is not
    asked where a reading moved more than a quarter lane from its track (the reference
    identifies that lane again): 0.30 lane is declined, 0.20 is not, a wrap across 0/1 is a
    small step (0.95 → 0.05 is +0.10)."""
    from engine.fast.decca import _big_step

    t = T0 - timedelta(seconds=2)
    assert _big_step(((10.40, t), None, None), (0.10, None, None))
    assert not _big_step(((10.40, t), None, None), (0.20, None, None))
    assert not _big_step(((10.95, t), (3.5, t), None), (0.05, 0.45, None))
    assert not _big_step((None, None, None), (0.9, 0.1, 0.5))

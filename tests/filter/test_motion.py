"""The COG/SOG stand-in's learnt process noise (engine.filter.motion) on synthetic COG/SOG
streams: a straight course learns a small rate of turn, a zig-zag keeps the cap, a random walk
of known spectral density is learnt without bias (E[Δψ²] = q·T, hand calculation), and bad COG
(at SOG ≈ 0, a 180° glitch) is bounded and counted."""

from __future__ import annotations

import math
from datetime import UTC, datetime, timedelta

import numpy as np
import pytest

from engine.filter.motion import (
    MIN_S,
    MotionSettings,
    MotionState,
    applied,
    learn,
    start,
    turn_rate_max_deg_s,
)

T0 = datetime(2013, 7, 31, 8, 0, tzinfo=UTC)
CAP_TURN = 3.0  # deg/s, the surface vessel's ψ̇_max
CAP_A2 = 0.25**2 / 3.0 * (1.0 + 4 * 0.01 - 0.75)  # thesis eq. 6.35, 6.04e-3 m²/s⁴
SETTINGS = MotionSettings.of(CAP_TURN, CAP_A2)


def _run(cogs: list[float | None], sogs: list[float | None], usable: list[bool] | None = None,
         state: MotionState | None = None) -> MotionState:
    s = start(SETTINGS) if state is None else state
    for k, (c, v) in enumerate(zip(cogs, sogs, strict=True)):
        s = learn(s, SETTINGS, T0 + timedelta(seconds=k), c, v,
                  True if usable is None else usable[k])
    return s


def test_caps_until_min_s_then_floors_and_caps() -> None:
    """The caps hold until MIN_S seconds are learnt; the floors are the stand-in's noise over a
    lag: 2·(3°)²/300 s = 0.06 deg²/s (ψ̇_max 0.49°/s), and σ_a² at least a third of its cap."""
    assert SETTINGS.turn_floor == pytest.approx(2 * 9.0 / 300.0)
    assert SETTINGS.accel_floor == pytest.approx(CAP_A2 / 3.0)
    n = int(MIN_S) - 100
    s = _run([45.0] * n, [3.0] * n)
    assert s.turn_rate_max_deg_s == CAP_TURN and s.sigma_a2 == pytest.approx(CAP_A2)
    assert applied(s, SETTINGS) == (SETTINGS.turn_cap, SETTINGS.accel_cap)


def test_straight_course_learns_a_small_rate_of_turn() -> None:
    """40 minutes on a steady course (COG noise 1°, SOG 3 m/s ± 0.05): below the cap after
    MIN_S, at the floors (the noise alone is 2·1²/300 = 0.0067 deg²/s < 0.06)."""
    rng = np.random.default_rng(1)
    n = 2400
    cogs = list(45.0 + rng.normal(0.0, 1.0, n))
    sogs = list(3.0 + rng.normal(0.0, 0.05, n))
    s = _run(cogs, sogs)
    assert s.n > 20 and s.clipped == 0 and s.skipped == 0
    assert s.turn_rate_max_deg_s == pytest.approx(turn_rate_max_deg_s(SETTINGS.turn_floor))
    assert s.turn_rate_max_deg_s == pytest.approx(2 * math.sqrt(0.06))  # 0.49°/s
    assert s.sigma_a2 == pytest.approx(SETTINGS.accel_floor)


def test_zigzag_keeps_the_cap() -> None:
    """Tacks of 90° every 5 minutes (a beat to windward): E[Δψ²]/T over any lag of 300 s is
    about 90²/300 = 27 deg²/s, far above the cap's 2.25: the cap stays."""
    n = 3600
    cogs = [45.0 if (k // 300) % 2 == 0 else 135.0 for k in range(n)]
    s = _run(cogs, [3.0] * n)
    assert s.turn_rate_max_deg_s == pytest.approx(CAP_TURN)
    assert s.q_turn > 5 * SETTINGS.turn_cap


def test_random_walk_is_learnt_without_bias() -> None:
    """A course that is a random walk of spectral density q = 0.5 deg²/s (σ_ψ̇ 0.71°/s): the
    mean of Δψ²/T is q (E[Δψ²] = q·T), within the scatter of an hour's window (±25 %)."""
    rng = np.random.default_rng(7)
    q = 0.5
    n = 6 * 3600
    cogs = list(np.cumsum(rng.normal(0.0, math.sqrt(q), n)) % 360.0)
    s = _run(cogs, [3.0] * n)
    assert s.q_turn == pytest.approx(q, rel=0.25)
    assert s.turn_rate_max_deg_s == pytest.approx(2 * math.sqrt(s.q_turn))


def test_bad_cog_is_bounded_and_counted() -> None:
    """COG that spins at SOG ≈ 0 is skipped (and counted), never learnt; one 180° glitch at
    speed is clipped (counted) and lifts the mean by at most about the cap, then decays."""
    rng = np.random.default_rng(3)
    n = 2400
    straight = _run([45.0] * n, [3.0] * n)
    spin = list(rng.uniform(0.0, 360.0, 600))
    drift = [0.1] * 600
    s = _run(spin, drift, usable=[False] * 600, state=straight)
    assert s.skipped == 600 and s.q_turn == straight.q_turn and s.n == straight.n
    # then a single wrong sentence: COG 225° for one second in a steady 45° course
    cogs = [45.0] * 1200
    cogs[600] = 225.0
    s2 = _run(cogs, [3.0] * 1200, state=straight)
    assert s2.clipped <= 1
    assert s2.q_turn <= straight.q_turn + 1.05 * SETTINGS.turn_cap
    assert math.isfinite(s2.q_turn) and s2.turn_rate_max_deg_s <= CAP_TURN
    # a non-finite value is skipped too
    s3 = learn(straight, SETTINGS, T0 + timedelta(seconds=n + 5), math.nan, 3.0, True)
    assert s3.skipped == straight.skipped + 1 and s3.q_turn == straight.q_turn


def test_outage_holds_and_gap_restarts_the_lag() -> None:
    """A record with neither COG nor SOG (an outage) changes nothing; after a gap longer than
    ``gap_s`` the change over the gap is not learnt (a course can wrap past 180°)."""
    straight = _run([45.0] * 2400, [3.0] * 2400)
    t = T0 + timedelta(seconds=2400)
    assert learn(straight, SETTINGS, t, None, None, False) is straight
    later = learn(straight, SETTINGS, t + timedelta(seconds=900), 225.0, 3.0, True)
    assert later.q_turn == straight.q_turn and later.n == straight.n
    assert later.kept == ((t + timedelta(seconds=900), 225.0, 3.0),)

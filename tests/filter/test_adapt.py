"""The fix-VCV factor the filter learns from the data (engine/filter/adapt.py, THEORY §8.17).

The statistics are drawn here from their known distributions (S² = λ_true·χ²_r/r, NIS per row
relative to the a-priori VCV = λ_true·χ²_2/2: the cycle hands over the update's NIS × the factor
its VCV carried), so the factor the estimator must reach is known independently of the engine;
the closed forms of the clipped χ² mean are checked against a Monte-Carlo mean.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from engine.filter.adapt import (
    AdaptSettings,
    AdaptState,
    clipped_chi2_mean,
    fix_nis_ratio,
    gain,
    learn_fix,
    start,
)

SETTINGS = AdaptSettings()


@pytest.mark.parametrize("dof", [1, 2, 3, 5])
def test_clipped_chi2_mean_matches_monte_carlo(dof: int) -> None:
    """E[min(χ²_d/d, 4)]: closed forms (d = 1, 2) and the quadrature (d ≥ 3) against 2·10⁶
    draws (standard error < 1e-3)."""
    rng = np.random.default_rng(7)
    x = rng.chisquare(dof, 2_000_000) / dof
    assert clipped_chi2_mean(dof, 4.0) == pytest.approx(float(np.minimum(x, 4.0).mean()),
                                                        abs=3e-3)


def _learn_s2(lam_true: float, dof: int, n: int, seed: int,
              state: AdaptState | None = None) -> AdaptState:
    rng = np.random.default_rng(seed)
    st = state or start(("GPS",))
    for s2 in lam_true * rng.chisquare(dof, n) / dof:
        st, _msg = learn_fix(st, SETTINGS, s2=float(s2), s2_dof=dof)
    return st


@pytest.mark.parametrize(("lam_true", "dof"), [(4.0, 2), (9.0, 1), (2.0, 2)])
def test_s2_channel_learns_the_true_variance_factor(lam_true: float, dof: int) -> None:
    """Fixes whose LOP errors are λ_true times their a-priori VCV: after 3000 epochs the
    factor is λ_true within 15 % (the W = 300 window's own scatter is ~8 % at 1σ)."""
    st = _learn_s2(lam_true, dof, 3000, seed=1)
    assert st.fix_factor == pytest.approx(lam_true, rel=0.15)
    assert st.n == 3000


def test_right_vcv_stays_at_the_floor() -> None:
    """With the a-priori VCV right (λ_true = 1) the factor stays within 10 % of 1 and never
    below it (λ_min = 1: the receiver class is the floor)."""
    rng = np.random.default_rng(3)
    st = start(None)
    worst = 1.0
    for s2, nis in zip(rng.chisquare(2, 3000) / 2, rng.chisquare(2, 3000) / 2, strict=True):
        st, _ = learn_fix(st, SETTINGS, s2=float(s2), s2_dof=2, nis=float(nis))
        worst = max(worst, st.fix_factor)
        assert st.fix_factor >= 1.0
    assert worst < 1.35
    assert st.fix_factor < 1.15


def test_one_blunder_does_not_inflate_everything() -> None:
    """A single S² of 10⁶ (a blunder that passed the gates) after 500 good epochs moves the
    factor by at most e^{c/W} (1 %), and 300 good epochs later it is back below 1.1."""
    st = _learn_s2(1.0, 2, 500, seed=4)
    before = st.fix_factor
    st, _ = learn_fix(st, SETTINGS, s2=1e6, s2_dof=2)
    assert st.fix_factor <= before * math.exp(4.0 / 300.0)  # (c − E[min(χ²₂/2, c)])/W
    assert st.clipped >= 1
    st = _learn_s2(1.0, 2, 300, seed=5, state=st)
    assert st.fix_factor < 1.1


def test_non_finite_statistics_are_said_and_not_learnt() -> None:
    st = _learn_s2(4.0, 2, 100, seed=6)
    for bad in (math.nan, math.inf, -1.0):
        new, msg = learn_fix(st, SETTINGS, s2=bad, s2_dof=2, nis=bad)
        assert new == st
        assert msg is not None and "not finite, not learnt" in msg


def test_runaway_factor_is_clamped_and_said_once() -> None:
    """Statistics 10⁴ times their a-priori size drive λ to its bound 100 (not beyond), and the
    message comes once, when it gets there."""
    st = start(None)
    msgs = []
    for _ in range(3000):
        st, msg = learn_fix(st, SETTINGS, s2=1e4 * st.fix_factor, s2_dof=2)
        if msg:
            msgs.append(msg)
    assert st.fix_factor == pytest.approx(100.0)
    assert st.at_bound
    assert len(msgs) == 1 and "at its bound 100" in msgs[0]
    # anti-windup: good epochs bring it down at once, not after undoing a wound-up excess
    st = _learn_s2(1.0, 2, 300, seed=8, state=st)
    assert st.fix_factor < 60.0


def test_gain_schedule() -> None:
    """A running mean for the first epochs (never faster than 1/30), a window of W later."""
    assert gain(1, SETTINGS) == pytest.approx(1 / 30)
    assert gain(100, SETTINGS) == pytest.approx(1 / 100)
    assert gain(10_000, SETTINGS) == pytest.approx(1 / 300)


def test_fix_nis_ratio_is_the_marginal_of_the_fix_rows() -> None:
    """The NIS of the fix rows of a stacked update (a depth row first), by hand: with S
    block-diagonal it is v_fᵀ S_f⁻¹ v_f / 2."""
    v = np.array([0.5, 3.0, -4.0])
    S = np.array([[2.0, 0.0, 0.0], [0.0, 9.0, 1.0], [0.0, 1.0, 16.0]])
    Sf = S[1:, 1:]
    expect = float(v[1:] @ np.linalg.solve(Sf, v[1:])) / 2
    assert fix_nis_ratio(v, S, slice(1, 3)) == pytest.approx(expect, rel=1e-12)
    assert math.isnan(fix_nis_ratio(v, -S, slice(1, 3)))


def test_settings_are_checked() -> None:
    with pytest.raises(ValueError):
        AdaptSettings(window=0.5)
    with pytest.raises(ValueError):
        AdaptSettings(fix_max=0.5)

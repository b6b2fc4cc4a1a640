"""The MSE split of ``tests.mpp_diagnose`` (docs/ASSESS.md, "Why the MPP does not beat the
LSE"), checked on a hand-made series."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.mpp_diagnose import WINDOWS, oracle, split_mse


def _series() -> tuple[np.ndarray, ...]:
    """400 s surfaced, 100 s submerged, 400 s after resurfacing, every 2 s; errors constant:
    MPP (3, 4) m, LSE (0, 4) m, its coloured part (0, 3) m; no LSE while submerged."""
    t = np.arange(0.0, 900.0, 2.0)
    phase = np.where(t < 400.0, 0, np.where(t < 500.0, 1, 2))
    n = t.size
    mpp = np.tile([3.0, 4.0], (n, 1))
    lse = np.tile([0.0, 4.0], (n, 1))
    colour = np.tile([0.0, 3.0], (n, 1))
    lse[phase == 1] = math.nan
    colour[phase == 1] = math.nan
    return t, phase, mpp, lse, colour


def test_split_by_window_adds_up() -> None:
    row = split_mse(*_series())
    assert row is not None
    # 200 surfaced + 200 after-resurfacing epochs; each |e_MPP|² − |e_LSE|² = 25 − 16 = 9 m²
    assert row["n"] == 400
    assert row["mpp"] == pytest.approx(5.0) and row["lse"] == pytest.approx(4.0)
    assert row["colour"] == pytest.approx(3.0)
    assert row["white_share"] == pytest.approx(1.0 / 16.0)
    # per stretch: 30 epochs in the first minute, 120 in minutes 1–5, 50 after 5 min
    want = {WINDOWS[0]: 9 * 30 / 400, WINDOWS[1]: 9 * 120 / 400, WINDOWS[2]: 9 * 30 / 400,
            WINDOWS[3]: 9 * 120 / 400, WINDOWS[4]: 9 * 100 / 400}
    assert row["parts"] == pytest.approx(want)
    assert sum(row["parts"].values()) == pytest.approx(5.0**2 - 4.0**2)


def test_missing_fix_restarts_the_stretch_and_nothing_surfaced_is_none() -> None:
    t, phase, mpp, lse, colour = _series()
    lse[100] = math.nan  # an outage of one epoch at 200 s: a new stretch starts at 202 s
    row = split_mse(t, phase, mpp, lse, colour)
    assert row is not None and row["n"] == 399
    # surfaced: 0–58 s and 202–260 s in the first minutes (30 + 30), 60–198 s and 262–398 s
    # in minutes 1–5 (70 + 69), none beyond; after resurfacing as before
    assert row["parts"][WINDOWS[0]] == pytest.approx(9 * 60 / 399)
    assert row["parts"][WINDOWS[1]] == pytest.approx(9 * 139 / 399)
    assert row["parts"][WINDOWS[4]] == pytest.approx(9 * 50 / 399)
    assert split_mse(t, np.ones_like(phase), mpp, lse, colour) is None


def _scenario(gps: bool, decca: bool, hdop: bool = False) -> str:
    extra = "hdop = 1.5\nuere_m = 8.0\nwhite_frac = 0.2\n" if hdop else ""
    return (f"[gps]\non = {str(gps).lower()}\nsigma_m = 30.0\ntau_s = 300.0\n"
            f"white_sigma_m = 10.0\n{extra}\n[decca]\non = {str(decca).lower()}\n"
            'chain = "9B"\ncf = 64.0\ntau_s = 500.0\n\n[sensors]\ngyro = true\n')


def test_oracle_takes_the_drawn_model() -> None:
    # GPS alone: its τ and coloured share 30² / (30² + 10²) = 0.9; with HDOP the drawn share
    assert oracle(_scenario(True, False)) == pytest.approx(
        {"fix_tau_s": 300.0, "fix_sigma_frac": 0.9})
    assert oracle(_scenario(True, False, hdop=True)) == pytest.approx(
        {"fix_tau_s": 300.0, "fix_sigma_frac": 0.8})
    assert oracle(_scenario(False, True)) == {"fix_tau_s": 500.0}
    assert oracle(_scenario(True, True)) == {"fix_tau_s": 500.0}

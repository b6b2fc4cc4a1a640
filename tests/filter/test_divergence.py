"""Recovery from a diverged filter (engine/filter/divergence.py, THEORY §8.18).

The run-level tests take the bundled demo mission (GPS only, so the LSE is the GPS fix), let the
filter settle on 600 fixes, then displace its position by 20 σ of the fix rows' innovation
(S = HPHᵀ + R) with its P left as it was: a confident, wrong filter, the state a long dive on a
wrong current leaves behind, while the fixes are good. The truth file gives the error
independently of the engine.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from engine.assess.accuracy import read_truth
from engine.filter.divergence import (
    CONSISTENT_CHI2,
    DivergenceWatch,
    RecoverSettings,
    current_inflation,
    due,
    fade_factor,
    fix_rows_test,
    fix_rows_upper,
    observe,
    settle,
)
from engine.filter.state import IX
from engine.run.config import FilterConfig
from engine.run.session import Session
from engine.run.setup import load_run_config
from tests.paths import DATA

COV = np.diag([100.0, 100.0])  # a 10-m fix (m²)
SETTINGS = RecoverSettings("reset", 5, 240.0)
AFTER_DIVE = DivergenceWatch(last_update_s=-3600.0)  # the last fix update an hour ago


def _reject(w: DivergenceWatch, t: float, fix: tuple[float, float],
            prior: tuple[float, float]) -> DivergenceWatch:
    w = observe(w, t_s=t, verdict="reject", fix_good=True, fix_xy=fix, fix_cov=COV,
                prior_xy=prior, cm_deg=3.0)
    return settle(w, prior, False)


def test_consistent_rejections_become_due_after_k() -> None:
    """A filter 500 m off after an hour's dive, moving with the fixes (1 m/s east, both): every
    fix agrees with the last once the dead-reckoned motion is taken out; the K-th rejection in a
    row is due."""
    w = AFTER_DIVE
    for k in range(1, 6):
        fix = (10.0 * k, 0.0)
        w = _reject(w, 10.0 * k, fix, (fix[0] + 500.0, 0.0))
        assert w.streak == k
        assert due(w, SETTINGS) == (k >= 5)


def test_rejections_without_a_gap_are_not_due() -> None:
    """The same run of rejections while the filter has been taking fixes every 10 s: a fix
    error slower and larger than its VCV looks the same, so the remedy waits for a gap."""
    w = DivergenceWatch(last_update_s=0.0)
    for k in range(1, 20):
        fix = (10.0 * k, 0.0)
        w = _reject(w, 10.0 * k, fix, (fix[0] + 500.0, 0.0))
        assert w.streak == k and not due(w, SETTINGS)


def test_single_blunder_is_never_due() -> None:
    """One rejected fix between accepted ones starts and ends a run of one."""
    w = AFTER_DIVE
    for k in range(50):
        if k % 7 == 3:
            w = _reject(w, float(k), (300.0, 0.0), (0.0, 0.0))
            assert w.streak == 1 and not due(w, SETTINGS)
        else:
            w = observe(w, t_s=float(k), verdict="accept", fix_good=True, fix_xy=(0.0, 0.0),
                        fix_cov=COV, prior_xy=(0.0, 0.0), cm_deg=3.0)
            assert w.streak == 0 and w.last_ok_s == float(k)


def test_rejections_that_disagree_are_not_consistent() -> None:
    """Fixes that jump ±200 m about a still filter (blunders, sky-wave scatter) each start a
    new run: 200 m against a 10-m fix is far beyond χ²₂(0.99)."""
    w = AFTER_DIVE
    for k in range(20):
        w = _reject(w, float(k), (200.0 * (-1) ** k, 0.0), (0.0, 0.0))
        assert w.streak == 1
    d = 400.0
    assert d * d / 200.0 > CONSISTENT_CHI2


def test_failed_lse_or_too_small_ends_the_run() -> None:
    """A fix that fails its own tests, or an update the test finds too good, ends the run."""
    w = DivergenceWatch()
    for k in range(4):
        w = _reject(w, float(k), (0.0, 0.0), (500.0, 0.0))
    w2 = observe(w, t_s=5.0, verdict="reject", fix_good=False, fix_xy=(0.0, 0.0), fix_cov=COV,
                 prior_xy=(500.0, 0.0), cm_deg=3.0)
    assert w2.streak == 0
    w3 = observe(w, t_s=5.0, verdict="too small", fix_good=True, fix_xy=(0.0, 0.0),
                 fix_cov=COV, prior_xy=(500.0, 0.0), cm_deg=3.0)
    assert w3.streak == 0


def test_fade_factor_and_current_inflation_by_hand() -> None:
    """λ = T/T_upper ≥ 1; (|ν|/Δt)²: 600 m over 20 min is 0.5 m/s, 0.25 m²/s²; at most
    (1 m/s)²."""
    upper = fix_rows_upper(0.05)
    assert upper == pytest.approx(7.3778 / 2.0, abs=1e-3)  # χ²₂(0.975)/2
    assert fade_factor(2.0 * upper, upper) == pytest.approx(2.0)
    assert fade_factor(1.0, upper) == 1.0
    assert current_inflation(600.0, 1200.0) == pytest.approx(0.25)
    assert current_inflation(600.0, None) == 0.0
    assert current_inflation(6000.0, 600.0) == 1.0


# --------------------------------------------------------------------------------------------
# The run: the demo mission, GPS only


def _session(tmp_path: Path, recover: str | None) -> Session:
    cfg, data = load_run_config(DATA / "DEMO.toml")
    f = cfg.filter if recover is None else dataclasses.replace(cfg.filter, recover=recover)
    cfg = cfg.replace(filter=f, decca=dataclasses.replace(cfg.decca, on=False))
    return Session(cfg, data=data, out_path=tmp_path / "run.OUT", force=True)


def _dive_off(s: Session, k_sigma: float, n: int = 300) -> float:
    """A dive of ``n`` s (records without GPS: dead reckoning only) that ends ``k_sigma`` σ of
    the last fix update's S (its fix rows) east of where the filter thinks it is, with the
    covariance it had before the dive: a current or log error the filter's P does not know
    (docs/ASSESS.md, "The worst missions and why"). Returns the offset (m)."""
    u = s.last.filter_update
    i = u.labels.index("x_LSE")
    sig = math.sqrt(float(np.linalg.eigvalsh(u.S[i:i + 2, i:i + 2]).max()))
    P_before = np.array(s.nav.filter.P)
    for _ in range(n):
        rec = s._next_record()
        assert rec is not None
        s.process(dataclasses.replace(rec, gps_lat_deg=None, gps_lon_deg=None))
    fs = s.nav.filter
    x = np.array(fs.x)
    x[IX] += k_sigma * sig
    s.nav = dataclasses.replace(s.nav, filter=dataclasses.replace(fs, x=x, P=P_before))
    return k_sigma * sig


def _errors(s: Session, n: int) -> tuple[list[float], list[str]]:
    """The MPP's horizontal error against the truth (m) and the fix gate of the next n cycles."""
    truth = read_truth(DATA / "DEMO.truth.csv")
    at = {int(t): (la, lo) for t, la, lo in zip(truth.t_ms, truth.lat_deg, truth.lon_deg,
                                                 strict=True)}
    errs, gates = [], []
    for _ in range(n):
        r = s.step()
        assert r is not None
        la, lo = at[int(r.time.timestamp() * 1000)]
        tx, ty = s.context.grid(r.cm_deg).forward(la, lo)
        errs.append(math.hypot(r.mpp.x_m - tx, r.mpp.y_m - ty))
        gates.append(r.fix_gate)
    return errs, gates


def _rms(errs: list[float]) -> float:
    return float(np.sqrt(np.mean(np.square(errs))))


def test_diverged_filter_recovers_within_k_epochs(tmp_path: Path) -> None:
    """A 5-min dive that ends 20 σ (~190 m) off with a covariance that does not know it, then
    good fixes: the default remedy re-initialises from the fix at the 5th consistent rejection,
    reported once; from 10 to 70 epochs later the MPP is no worse than after the same dive
    ending where the filter thinks (RMS within 10 %; the C/A fixes of 1992 are ~26 m RMS). The
    thesis' behaviour ("off", as before the remedy existed) stays more than 1.5 × worse for that
    minute: the fix-error states take the offset up as a fix bias and let it go over τ."""
    with _session(tmp_path, None) as s:
        s.run(max_cycles=600)
        _dive_off(s, 0.0)
        undisturbed = _rms(_errors(s, 70)[0][10:])
    with _session(tmp_path, None) as s:
        assert s.config.filter.recover == "reset"
        s.run(max_cycles=600)
        offset = _dive_off(s, 20.0)
        assert 100.0 < offset < 400.0
        errs, gates = _errors(s, 70)
        assert gates.count("recovered") == 1 and gates.index("recovered") <= 5
        assert _rms(errs[10:]) < 1.1 * undisturbed
        assert s.summary().recoveries == 1
    text = (tmp_path / "run.OUT").read_text()
    assert text.count("Filter diverged: 5 consistent fixes in a row") == 1
    with _session(tmp_path, "off") as s:
        s.run(max_cycles=600)
        _dive_off(s, 20.0)
        errs, gates = _errors(s, 70)
        assert "recovered" not in gates
        assert _rms(errs[10:]) > 1.5 * undisturbed


def test_single_blunder_fix_is_flagged_not_acted_on(tmp_path: Path) -> None:
    """After the same dive (ending where the filter thinks), the first GPS fix is 150 m north
    (a blunder, below the 30-σ gross gate): the innovation test rejects it and the filter takes
    it as the thesis does; the good fixes after it are accepted and nothing is reset."""
    with _session(tmp_path, None) as s:
        s.run(max_cycles=600)
        _dive_off(s, 0.0)
        rec = s._next_record()
        assert rec is not None and rec.gps_lat_deg is not None
        r = s.process(dataclasses.replace(rec, gps_lat_deg=rec.gps_lat_deg + 150.0 / 111_200))
        assert r is not None and r.fix_gate == "innovation"
        _errs, gates = _errors(s, 60)
        assert "recovered" not in gates
        assert s.summary().recoveries == 0


def test_thesis_preset_has_no_remedy() -> None:
    """``preset = "thesis"`` keeps the thesis' literal behaviour: the remedy is off."""
    assert FilterConfig.from_preset("thesis").recover == "off"
    assert FilterConfig().recover == "reset"


def test_fix_rows_statistic_is_the_solved_quadratic_form() -> None:
    """T = vᵀS_f⁻¹v / 2 of the fix rows by the closed-form 2×2 inverse equals numpy's solve
    (rtol 1e-12) on random positive-definite S with a depth row stacked first; a singular S_f
    gives no verdict."""
    rng = np.random.default_rng(7)
    for _ in range(200):
        a = rng.normal(size=(3, 3)) * rng.uniform(0.1, 1e3)
        S = a @ a.T + np.eye(3) * 1e-3
        v = rng.normal(size=3) * 50.0
        want = float(v[1:] @ np.linalg.solve(S[1:, 1:], v[1:])) / 2.0
        verdict, t = fix_rows_test(v, S, ("depth", "x_LSE", "y_LSE"), 3.69)
        assert t == pytest.approx(want, rel=1e-12)
        assert verdict == ("reject" if want > 3.69 else "accept")
    assert fix_rows_test(np.ones(2), np.ones((2, 2)), ("x_LSE", "y_LSE"), 3.69)[0] == ""

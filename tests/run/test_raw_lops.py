"""Raw LOPs on the too-few-LOPs path (THEORY §9.3, D20) weighted as the correlated errors they
are (:func:`engine.run.cycle.lop_vcv_factor`).

A single Decca pattern (the others in doubt, or not selected) gives one LOP an epoch, which the
filter takes as a raw measurement. Its error is the chain's slowly varying sky-wave error, so
hundreds of epochs of it are a handful of independent samples: taken as white, they would
squeeze the ellipse along the LOP's normal to metres while the error there stays the LOP's.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from engine.api import Session, load_config
from engine.run.cycle import lop_vcv_factor
from tests.paths import DATA

M2 = "M2_DECCA2E"
RECORDS = 900
CHI2_2_95 = 5.991464547107979  # χ²₂ 95 % quantile, −2 ln 0.05


def _ar1_mean_variance_ratio(rho: float, n: int) -> float:
    """n·Var(mean of n AR(1) samples)/σ², the exact finite sum 1 + 2Σ(1 − k/n)ρᵏ."""
    k = np.arange(1, n)
    return float(1.0 + 2.0 * np.sum((1.0 - k / n) * rho**k))


@pytest.mark.parametrize(("dt", "tau", "frac"), [(2.0, 240.0, 0.99), (1.0, 1800.0, 0.985),
                                                 (10.0, 60.0, 0.9), (600.0, 60.0, 0.99)])
def test_factor_is_the_effective_sample_size_of_the_coloured_share(dt: float, tau: float,
                                                                   frac: float) -> None:
    """(1 − f) + f·n·Var(mean)/σ² of a long AR(1) sequence: the exact sum, independently."""
    rho = math.exp(-dt / tau)
    n = 200_000
    expected = (1.0 - frac) + frac * _ar1_mean_variance_ratio(rho, n)
    assert lop_vcv_factor(dt, tau, frac) == pytest.approx(expected, rel=0.01)


def test_factor_is_one_for_white_errors_and_never_below_one() -> None:
    assert lop_vcv_factor(2.0, 240.0, 0.0) == pytest.approx(1.0)
    assert lop_vcv_factor(1e6, 240.0, 0.99) == pytest.approx(1.0, abs=1e-9)
    assert lop_vcv_factor(0.0, 240.0, 0.99) == lop_vcv_factor(1.0, 240.0, 0.99)  # first epoch


def _one_pattern(work: Path) -> tuple[Session, list]:
    """M2 simulated (seed 1) with its Decca errors twice their a-priori σ and a τ of 15 min,
    replayed with the red pattern alone: one LOP an epoch, the too-few-LOPs path throughout."""
    from engine.run.setup import read_data_dir
    from engine.sim.scenario import parse_scenario_text
    from engine.sim.simulate import simulate

    path = DATA / "scenarios" / f"{M2}.scenario.toml"
    text = path.read_text(encoding="utf-8").replace(
        "[decca]\n", "[decca]\nsigma_scale = 2\n", 1)
    assert "tau_s = 180.0" in text
    text = text.replace("tau_s = 180.0", "tau_s = 900.0", 1)
    scenario = parse_scenario_text(text, str(path), path.parent)
    lines, truth = [], []
    for t, rec in simulate(scenario, *read_data_dir(DATA), 1):
        lines.append(rec.raw + "\n")
        truth.append(t)
        if len(lines) >= RECORDS:
            break
    run = work / "m2_red.RUN"
    run.write_text("".join(lines), encoding="ascii")
    cfg = load_config(DATA / "scenarios" / f"{M2}.toml").replace(run_file=str(run))
    cfg = cfg.replace(decca=dataclasses.replace(cfg.decca, select=("red",)))
    return Session(cfg), truth


def test_one_lop_for_long_keeps_the_ellipse_honest(tmp_path: Path) -> None:
    """The MPP's 95 % ellipse holds the true position at ≥ 85 % of the epochs (white raw LOPs:
    22 %, the ellipse's minor axis 5 m against a LOP error of tens of metres)."""
    s, truth = _one_pattern(tmp_path)
    inside, raw_updates = [], 0
    for tr in truth:
        r = s.step()
        assert r is not None
        if r.filter_update is not None and any(lab.startswith("lop")
                                               for lab in r.filter_update.labels):
            raw_updates += 1
        tx, ty = s.context.grid(r.cm_deg).forward(tr.lat_deg, tr.lon_deg)
        e = np.array([r.mpp.x_m - tx, r.mpp.y_m - ty])
        inside.append(float(e @ np.linalg.solve(r.mpp.cov, e)) <= CHI2_2_95)
    assert raw_updates > 0.9 * RECORDS  # the path under test
    assert np.mean(inside) >= 0.85


@pytest.mark.parametrize("model", ["coloured", "thesis"])
def test_the_raw_lop_variance_the_filter_used(tmp_path: Path, model: str) -> None:
    """R of the raw LOP row, recovered from the update as S − a P⁻ aᵀ (P⁻ the predicted
    position VCV): C_l × λ × the effective-sample-size factor with the coloured fix-error
    model, C_l itself with the thesis' white one (``preset = "thesis"`` keeps the thesis)."""
    s, truth = _one_pattern(tmp_path)
    cfg = s.config.replace(filter=dataclasses.replace(s.config.filter, model=model))
    s = Session(cfg)
    params = s.context.filter_params
    checked = 0
    prev = None
    for _ in range(60):
        r = s.step()
        assert r is not None
        u, fix = r.filter_update, r.fix
        if (prev is not None and u is not None and fix is not None and fix.raw_lops is not None
                and u.labels[:1] == ("lop2",) and r.kf_pred is not None):
            a = np.asarray(fix.raw_lops.A)[0]
            R = float(u.S[0, 0]) - float(a @ np.asarray(r.kf_pred.cov) @ a)
            cl = float(np.asarray(fix.raw_lops.Cl)[0, 0])
            if model == "thesis":
                expected = cl
            else:
                lam = r.fix_cov_scale
                expected = cl * lam * lop_vcv_factor(r.dt_s, params.fix_tau_s,
                                                     params.fix_sigma_frac)
            assert R == pytest.approx(expected, rel=1e-6)
            checked += 1
        prev = r
    assert checked > 40

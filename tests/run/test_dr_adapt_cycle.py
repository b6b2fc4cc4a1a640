"""The dead-reckoning noise factor μ in the cycle and the logs (``[filter] adapt_dr``,
THEORY §8.19): the thesis preset does not learn it (its screens and golden ``.OUT`` stay), the
default does not either (measured: docs/ASSESS.md); ``adapt_dr = true`` learns it, shows it
on the ``ADAPT`` line and in the JSON lines, and applies it to the filter's time update (a μ > 1
widens the prediction's covariance by exactly the scaled random walks)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from engine.api import Session, load_config
from engine.filter import horizon as H
from engine.filter.predict import predict_step
from engine.run.records import cycle_block, cycle_json
from tests.paths import DATA

DEMO = DATA / "DEMO.toml"
SAMPLE = DATA / "920917_1.toml"


def test_thesis_preset_does_not_learn_the_dr_noise() -> None:
    s = Session(load_config(SAMPLE))
    for _ in range(3):
        r = s.step()
        if r is None:
            break
        assert r.dr_adapt is None
        assert "adapt" not in cycle_json(r)


def _demo_dr() -> Session:
    cfg = load_config(DEMO)
    return Session(cfg.replace(filter=replace(cfg.filter, adapt_dr=True)))


def test_default_does_not_learn_the_dr_noise() -> None:
    s = Session(load_config(DEMO))
    r = s.step()
    assert r is not None and r.adapt is not None and r.dr_adapt is None
    assert "dr" not in cycle_json(r)["adapt"]


def test_adapt_dr_learns_mu_from_shadow_checks_and_logs_it() -> None:
    """DEMO (GPS + Decca at the surface, 1-s records): a check every 150 s after the first
    300 s of fixes; the ADAPT line carries dr and checks, the JSON lines dr, dr_checks, dr_nees."""
    s = _demo_dr()
    rows = [s.step() for _ in range(1000)]
    last = rows[-1]
    assert last is not None and last.dr_adapt is not None
    d = last.dr_adapt
    # 1000 s of fixes: shadows start at t ≈ 0, 150, 300, …; checks at 300, 450, …, 900
    assert 4 <= d.n <= 6, d.n
    assert math.isfinite(d.nees_mean) and d.mu >= 1.0
    first = rows[0]
    assert first is not None and first.adapt_logged
    tags = [(tag.strip(), fields) for tag, fields in cycle_block(first)[1]]
    adapt = [f for tag, f in tags if tag == "ADAPT"]
    assert adapt and list(adapt[0])[-2:] == ["dr", "checks"]
    assert adapt[0]["dr"] == first.dr_adapt.mu == 1.0 and adapt[0]["checks"] == 0
    j = cycle_json(last)["adapt"]
    assert j["dr"] == pytest.approx(d.mu, rel=1e-3) and j["dr_checks"] == d.n
    assert j["dr_nees"] == pytest.approx(d.nees_mean, rel=1e-2)


def test_mu_scales_the_time_update_of_the_cycle() -> None:
    """With μ = 4 in the state, the cycle's prediction has the covariance of the filter
    parameters with the current's and biases' random walks × 4 (the reference time update)."""
    s = _demo_dr()
    for _ in range(20):
        s.step()
    nav = s.nav
    mu = math.exp(round(math.log(4.0) / H.MU_STEP) * H.MU_STEP)
    s.nav = replace(nav, dr_adapt=replace(nav.dr_adapt, mu=mu, log_mu=math.log(mu)))
    r = s.step()
    assert r is not None and r.smoother_link is not None
    before, pred, _phi = r.smoother_link
    params = H.scaled_params(s.context.filter_params, mu)
    want = predict_step(before, pred.t - before.t, params)[0]
    np.testing.assert_allclose(pred.P, want.P, rtol=1e-9, atol=1e-9)
    plain = predict_step(before, pred.t - before.t, s.context.filter_params)[0]
    assert want.P[6, 6] > plain.P[6, 6]  # the current's variance grew more

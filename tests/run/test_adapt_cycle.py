"""The learnt fix-VCV factor in the cycle and the logs (``[filter] adapt``, THEORY §8.17).

Mission M2 (Decca 2E alone, three patterns, one degree of freedom per fix) is simulated with the
thesis' a-priori VCV (docs/SIMULATOR.md) and, as a second run, with its Decca errors twice as
large (``decca.sigma_scale = 2``: four times the variance the engine assumes), which the fixes'
S² shows: the factor must rise well above 1 there, stay near 1 on the first, and the MPP's
ellipse follows. The thesis preset must not adapt (its screens and golden ``.OUT`` stay).
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from engine.api import RunConfig, Session, load_config
from engine.io.outlog import parse_line
from engine.run.records import cycle_block, cycle_json
from tests.paths import DATA

DEMO = DATA / "DEMO.toml"
SAMPLE = DATA / "920917_1.toml"
M2 = "M2_DECCA2E"
RECORDS = 900


def _m2(work: Path, sigma_scale: float) -> RunConfig:
    """M2 simulated (seed 1) with its Decca errors × ``sigma_scale``, its first 900 records in
    a .RUN; the start-up configuration (the engine's a-priori VCV) pointed at it."""
    from engine.run.setup import read_data_dir
    from engine.sim.scenario import parse_scenario_text
    from engine.sim.simulate import simulate

    path = DATA / "scenarios" / f"{M2}.scenario.toml"
    text = path.read_text(encoding="utf-8").replace(
        "[decca]\n", f"[decca]\nsigma_scale = {sigma_scale}\n", 1)
    scenario = parse_scenario_text(text, str(path), path.parent)
    lines = []
    for _truth, rec in simulate(scenario, *read_data_dir(DATA), 1):
        lines.append(rec.raw + "\n")
        if len(lines) >= RECORDS:
            break
    run = work / f"{M2}_{sigma_scale:g}.RUN"
    run.write_text("".join(lines), encoding="ascii")
    return load_config(DATA / "scenarios" / f"{M2}.toml").replace(run_file=str(run))


@pytest.fixture(scope="module")
def m2_config(tmp_path_factory: pytest.TempPathFactory) -> RunConfig:
    """M2 as the engine assumes it."""
    return _m2(tmp_path_factory.mktemp("m2"), 1.0)


@pytest.fixture(scope="module")
def m2_worse(tmp_path_factory: pytest.TempPathFactory) -> RunConfig:
    """M2 with Decca errors twice their a-priori σ."""
    return _m2(tmp_path_factory.mktemp("m2x2"), 2.0)


def _demo(cycles: int, base: RunConfig | None = None, **changes: object) -> tuple[Session, list]:
    cfg = load_config(DEMO) if base is None else base
    cfg = cfg.replace(filter=replace(cfg.filter, **changes))
    s = Session(cfg)
    out = [s.step() for _ in range(cycles)]
    return s, out


def test_thesis_preset_does_not_adapt() -> None:
    s = Session(load_config(SAMPLE))
    for _ in range(3):
        r = s.step()
        if r is None:
            break
        assert r.adapt is None and not r.adapt_logged
        assert "adapt" not in cycle_json(r)
        assert all(tag.strip() != "ADAPT" for tag, _f in cycle_block(r)[1])


def test_understated_decca_vcv_is_learnt_and_widens_the_ellipse(m2_worse: RunConfig) -> None:
    """Decca errors 2σ of their VCV: after 900 fix epochs the factor is above 2, each cycle's
    fix VCV is the one learnt up to the cycle before, and the MPP ellipse is larger than
    without adaptation."""
    _s, on = _demo(RECORDS, m2_worse)
    _s, off = _demo(RECORDS, m2_worse, adapt=False)
    last = on[-1]
    assert last.adapt is not None and last.adapt.fix_factor > 2.0
    assert off[-1].adapt is None
    for prev, r in zip(on[-50:-1], on[-49:], strict=True):
        assert r.fix_cov_scale >= prev.adapt.fix_factor - 1e-12
    assert np.trace(last.mpp.cov) > 1.5 * np.trace(off[-1].mpp.cov)


def test_right_vcv_leaves_the_factor_near_one(m2_config: RunConfig) -> None:
    """M2 as simulated (CF 64, the engine's own a-priori VCV): the factor stays small."""
    _s, on = _demo(RECORDS, m2_config)
    assert 1.0 <= on[-1].adapt.fix_factor < 1.6


def test_factor_in_out_and_json(tmp_path: Path, m2_worse: RunConfig) -> None:
    """The .OUT has an ADAPT line at the first cycle and whenever the factor moved by more
    than 5 % since the last one; the JSON lines carry it every cycle."""
    cfg = m2_worse
    out = tmp_path / "a.OUT"
    jsonl = tmp_path / "a.jsonl"
    s = Session(cfg, out_path=out, jsonl_path=jsonl)
    s.run(max_cycles=RECORDS)
    s.close()
    lines = [parse_line(line.strip()) for line in out.read_text().splitlines()
             if line.strip().startswith("ADAPT")]
    assert len(lines) >= 3
    factors = [f["fix"] for _t, f in lines]
    assert factors[0] < 1.2 and factors[-1] > 1.5  # the first cycle, then as it learns
    assert all(b / a > 1.05 or b / a < 0.95 for a, b in zip(factors, factors[1:], strict=False))
    objs = [json.loads(line) for line in jsonl.read_text().splitlines()]
    assert all("adapt" in o for o in objs)
    assert objs[-1]["adapt"]["fix"] > 1.5


def test_gps_alone_learns_the_true_factor_from_the_nis(tmp_path: Path) -> None:
    """GPS alone (M4: no redundancy, so the fix update's NIS is the only evidence), simulated
    with its error twice the σ the engine assumes (81.8 m against the SA-era 40.9 m per axis,
    white part 10 m against 5 m, the engine's τ of 240 s): λ_true = 4. The NIS is taken with
    the factor in force, so it must go in relative to the a-priori VCV; divided by λ twice
    the factor settled at √λ_true = 2 (measured 1.9–2.1 on three seeds)."""
    from engine.run.setup import read_data_dir
    from engine.sim.scenario import parse_scenario_text
    from engine.sim.simulate import simulate

    name = "M4_GPS_SW_WGS84"
    path = DATA / "scenarios" / f"{name}.scenario.toml"
    text = path.read_text(encoding="utf-8")
    assert "sigma_m = 35.0" in text and "white_sigma_m = 5.0" in text
    text = text.replace("white_sigma_m = 5.0", "white_sigma_m = 10.0").replace(
        "sigma_m = 35.0", "sigma_m = 81.8")
    scenario = parse_scenario_text(text, str(path), path.parent)
    lines = [rec.raw + "\n" for _t, rec in simulate(scenario, *read_data_dir(DATA), 2)]
    run = tmp_path / "m4x2.RUN"
    run.write_text("".join(lines), encoding="ascii")
    s = Session(load_config(DATA / "scenarios" / f"{name}.toml").replace(run_file=str(run)))
    factors = []
    while (r := s.step()) is not None:
        assert r.adapt is not None
        factors.append(r.adapt.fix_factor)
    assert len(factors) == 1200
    # the last 10 minutes: within 25 % of 4 (the window's scatter with τ = 240 s is ~10 %)
    assert np.median(factors[600:]) == pytest.approx(4.0, rel=0.25)

"""The randomized mission sampler (engine/sim/sampler.py, docs/SIMULATOR.md "Randomized
missions"): reproducible draws inside the documented ranges, start-up configurations an operator
would enter, refused draws reported (never dropped), and the simulator's sky-wave and per-pattern
Decca scales."""

from __future__ import annotations

import dataclasses
import math
import tomllib
from datetime import UTC, datetime

import numpy as np
import pytest

from engine.sim import sampler
from engine.sim.sampler import (
    RANGES,
    SamplerError,
    SamplerOptions,
    draw_mission,
    start_zone_lanes,
)
from engine.sim.scenario import load_scenario, parse_scenario_text
from engine.sim.simulate import read_data_files, simulate
from tests.paths import DATA

N_DRAWS = 300
"""Seeds 0-299: enough for the distribution checks below (standard errors stated there)."""


@pytest.fixture(scope="module")
def data() -> tuple:
    return read_data_files(DATA)


@pytest.fixture(scope="module")
def draws(data: tuple) -> list:
    return [draw_mission(seed, *data) for seed in range(N_DRAWS)]


def test_same_seed_same_mission_other_seed_other_mission(data: tuple) -> None:
    a, b, c = draw_mission(5, *data), draw_mission(5, *data), draw_mission(6, *data)
    assert (a.scenario_text, a.config_text) == (b.scenario_text, b.config_text)
    assert a.scenario_text != c.scenario_text


@pytest.mark.parametrize("name", ["M1_SURF9B", "M2_DECCA2E", "M5_DIVE30", "M6_DIVE150"])
def test_start_zone_lanes_are_the_hand_entered_ones(data: tuple, name: str) -> None:
    """The zone/lanes the sampler enters are those the bundled missions' authors typed in."""
    scen = load_scenario(DATA / "scenarios" / f"{name}.scenario.toml")
    with open(DATA / "scenarios" / f"{name}.toml", "rb") as fh:
        cfg = tomllib.load(fh)["decca"]
    assert start_zone_lanes(scen, *data) == {p: cfg[p] for p in ("red", "green", "purple")}


def test_every_draw_is_inside_its_documented_range(draws: list) -> None:
    for m in draws:
        g = m.drawn
        for name in ("gps_sigma_m", "gps_tau_s", "gps_white_m", "decca_tau_s", "current_kn",
                     "log_scale", "gyro_bias_deg", "gyro_drift_sigma_deg", "gyro_drift_tau_s"):
            lo, hi, _kind = RANGES[name]
            step = 0.5 if name == "gyro_drift_tau_s" else 0.05
            assert lo - step <= float(g[name]) <= hi + step, (m.seed, name, g[name])
        for p in ("red", "green", "purple"):
            assert 0.5 - 5e-4 <= float(g[f"decca_{p}_scale"]) <= 3.0 + 5e-4
        assert 1800 <= int(g["mission_s"]) <= 43200
        assert int(g["surfaced_s"]) + int(g["dived_s"]) == int(g["mission_s"])
        assert sum(leg.duration_s for leg in m.scenario.legs) == int(g["mission_s"])
        assert m.scenario.legs[0].surfaced  # every mission starts on the surface
        if float(g["gps_hdop"]) > 0.0:
            # σ at the mean HDOP is the drawn σ (with its white part)
            total = float(g["gps_hdop"]) * float(g["gps_uere_m"]) / math.sqrt(2.0)
            assert total == pytest.approx(math.hypot(float(g["gps_sigma_m"]),
                                                     float(g["gps_white_m"])), rel=0.01)
        assert float(g["skywave_max"]) <= RANGES["skywave_factor"][1] + 1e-3


def test_operator_current_is_off_by_at_most_one_knot(draws: list) -> None:
    worst = 0.0
    for m in draws:
        cfg = tomllib.loads(m.config_text)
        cur = m.scenario.current
        te, tn = cur.east_north_ms()
        entry = dataclasses.replace(cur, set_deg=cfg["current_set_deg"],
                                    speed_kn=cfg["current_speed_kn"])
        ee, en = entry.east_north_ms()
        off_kn = math.hypot(ee - te, en - tn) * 3600.0 / 1852.0
        worst = max(worst, off_kn)
        assert off_kn <= 1.0 + 0.02, (m.seed, off_kn)  # + the 0.01-kn / 0.1° rounding
    assert worst > 0.8  # the whole range is used


def test_log_uniform_and_uniform_draws_have_their_medians(draws: list) -> None:
    """Median of a log-uniform draw on [a, b] is √(ab); of a uniform one (a + b)/2. With 300
    draws the sample median's standard error is about 1.25·σ/√300 (≈ 7 % of the range's log for
    log-uniform): asserted within 4 standard errors."""
    for name in ("gps_sigma_m", "gps_tau_s", "decca_tau_s"):
        lo, hi, kind = RANGES[name]
        assert kind == "log"
        values = np.log([float(m.drawn[name]) for m in draws])
        sd = (math.log(hi) - math.log(lo)) / math.sqrt(12.0)
        assert np.median(values) == pytest.approx(0.5 * (math.log(lo) + math.log(hi)),
                                                  abs=4 * 1.25 * sd / math.sqrt(N_DRAWS))
    lo, hi, kind = RANGES["current_kn"]
    assert kind == "uniform"
    cur = [float(m.drawn["current_kn"]) for m in draws]
    assert np.median(cur) == pytest.approx(1.0, abs=4 * 1.25 * (hi - lo) / math.sqrt(12 * 300))
    systems = [m.drawn["systems"] for m in draws]
    assert 0.5 < systems.count("gps+decca") / N_DRAWS < 0.7


def test_skywave_episodes_only_at_night(draws: list) -> None:
    """Every leg with a sky-wave factor starts or ends with the sun below the horizon (legs are
    at most 30 min; the factor is drawn at the leg's midpoint)."""
    seen = 0
    for m in draws:
        t = 0
        for leg in m.scenario.legs:
            if leg.decca_sigma_factor != 1.0:
                seen += 1
                assert leg.surfaced
                assert 3.0 <= leg.decca_sigma_factor <= 8.0
                mid = m.scenario.start_time.timestamp() + t + leg.duration_s / 2
                when = datetime.fromtimestamp(mid, UTC)
                lat, lon = m.scenario.start_lat_deg, m.scenario.start_lon_deg
                assert sampler._sun_elevation_deg(when, lat, lon) < 1.5, (m.seed, when)
            t += leg.duration_s
    assert seen > 20


def test_sun_elevation_against_hand_values() -> None:
    """Midsummer noon at 52° N on the Greenwich meridian: 90 − 52 + 23.44 = 61.4°; midwinter
    midnight there: −(90 − 52 + 23.44) = −61.4° (±1° for the approximate declination)."""
    noon = sampler._sun_elevation_deg(datetime(1992, 6, 21, 12, tzinfo=UTC), 52.0, 0.0)
    night = sampler._sun_elevation_deg(datetime(1992, 12, 21, 0, tzinfo=UTC), 52.0, 0.0)
    assert noon == pytest.approx(61.4, abs=1.0)
    assert night == pytest.approx(-61.4, abs=1.0)


def test_a_draw_the_engine_refuses_is_a_sampler_error(data: tuple,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    """A range that produces a mission the engine cannot start (a speed above the scenario's
    60 kn) is reported with the seed and the engine's message, never dropped."""
    bad = dict(RANGES)
    bad["speed_surfaced_kn"] = (70.0, 80.0, "uniform")
    monkeypatch.setattr(sampler, "RANGES", bad)
    with pytest.raises(SamplerError, match=r"seed 3 .*speed_kn: Out of range"):
        draw_mission(3, *data)


def test_the_interval_and_the_longest_mission_are_honoured(data: tuple) -> None:
    opts = SamplerOptions(sample_interval_s=2, max_mission_s=3600)
    for seed in range(40):
        m = draw_mission(seed, *data, opts)
        assert m.scenario.sample_interval_s == 2
        assert int(m.drawn["mission_s"]) <= 3600
        assert all(leg.duration_s % 2 == 0 for leg in m.scenario.legs)


# --------------------------------------------------------------------------------------------
# The simulator's Decca scales (engine/sim/simulate.py)

_DECCA_SCENARIO = """
start_time = "1992-06-11T10:00:00Z"
start_position = "53 00 00 N 004 05 00 E"
[current]
speed_kn = 0.0
[gps]
on = false
[decca]
chain = "9B"
tau_s = 120.0
{extra}
[[leg]]
duration_s = 600
course_deg = 90.0
speed_kn = 6.0
[[leg]]
duration_s = 600
course_deg = 90.0
speed_kn = 6.0
{leg2}
"""


def _decca_errors(data: tuple, extra: str = "", leg2: str = "") -> np.ndarray:
    """Unquantised Decca readings minus the error-free ones (lanes, wrapped to ±0.5)."""
    def fractions(text: str) -> np.ndarray:
        scen = parse_scenario_text(text)
        return np.array([rec.decca for _t, rec in simulate(scen, *data, seed=11)], dtype=float)
    noisy = fractions(_DECCA_SCENARIO.format(extra=extra, leg2=leg2))
    clean = fractions(_DECCA_SCENARIO.format(extra="sigma_scale = 0.0\n" + extra, leg2=leg2))
    return (noisy - clean + 0.5) % 1.0 - 0.5


def test_per_pattern_scale_multiplies_that_pattern_only(data: tuple) -> None:
    base = _decca_errors(data)
    scaled = _decca_errors(data, "red_scale = 2.0\npurple_scale = 0.5")
    assert np.abs(base).max() > 0.003  # a real error to scale
    np.testing.assert_allclose(scaled[:, 0], 2.0 * base[:, 0], atol=1e-9)
    np.testing.assert_allclose(scaled[:, 1], base[:, 1], atol=1e-9)
    np.testing.assert_allclose(scaled[:, 2], 0.5 * base[:, 2], atol=1e-9)


def test_leg_skywave_factor_multiplies_that_leg_only(data: tuple) -> None:
    base = _decca_errors(data)
    episode = _decca_errors(data, leg2="decca_sigma_factor = 3.0")
    np.testing.assert_allclose(episode[:600], base[:600], atol=1e-9)
    np.testing.assert_allclose(episode[600:], 3.0 * base[600:], atol=1e-9)

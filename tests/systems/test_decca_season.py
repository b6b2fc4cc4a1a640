"""The Decca sky-wave condition by the sun (engine.systems.decca_season) and the cycle's use of
it under ``lsq.decca_cf = "auto"`` (thesis L8352: summer night ×1, summer day σ/8, winter day
σ/2, winter night σ×1.5; THEORY §3.5).

The cycle test replays the thesis sample's first records (17 Sept 1992, 08:35 UTC at 52.8° N:
summer, sun about 25° up) and the same records moved to 22:35 UTC (sun about 27° below the
horizon): under "auto" the night fix's sky-wave VCV (its covariances, which hold no
synchronisation term) is 64 times the day fix's; the thesis preset keeps 64 at night too.
"""

from __future__ import annotations

import json
from dataclasses import replace
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pytest

from engine.api import RunConfig, Session, load_config
from engine.run.records import cycle_json
from engine.systems.decca_season import (
    DAY_MIN_SUN_ELEVATION_DEG,
    decca_condition,
    is_local_summer,
)
from tests.paths import DATA

SAMPLE = DATA / "920917_1.toml"


@pytest.mark.parametrize(("when", "lat", "lon", "code", "cf"), [
    # 9B area, midsummer noon: sun 90 − 53 + 23.44 ≈ 60° (hand) → summer day, σ/8
    ((1992, 6, 21, 12, 0), 53.0, 4.1, "SD", 64.0),
    # midsummer 23:00 UTC: sun ≈ 13° below the horizon → summer night, σ
    ((1992, 6, 21, 23, 0), 53.0, 4.1, "SN", 1.0),
    # midwinter noon: sun 90 − 53 − 23.44 ≈ 13.5° → winter day, σ/2
    ((1992, 12, 21, 12, 0), 53.0, 4.1, "WD", 4.0),
    # midwinter 20:00 UTC → winter night, σ × 1.5
    ((1992, 12, 21, 20, 0), 53.0, 4.1, "WN", 1.0 / 2.25),
    # December is summer at the Cape (hemisphere-aware): 10:00 UTC, sun high → summer day
    ((1992, 12, 21, 10, 0), -34.0, 18.4, "SD", 64.0),
    # June at the Cape, 22:00 UTC → winter night
    ((1992, 6, 21, 22, 0), -34.0, 18.4, "WN", 1.0 / 2.25),
    # midsummer dawn, 03:50 UTC: sun +2.9°, above the horizon but inside the twilight band
    # [choice, cautious]: still the night variance
    ((1992, 6, 21, 3, 50), 53.0, 4.1, "SN", 1.0),
    # 04:20 UTC: sun +6.7°, past the band → day
    ((1992, 6, 21, 4, 20), 53.0, 4.1, "SD", 64.0),
])
def test_condition_by_season_and_sun(when: tuple[int, ...], lat: float, lon: float,
                                     code: str, cf: float) -> None:
    cond = decca_condition(datetime(*when, tzinfo=UTC), lat, lon)
    assert (cond.code, cond.cf) == (code, pytest.approx(cf, rel=1e-12))
    assert (cond.sun_deg >= DAY_MIN_SUN_ELEVATION_DEG) == code.endswith("D")


def test_summer_is_the_half_year_of_the_hemisphere() -> None:
    """From the spring to the autumn equinox (20 March and 22 September 1992, about 08:48 and
    18:43 UTC): summer in the north, winter in the south; on the equator always winter (the
    larger variance)."""
    spring, autumn = datetime(1992, 3, 21, tzinfo=UTC), datetime(1992, 9, 22, tzinfo=UTC)
    assert is_local_summer(spring, 53.0) and is_local_summer(autumn, 53.0)
    assert not is_local_summer(spring, -34.0) and not is_local_summer(autumn, -34.0)
    assert not is_local_summer(datetime(1992, 3, 19, tzinfo=UTC), 53.0)
    assert not is_local_summer(datetime(1992, 9, 24, tzinfo=UTC), 53.0)
    assert not is_local_summer(datetime(1992, 6, 21, tzinfo=UTC), 0.0)


def _sample(work: Path, hour: str, records: int = 5) -> Path:
    """The thesis sample's first ``records`` records at ``hour`` UTC (the minutes kept)."""
    lines = (DATA / "920917_1.RUN").read_text(encoding="ascii").splitlines(keepends=True)
    out = [lines[0]] + [line.replace("\t08", f"\t{hour}", 1) for line in lines[1:records + 1]]
    path = work / f"night_{hour}.RUN"
    path.write_text("".join(out), encoding="ascii")
    return path


def _first_fix(cfg: RunConfig) -> tuple[np.ndarray, object]:
    s = Session(cfg)
    r = s.step()
    assert r is not None and r.fix is not None and r.fix.ok
    cl = r.fix.apriori_vcv("decca")
    assert cl is not None
    return np.array(cl), r


def test_night_epoch_has_the_summer_night_vcv(tmp_path: Path) -> None:
    thesis = load_config(SAMPLE)
    assert thesis.lsq.decca_cf == 64.0  # the thesis preset's summer's day (A8.2)
    auto = thesis.replace(lsq=replace(thesis.lsq, decca_cf="auto"))
    day, r_day = _first_fix(auto.replace(run_file=str(_sample(tmp_path, "08"))))
    night, r_night = _first_fix(auto.replace(run_file=str(_sample(tmp_path, "22"))))
    fixed, r_fixed = _first_fix(thesis.replace(run_file=str(_sample(tmp_path, "22"))))
    assert (r_day.decca_cf, r_day.decca_condition) == (64.0, "SD")
    assert (r_night.decca_cf, r_night.decca_condition) == (1.0, "SN")
    assert (r_fixed.decca_cf, r_fixed.decca_condition) == (64.0, "")
    off = ~np.eye(3, dtype=bool)
    # the covariances (m²) are 12σ_n²/CF ·k_i k_j … (A4.2d–f): the ratio is 64; the fixes
    # differ by their weights, so the geometry by metres (1e-3 relative is ample)
    np.testing.assert_allclose(night[off], 64.0 * day[off], rtol=1e-3)
    np.testing.assert_allclose(fixed[off], day[off], rtol=1e-3)
    # Red and Green (selected): the sky-wave part × 64, the synchronisation part (not divided
    # by CF) kept, so more than 10 × (Green's sync share is large); Purple unselected: 1 (L6552)
    assert np.all(np.diag(night)[:2] > 10.0 * np.diag(day)[:2])
    assert night[2, 2] == day[2, 2] == 1.0
    assert any("Decca sky-wave: summer night, CF 1 (sun -" in m for m in r_night.messages)
    assert not any("sky-wave" in m for m in r_fixed.messages)
    obj = json.loads(json.dumps(cycle_json(r_night)))
    assert obj["decca_cf"] == {"cf": 1.0, "condition": "SN"}
    assert "decca_cf" not in cycle_json(r_fixed)


def test_compiled_path_takes_the_night_cf(tmp_path: Path,
                                          monkeypatch: pytest.MonkeyPatch) -> None:
    """The compiled lane model receives the epoch's CF as an argument: a night run on the
    chosen parts and on the pure reference give the same VCV (tolerance contract, 1e-9)."""
    import engine.run.session as session_mod
    from engine.run.parts import REFERENCE

    thesis = load_config(SAMPLE)
    cfg = thesis.replace(lsq=replace(thesis.lsq, decca_cf="auto"),
                         run_file=str(_sample(tmp_path, "22")))
    fast, _r = _first_fix(cfg)
    monkeypatch.setattr(session_mod, "choose_parts", lambda: REFERENCE)
    pure, r = _first_fix(cfg)
    assert r.decca_condition == "SN"
    np.testing.assert_allclose(fast, pure, rtol=1e-9, atol=1e-9)

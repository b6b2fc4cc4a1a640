"""Cross-test of the NMEA paths (issue 13): ``uvnav simulate --nmea`` writes the mission as an
NMEA 0183 log, the NMEA reader (engine/io/nmea_log.py) replays it, and the fixes are compared
with the simulator's truth and with the replay of the same mission's ``.RUN``.

Tolerances, stated:

* noise-free mission: the GPS reading is the truth, so the replayed least-squares fix (GPS only,
  Decca has no NMEA sentence) lies on the truth within the NMEA position step: half of 1e-4′
  is 0.093 m in latitude and 0.056 m in longitude at 52.8° N, 0.11 m together, plus 1 mm;
* with errors: the fix error is the simulated GPS error, first-order Gauss–Markov σ = 35 m per
  axis plus 3 m white (data/DEMO.scenario.toml's values, the defaults), σ = 35.1 m per axis; a
  radial error beyond 5 σ = 176 m has probability e^(−12.5) ≈ 4e-6 per epoch (Rayleigh), so
  that is the bound. Tighter, and independent of the noise: the NMEA replay's fix equals the
  ``.RUN`` replay's fix of the same seed within both quantisations (0.11 m NMEA + 0.03 m for
  the ``.RUN``'s 0.001″ on both axes), 0.15 m.

The reader keeps a GNSS position for ``nmea.position_stale_s`` (3 s by default) after its
sentence, so the last surfaced fix would be used again for three epochs after the dive; the
configuration here sets 0.5 s so every GGA is used exactly once, at its own epoch.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from engine.run.config import load_config
from engine.run.session import Session
from engine.sim.scenario import parse_scenario_text
from engine.sim.simulate import read_data_files, simulate, write_simulation
from tests.paths import DATA

MISSION = """start_time = "1992-09-17T23:59:00Z"
start_position = "52 50 00 N 004 30 00 E"
water_depth_m = 70
[current]
set_deg = 30
speed_kn = 0.5
[sensors]
echosounder = true
[decca]
on = false
[[leg]]
duration_s = 90
course_deg = 232
speed_kn = 10
[[leg]]
duration_s = 90
course_deg = 260
speed_kn = 6
depth_m = 20
surfaced = false
"""

CONFIG = f"""datum = "ED50"
dr_position = "52 50 00 N 004 30 00 E"
run_file = "{{run}}"
run_gps_datum = "WGS84"
data_dir = "{DATA}"
[gps]
on = true
[decca]
on = false
[nmea]
position_stale_s = 0.5
"""

GPS_SIGMA_M = math.hypot(35.0, 3.0)


def _replay(tmp: Path, run: str, data) -> list:
    cfg_path = tmp / f"{run}.toml"
    cfg_path.write_text(CONFIG.replace("{run}", run), encoding="utf-8")
    session = Session(load_config(cfg_path), history=1, data=data)
    out = []
    while (r := session.step()) is not None:
        out.append((r, session.context.grid(r.cm_deg)))
    session.close()
    return out


def _fixes(cycles: list) -> dict:
    return {r.time: (r.fix.x_m, r.fix.y_m) for r, _g in cycles
            if r.fix is not None and r.fix.lse_ok}


@pytest.fixture(scope="module")
def data():
    return read_data_files(DATA)


def test_noise_free_nmea_replay_lies_on_the_truth(tmp_path: Path, data) -> None:
    sc = parse_scenario_text(MISSION).without_errors()
    truth = [t for t, _rec in simulate(sc, *data, seed=2)]
    write_simulation(sc, tmp_path / "N.RUN", None, 2, datums=data[0], chains=data[1],
                     nmea_path=tmp_path / "N.nmea")
    cycles = _replay(tmp_path, "N.nmea", data)
    assert [r.time for r, _g in cycles] == [t.time for t in truth]  # across midnight too
    fixes = 0
    for (r, grid), t in zip(cycles, truth, strict=True):
        assert (r.fix is not None and r.fix.lse_ok) == t.surfaced
        if t.surfaced:
            tx, ty = grid.forward(t.lat_deg, t.lon_deg)
            assert math.hypot(r.fix.x_m - tx, r.fix.y_m - ty) <= 0.11 + 1e-3
            fixes += 1
        assert r.sensors.heading_true_deg == pytest.approx(t.heading_true_deg, abs=0.05 + 1e-9)
        assert r.sensors.speed_kn == pytest.approx(t.speed_kn, abs=0.05 + 1e-9)
    assert fixes == 90


def test_nmea_replay_matches_truth_and_the_run_replay(tmp_path: Path, data) -> None:
    sc = parse_scenario_text(MISSION)
    truth = {t.time: t for t, _rec in simulate(sc, *data, seed=8)}
    write_simulation(sc, tmp_path / "E.RUN", None, 8, datums=data[0], chains=data[1],
                     nmea_path=tmp_path / "E.nmea")
    by_nmea = _replay(tmp_path, "E.nmea", data)
    by_run = _replay(tmp_path, "E.RUN", data)
    fix_n, fix_r = _fixes(by_nmea), _fixes(by_run)
    assert len(fix_n) == len(fix_r) == 90 and fix_n.keys() == fix_r.keys()
    for r, grid in by_nmea:
        if r.time in fix_n:
            t = truth[r.time]
            tx, ty = grid.forward(t.lat_deg, t.lon_deg)
            x, y = fix_n[r.time]
            assert math.hypot(x - tx, y - ty) <= 5 * GPS_SIGMA_M
            xr, yr = fix_r[r.time]
            assert math.hypot(x - xr, y - yr) <= 0.15

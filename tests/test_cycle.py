"""The processing cycle and the session on the thesis sample and on planted faults."""

from __future__ import annotations

import math
from dataclasses import replace
from datetime import UTC
from pathlib import Path

import numpy as np
import pytest

from engine.commands import (
    AddObservation,
    SetCurrent,
    SetDatum,
    SetDecca,
    SetDRPosition,
    SetFiltering,
    SetGps,
    SetParameters,
    SetSensor,
)
from engine.errors import InputError
from engine.fix import ManualObservation
from engine.geodesy import datum_shift
from engine.runconfig import load_config
from engine.session import Session

DATA = Path(__file__).resolve().parents[1] / "data"
SAMPLE = DATA / "920917_1.toml"


def _run(cfg, **kw) -> tuple[Session, list]:
    s = Session(cfg, **kw)
    out = []
    while (r := s.step()) is not None:
        out.append(r)
    return s, out


def test_sample_replays_ten_cycles_with_fixes() -> None:
    s, res = _run(load_config(SAMPLE))
    assert [r.n for r in res] == list(range(1, 11))
    assert [r.time.strftime("%H%M%S") for r in res][:2] == ["083538", "083539"]
    assert all(r.fix is not None and r.fix.ok and r.fix.category == "IV" for r in res)
    # First cycle initialises the filter at the LSE (kalman.md A3): N/A, MPP = LSE.
    assert res[0].filter_status == "N/A" and res[0].mpp.source == "LSE"
    assert all(r.filter_status == "ON" and r.mpp.source == "KF" for r in res[1:])
    # The ship runs 232° at 12.7 kn: 9 s → ~59 m south-west.  The filtered track must follow:
    # displacement of the MPP between cycles 2 and 10 within 15 m of the log/gyro distance.
    d = math.hypot(res[-1].mpp.x_m - res[1].mpp.x_m, res[-1].mpp.y_m - res[1].mpp.y_m)
    assert d == pytest.approx(8 * 12.8 * 1852 / 3600, abs=15.0)
    # Sanity: each filtered MPP lies within the LSE's 95 % semi-major axis of that cycle's LSE.
    for r in res[1:]:
        a95_lse = r.fix.ellipse.scaled(0.95)[0]
        assert math.hypot(r.mpp.x_m - r.fix.x_m, r.mpp.y_m - r.fix.y_m) < a95_lse
    assert s.summary().skipped_records == 0


def test_pg641_kf_row_is_the_dr_of_two_records() -> None:
    """kalman.md §10.5: DR start 52 50 00 N 004 30 00 E, records 083538 and 083539, zero
    current → KF x −33709.65 y 5856305.50 (Pg 641, printed to 0.01 m).  With GPS and Decca off
    the cycle is pure DR, which is what the thesis screen shows (its filter was N/A)."""
    cfg = load_config(SAMPLE)
    cfg = cfg.replace(gps=replace(cfg.gps, on=False), decca=replace(cfg.decca, on=False))
    _s, res = _run(cfg)
    kf = res[1].kf_pred
    assert (kf.x_m, kf.y_m) == pytest.approx((-33709.65, 5856305.50), abs=0.01)
    assert res[1].filter_status == "ON" and res[1].mpp.source == "KF"  # DR-only path (§2.5)
    assert res[1].fix is None


def test_gps_datum_defaults_to_wgs84() -> None:
    """lsq.md §13 item 2: the .RUN GPS is WGS84 unless the configuration says otherwise."""
    cfg = load_config(SAMPLE)
    wgs = cfg.replace(run_gps_datum="WGS84")
    r_ed = _run(cfg)[1][0]
    r_w = _run(wgs)[1][0]
    assert r_ed.gps.lat_deg == r_ed.gps.lat_in_deg
    ctx = Session(wgs).context
    shift = datum_shift(ctx.datums.datum("WGS84"), ctx.working)
    lat, lon, _ = shift.transform(r_w.gps.lat_in_deg, r_w.gps.lon_in_deg, 0.0)
    assert (r_w.gps.lat_deg, r_w.gps.lon_deg) == pytest.approx((lat, lon), abs=1e-9)
    # ED50 vs WGS84 differ here by ~130 m (the 3-parameter shift), so the fixes differ too.
    dx = r_w.gps.x_m - r_ed.gps.x_m
    dy = r_w.gps.y_m - r_ed.gps.y_m
    assert 100 < math.hypot(dx, dy) < 160


def test_bad_records_are_skipped_and_reported(tmp_path: Path) -> None:
    lines = (DATA / "920917_1.RUN").read_text().splitlines()  # caption + 10 records
    bad = lines[:3] + [
        "920917 083541 52 50 32.584 N 004 31 50.125 E .873 .347 .118 400.0 12.7 -.4",
        "garbage",
        lines[3],
    ] + lines[4:]
    run = tmp_path / "BAD.RUN"
    run.write_text("\n".join(bad) + "\n")
    cfg = load_config(SAMPLE).replace(run_file=str(run))
    s, res = _run(cfg, out_path=tmp_path / "BAD.OUT")
    s.close()
    # 10 good records; the heading 400 and the garbage line are rejected by the parser.
    assert len(res) == 10
    fields = sorted(b.error.field or "" for b in s.bad_records)
    assert fields == ["heading", "record"]
    from engine.outlog import read_out_log

    log = read_out_log(tmp_path / "BAD.OUT")
    assert len(log.cycles) == 10 and len(log.bad_records) == 2
    assert {b["field"] for b in log.bad_records} == {"heading", "record"}


def test_repeated_time_is_skipped_not_fatal(tmp_path: Path) -> None:
    lines = (DATA / "920917_1.RUN").read_text().splitlines()
    run = tmp_path / "DUP.RUN"
    run.write_text("\n".join(lines[:4] + [lines[3]] + lines[4:]) + "\n")
    s, res = _run(load_config(SAMPLE).replace(run_file=str(run)))
    assert len(res) == 10
    assert len(s.bad_records) == 1 and "does not advance" in s.bad_records[0].error.message


def test_commands_change_the_next_cycle() -> None:
    s = Session(load_config(SAMPLE))
    s.step()
    s.apply(SetGps(on=False))
    r = s.step()
    assert r.gps is None and all(lop.system == "Decca" for lop in r.fix.lops)
    assert r.systems == "....D"
    s.apply(SetDecca(on=False))
    r = s.step()
    assert r.fix is None and r.mpp.source == "KF"  # DR only
    s.apply(SetGps(on=True, receiver="P"))
    r = s.step()
    # P code: σ 8.9 m per axis (program.md A13) → the GPS rows dominate: a95 < 25 m.
    assert r.fix.ellipse.scaled(0.95)[0] < 25.0
    with pytest.raises(InputError):
        s.apply(SetSensor("gyro", "maybe"))
    s.apply(SetFiltering(on=False))
    r = s.step()
    assert r.filter_status == "OFF" and r.mpp.source == "LSE"
    s.apply(SetParameters("lsq", (("conf_region_pct", 99.9),)))
    assert s.config.lsq.conf_region_pct == 99.9


def test_manual_bearing_is_used_once() -> None:
    s = Session(load_config(SAMPLE))
    r1 = s.step()
    # A bearing to Heiloo lighthouse area (the Green slave, ED50) consistent with the fix.
    from engine.geodesy import GeodesicSolver

    heiloo = (52 + 35 / 60 + 30.089 / 3600, 4 + 43 / 60 + 47.118 / 3600)
    az, _d = GeodesicSolver(s.context.working.ellipsoid).azimuth_distance(
        r1.mpp.lat_deg, r1.mpp.lon_deg, *heiloo)
    s.apply(AddObservation((ManualObservation("bearing", "Heiloo", *heiloo, az, 0.8,
                                              "compass repeater"),)))
    r2 = s.step()
    brg = [lop for lop in r2.fix.lops if lop.pattern == "Brg"]
    assert len(brg) == 1 and brg[0].used and r2.fix.n_used == 5
    # Ship moved ~6.5 m in 1 s; the bearing residual is metres across a 31 km line.
    assert abs(brg[0].v_m) < 60.0
    r3 = s.step()
    assert not any(lop.pattern == "Brg" for lop in r3.fix.lops)


def test_dr_position_and_current_commands_reset_the_filter() -> None:
    s = Session(load_config(SAMPLE))
    s.step()
    s.step()
    s.apply(SetDRPosition(52.9, 4.6))
    assert s.nav.mpp_lat_deg == 52.9 and not s.nav.filter_has_fix
    assert s.nav.filter.P[0, 0] == pytest.approx(s.config.filter.dr_sigma_m**2)
    s.apply(SetCurrent(90.0, 2.0))
    assert s.nav.filter.x[6] == pytest.approx(2 * 1852 / 3600, rel=0.02)  # east component
    r = s.step()
    # The first LSE after a DR reset re-initialises the position (A3): MPP is the LSE.
    assert r.mpp.source == "LSE"


def test_datum_change_moves_the_state() -> None:
    s = Session(load_config(SAMPLE))
    r = s.step()
    lat0, lon0 = r.mpp.lat_deg, r.mpp.lon_deg
    s.apply(SetDatum("WGS84"))
    shift = datum_shift(s.datums.datum("ED50"), s.datums.datum("WGS84"))
    lat, lon, _ = shift.transform(lat0, lon0, 0.0)
    assert (s.nav.mpp_lat_deg, s.nav.mpp_lon_deg) == pytest.approx((lat, lon), abs=1e-9)
    r2 = s.step()
    assert r2.datum == "WGS84" and r2.fix.ok
    # The same ship, now on WGS84: 1 s later, within 20 m of the transformed previous MPP.
    x, y = s.context.grid(r2.cm_deg).forward(lat, lon)
    assert math.hypot(r2.mpp.x_m - x, r2.mpp.y_m - y) < 20.0


def test_cm_switches_and_reprojects(tmp_path: Path) -> None:
    """A track crossing 5.5°E moves the CM from 5° to 6° (program.md A11); the filter state is
    re-projected so the MPP stays continuous in geodetic coordinates."""
    from datetime import datetime, timedelta

    from engine.runfile import RunRecord, format_run_record

    t0 = datetime(1992, 9, 17, 8, 0, 0, tzinfo=UTC)
    recs = []
    lat = 52.8
    for i in range(900):
        lon = 5.49 + i * 0.0001  # ~6.7 m/s east
        recs.append(format_run_record(RunRecord(i + 1, t0 + timedelta(seconds=i), lat, lon,
                                                (None, None, None), 90.0, 13.0, 0.0)))
    run = tmp_path / "CM.RUN"
    run.write_text("\n".join(recs) + "\n")
    cfg = load_config(SAMPLE)
    cfg = cfg.replace(run_file=str(run), dr_position="52 48 00 N 005 29 24 E",
                      run_gps_datum="ED50", decca=replace(cfg.decca, on=False))
    _s, res = _run(cfg)
    cms = sorted({r.cm_deg for r in res})
    assert cms == [5.0, 6.0]
    switch = next(i for i, r in enumerate(res) if r.cm_deg == 6.0)
    assert any("CM changed" in m for m in res[switch].messages)
    # Continuity across the switch: geodetic step ≈ one second of motion (< 15 m).
    a, b = res[switch - 1].mpp, res[switch].mpp
    dy = (b.lat_deg - a.lat_deg) * 111_000
    dx = (b.lon_deg - a.lon_deg) * 111_000 * math.cos(math.radians(lat))
    assert math.hypot(dx, dy) < 15.0
    assert np.all(np.isfinite(res[-1].mpp.cov))

"""The processing cycle and the session on the thesis sample and on planted faults."""

from __future__ import annotations

import math
from dataclasses import FrozenInstanceError, fields, replace
from datetime import UTC
from pathlib import Path

import numpy as np
import pytest

from engine.errors import InputError
from engine.geodesy.ellipsoidal import datum_shift
from engine.lsq.fix import ManualObservation
from engine.run.commands import (
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
from engine.run.config import load_config
from engine.run.cycle import CycleResult, NavState
from engine.run.session import Session
from engine.systems.registry import systems_string
from engine.systems.sensors import SENSOR_NAMES
from tests.paths import DATA

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
    # First cycle initialises the filter at the LSE (THEORY D22): N/A, MPP = LSE.
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
    """THEORY §14.4: DR start 52 50 00 N 004 30 00 E, records 083538 and 083539, zero
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
    """THEORY D6: the .RUN GPS is WGS84 unless the configuration says otherwise."""
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
    from engine.io.outlog import read_out_log

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
    # P code: σ 8.9 m per axis (THEORY D5) → the GPS rows dominate: a95 < 25 m.
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
    from engine.geodesy.ellipsoidal import GeodesicSolver

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
    """A track crossing 5.5°E moves the CM from 5° to 6° (THEORY D3); the filter state is
    re-projected so the MPP stays continuous in geodetic coordinates."""
    from datetime import datetime, timedelta

    from engine.io.runfile import RunRecord, format_run_record

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


# ------------------------------------------------------------------------------------------
# Kalman ▸ Predict, fix sources, tests in the logs, Setup ▸ Current, immutability
# ------------------------------------------------------------------------------------------

DEMO = DATA / "DEMO.toml"


def _demo_session(cycles: int, **filter_changes: object) -> Session:
    cfg = load_config(DEMO)
    if filter_changes:
        cfg = cfg.replace(filter=replace(cfg.filter, **filter_changes))
    s = Session(cfg)
    s.run(max_cycles=cycles)
    return s


def test_predict_ellipse_does_not_depend_on_the_step() -> None:
    """Kalman ▸ Predict over 600 s from the demo's state after 10 min (coloured model, surfaced):
    the default q_mode "vanloan" integrates the noise exactly and Φ = I + FΔt is exact (F² = 0,
    F constant along a prediction), so steps of 1, 10, 60 and 600 s give the same ellipse to
    rounding (1e-9 relative; the sums of 600 steps lose ~1e-13). The thesis' per-step Q, by
    contrast, gives an ellipse that grows with the step (the audit's 2971 … 34283 m)."""
    s = _demo_session(600)
    assert s.context.filter_params.q_mode == "vanloan"  # the configuration default
    ell = [s.predict(600.0, h)[-1] for h in (1.0, 10.0, 60.0, 600.0)]
    ref = ell[0]
    assert ref.ellipse.a_m > 300.0  # a real prediction: 10 min of dead reckoning
    for e in ell[1:]:
        np.testing.assert_allclose(e.cov, ref.cov, rtol=1e-9)
        assert (e.x_m, e.y_m) == pytest.approx((ref.x_m, ref.y_m), abs=1e-6)
        assert e.ellipse.az_deg == pytest.approx(ref.ellipse.az_deg, abs=1e-6)
    t = _demo_session(600, q_mode="thesis")
    a_t = [t.predict(600.0, h)[-1].ellipse.a_m for h in (1.0, 600.0)]
    assert a_t[0] == pytest.approx(ref.ellipse.a_m, rel=1e-3)  # same model at Δt = 1 s …
    assert a_t[1] > 10 * a_t[0]  # … but not for a single 600-s step


def test_gps_receiver_switch_restarts_the_fix_error_states() -> None:
    """Coloured model (DEMO.toml): the Gauss–Markov pair's stationary VCV follows each LSE
    (frac·C_LSE, not frozen at the first fix); switching C/A → P code starts a new error
    process: at that epoch's prediction b = 0, P_bb = frac·C_LSE(P), no correlation with the
    navigation states, and Φ has zero rows for b (the smoother's link stays consistent)."""
    cfg = load_config(DEMO)
    frac = cfg.filter.fix_sigma_frac
    s = Session(cfg, collect_smoother=True)
    r = None
    for _ in range(300):
        r = s.step()
    fs = s.nav.filter
    assert fs.fix_states == ("fix_e", "fix_n")
    # refreshed each fix (the VCV the filter used: × the learnt factor, [filter] adapt)
    np.testing.assert_allclose(fs.fix_cov, frac * r.fix_cov_scale * r.fix.cov, rtol=1e-12)
    s.apply(SetGps(on=True, receiver="P"))
    r = s.step()
    assert "Fix source changed: fix-error states restarted" in r.messages
    start, pred, phi = r.smoother_link
    c_p = frac * r.fix_cov_scale * r.fix.cov
    # P code: σ 8.9 m per axis (THEORY D5) → C_LSE below (10 m)² per axis.
    assert np.all(np.diag(r.fix.cov) < 100.0)
    np.testing.assert_array_equal(pred.x[11:], [0.0, 0.0])
    np.testing.assert_allclose(pred.P[11:, 11:], c_p, rtol=1e-12)
    assert np.all(pred.P[11:, :11] == 0.0) and np.all(phi[11:, :] == 0.0)
    np.testing.assert_allclose(s.nav.filter.fix_cov, c_p, rtol=1e-12)
    # (start, pred, Φ) is a prediction: P_pred = Φ P Φᵀ + Q with Q_bb = frac·C_LSE(P).
    q = pred.P - phi @ start.P @ phi.T
    np.testing.assert_allclose(q[11:, 11:], c_p, rtol=1e-9)
    assert np.abs(q[:11, 11:]).max() < 1e-9
    r2 = s.step()  # the same source: no second restart
    assert not any("restarted" in m for m in r2.messages)
    sm = s.smooth()
    assert len(sm) == 302 and all(np.all(np.isfinite(e.cov)) for e in sm)


def test_sensor_update_tests_reach_the_result_the_out_log_and_jsonl(tmp_path: Path) -> None:
    """Both filter updates of a cycle keep their LOM/LS results: the gyro/log rows (before the
    step) and the fix rows (at the epoch). The LOM statistic is recomputed here from v̂ and S
    (v̂ᵀS⁻¹v̂/p, bounds χ²_p(0.025, 0.975)/p from scipy, THEORY §8.14, D30)."""
    import json

    from scipy.stats import chi2

    from engine.io.outlog import read_out_log

    s, res = _run(load_config(SAMPLE), out_path=tmp_path / "S.OUT",
                  jsonl_path=tmp_path / "S.jsonl")
    s.close()
    r = res[4]
    su, fu = r.sensor_update, r.filter_update
    assert su is not None and fu is not None
    assert su.labels == ("v_m", "psi_m") and fu.labels == ("x_LSE", "y_LSE")
    v, S = np.asarray(su.innovation), np.asarray(su.S)
    assert su.lom.t == pytest.approx(float(v @ np.linalg.solve(S, v)) / 2, rel=1e-10)
    assert su.lom.upper == pytest.approx(chi2.ppf(0.975, 2) / 2, rel=1e-5)
    cycle = read_out_log(tmp_path / "S.OUT").cycles[4]
    tests = [f for tag, f in cycle.lines if tag == "TEST"]
    assert [t["upd"] for t in tests] == ["epoch", "sensors"]  # epoch first (assess reads it)
    assert tests[1]["rows"] == "v_m,psi_m" and tests[1]["dof"] == 2
    assert tests[1]["lom"] == pytest.approx(su.lom.t, rel=1e-12)
    assert tests[0]["lom"] == pytest.approx(fu.lom.t, rel=1e-12)
    obj = json.loads((tmp_path / "S.jsonl").read_text().splitlines()[4])
    assert [t["upd"] for t in obj["tests"]] == ["epoch", "sensors"]
    assert obj["tests"][1]["rows"] == ["v_m", "psi_m"]
    assert obj["tests"][1]["verdict"] == su.lom.verdict
    assert obj["tests"][1]["ls"] == pytest.approx(np.round(su.ls.t, 3).tolist(), abs=1e-9)


def test_set_current_is_rotated_to_the_grid() -> None:
    """Setup ▸ Params ▸ Current gives the filter the current in the grid, like init_state:
    grid set = true set − γ with γ = arctan(tan(λ − λ0) sin φ) at the MPP (THEORY §8.4).
    Hand calculation with the spherical formula, which differs from the TM series by < 1e-6°
    this close to the CM (Δλ ≈ 0.47°): a 2-kn current setting 090° true."""
    s = Session(load_config(SAMPLE))
    s.step()
    s.step()
    lat, lon, cm = s.nav.mpp_lat_deg, s.nav.mpp_lon_deg, s.nav.cm_deg
    gamma = math.degrees(math.atan(math.tan(math.radians(lon - cm))
                                   * math.sin(math.radians(lat))))
    assert -0.40 < gamma < -0.35  # west of 5°E at 52.8°N: grid north is east of true north
    s.apply(SetCurrent(90.0, 2.0))
    vc = 2.0 * 1852.0 / 3600.0
    e, n = s.nav.filter.x[6], s.nav.filter.x[7]
    assert e == pytest.approx(vc * math.cos(math.radians(gamma)), abs=1e-8)
    assert n == pytest.approx(vc * math.sin(math.radians(gamma)), abs=1e-7)  # ≈ −6.6 mm/s
    assert n < -0.006


def test_cycle_result_arrays_are_read_only() -> None:
    """A cycle result is an immutable value: its covariances, the fix's arrays, the update's
    innovation/S/K and the smoother link's Φ cannot be written."""
    s = Session(load_config(SAMPLE))
    s.step()
    r = s.step()
    arrays = [r.mpp.cov, r.kf.cov, r.kf_pred.cov, r.fix.cov, r.fix.ellipse.eigenvectors,
              r.filter_update.K, r.filter_update.S, r.filter_update.innovation,
              r.sensor_update.K, r.smoother_link[2], r.filter_state.P]
    for a in arrays:
        with pytest.raises(ValueError):
            a[(0,) * a.ndim] = 1.0


def test_cycle_values_are_whole_frozen_dataclasses() -> None:
    """The cycle builds its CycleResult and NavState without the generated __init__ (speed,
    issue 14): every field is set on the instance, they compare equal to the same values
    built the ordinary way and stay frozen."""
    s = Session(load_config(SAMPLE))
    for _ in range(3):
        r = s.step()
        for value, cls in ((r, CycleResult), (s.nav, NavState)):
            # every slot set (an unset one raises AttributeError), no instance dict besides
            values = {f.name: getattr(value, f.name) for f in fields(cls)}
            assert not hasattr(value, "__dict__")
            assert cls(**values) == value
            with pytest.raises(FrozenInstanceError):
                value.n = 0  # type: ignore[misc]


def test_per_configuration_values_follow_the_configuration() -> None:
    """The systems string and the sensor status codes are computed once per configuration,
    and again for another one put in place (the console's pages do that)."""
    s = Session(load_config(SAMPLE))
    assert s.step().systems == systems_string(s.config)
    cfg = s.config
    off = cfg.replace(gps=replace(cfg.gps, on=False),
                      sensors=replace(cfg.sensors, rudder="on"))
    s.context.config = off
    r = s.step()
    assert r.systems == systems_string(off) != systems_string(cfg)
    assert r.sensors.status == tuple(off.sensors.status(n) for n in SENSOR_NAMES)
    s.context.config = cfg
    assert s.step().systems == systems_string(cfg)


def test_gps_on_another_datum_than_the_working_one() -> None:
    """The sample's .RUN positions read as ED50 (run_gps_datum) on a WGS84 working datum: the
    WGS84 fix shown on Pg 611/100 is the *received* ED50 position shifted once to WGS84, and
    the working-datum position is the same point (both WGS84 here). The ED50 → WGS84 shift is
    checked against PROJ in test_geodesy; at 52.8°N it moves the point ~ 95 m."""
    cfg = load_config(SAMPLE).replace(datum="WGS84")
    assert cfg.run_gps_datum == "ED50"
    s = Session(cfg)
    r = s.step()
    g = r.gps
    shift = datum_shift(s.datums.datum("ED50"), s.datums.datum("WGS84"))
    lat, lon, _h = shift.transform(g.lat_in_deg, g.lon_in_deg, 0.0)
    assert (g.wgs84_lat_deg, g.wgs84_lon_deg) == pytest.approx((lat, lon), abs=1e-12)
    assert (g.lat_deg, g.lon_deg) == pytest.approx((lat, lon), abs=1e-9)
    moved_m = math.hypot((lat - g.lat_in_deg) * 111_000,
                         (lon - g.lon_in_deg) * 111_000 * math.cos(math.radians(lat)))
    assert 50.0 < moved_m < 150.0


def test_implausible_pressure_depth_is_not_used(tmp_path: Path) -> None:
    """A crystal frequency that converts to a depth outside [-20 m, 11 km] (499 980 Hz gives
    −268 km with the demo's reference) is reported and kept out of the filter."""
    lines = [
        "920917 083539 - - - - - 19.0 10.0 - - 39939.662",  # the surface reference: 0 m
        "920917 083540 - - - - - 19.0 10.0 - - 499980.000",
        "920917 083541 - - - - - 19.0 10.0 - - 39939.662",
    ]
    run = tmp_path / "P.RUN"
    run.write_text("\n".join(lines) + "\n")
    s = Session(load_config(DATA / "DEMO.toml").replace(run_file=str(run)))
    r1, r2, r3 = s.step(), s.step(), s.step()
    assert r1.sensors.depth_m == pytest.approx(0.0, abs=1e-6)
    assert r2.sensors.depth_m is None
    assert any("implausible, not used" in m for m in r2.messages)
    assert abs(r3.mpp.depth_m) < 5.0 and abs(r3.filter_state.x[3]) < 10.0  # depth, speed sane


def _shift_gps(lines: list[str], rows: range, dlat_deg: int) -> list[str]:
    """The sample lines with the GPS latitude degrees of data rows ``rows`` moved by dlat_deg."""
    out = list(lines)
    for i in rows:
        f = out[i].split("\t")
        lat = f[2].split()
        lat[0] = f"{int(lat[0]) + dlat_deg:02d}"
        f[2] = " ".join(lat)
        out[i] = "\t".join(f)
    return out


def _gps_only_run(tmp_path: Path, lines: list[str]) -> list:
    cfg = load_config(SAMPLE)
    run = tmp_path / "G.RUN"
    run.write_text("\n".join(lines) + "\n")
    cfg = cfg.replace(run_file=str(run), decca=replace(cfg.decca, on=False))
    return _run(cfg)[1]


def test_a_gross_gps_error_is_kept_out_of_the_filter(tmp_path: Path) -> None:
    """A GPS fix 1° (111 km) north of the track is a gross error: the LSE follows it (GPS alone
    has no redundancy), the filter does not take it and says so; the MPP stays on the track."""
    lines = (DATA / "920917_1.RUN").read_text().splitlines()
    clean = _gps_only_run(tmp_path, lines)
    res = _gps_only_run(tmp_path, _shift_gps(lines, range(6, 7), 1))  # record 083543
    r = res[5]
    assert r.fix.y_m - clean[5].fix.y_m == pytest.approx(111_000, rel=0.01)
    assert any("gross error, not used (1 in a row)" in m for m in r.messages)
    # The gated epoch is the prediction: within 5 m of the clean run (one 1 s step of ~6.5 m,
    # whose clean update moves the estimate by a few metres at most).
    assert math.hypot(r.mpp.x_m - clean[5].mpp.x_m, r.mpp.y_m - clean[5].mpp.y_m) < 5.0
    assert res[6].mpp.source == "KF" and not any("gross" in m for m in res[6].messages)
    assert all(np.isfinite(x.filter_state.x).all() for x in res)


def test_three_gated_fixes_in_a_row_restart_the_filter_from_the_lse(tmp_path: Path) -> None:
    """From the third consecutive gross fix on, the fixes are believed: the filter position
    restarts from the LSE (THEORY D22), so a filter that went wrong cannot shut out every
    later fix. Records 083543–083547 are 1° south; the third, 083545, restarts the filter."""
    lines = (DATA / "920917_1.RUN").read_text().splitlines()
    res = _gps_only_run(tmp_path, _shift_gps(lines, range(6, 11), -1))
    assert [sum("gross error" in m for m in r.messages) for r in res] == [0] * 5 + [1, 1, 1, 0, 0]
    restart = res[7]
    assert any("re-initialised from the LSE after 3 gated fixes" in m for m in restart.messages)
    fs = restart.filter_state
    assert (float(fs.x[0]), float(fs.x[1])) == (restart.fix.x_m, restart.fix.y_m)
    # Afterwards the filter follows the shifted fixes: MPP within the LSE's 95 % axis.
    for r in res[8:]:
        assert math.hypot(r.mpp.x_m - r.fix.x_m, r.mpp.y_m - r.fix.y_m) < r.fix.ellipse.scaled(
            0.95)[0]

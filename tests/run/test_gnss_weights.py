"""GNSS receiver weights (HDOP × UERE per GGA quality) and the COG/SOG stand-in (issue 13,
parts 4–5; docs/GNSS_WEIGHTS.md), on synthetic record streams built directly as RunRecords."""

from __future__ import annotations

import math
from dataclasses import replace
from datetime import UTC, datetime, timedelta

import numpy as np
import pytest

from engine.errors import InputError
from engine.filter.kalman import FIX_TAU_GNSS_S, predict_step
from engine.io.runfile import RunRecord
from engine.run.config import RunConfig, parse_config_text
from engine.run.cycle import NavState, RunContext, build_context, initial_state, step
from engine.run.records import cycle_block, cycle_json
from engine.run.session import load_data
from engine.systems.gps import gps_weight
from engine.systems.sensors import KNOT_MS, standin_sigmas
from tests.paths import DATA

BASE = """
datum = "WGS84"
dr_position = "52 50 00 N 004 30 00 E"
run_gps_datum = "WGS84"
current_set_deg = 90.0
current_speed_kn = 1.0
[gps]
on = true
"""
T0 = datetime(2026, 7, 1, 10, 0, 0, tzinfo=UTC)


def _cfg(extra: str = "") -> RunConfig:
    return parse_config_text(BASE + extra, base_dir=DATA)


def _record(k: int, lat: float | None, lon: float | None, *, hdop: float | None = None,
            quality: int | None = None, sats: int | None = None, heading: float | None = None,
            speed: float | None = None, cog: float | None = None,
            sog: float | None = None) -> RunRecord:
    return RunRecord(k + 1, T0 + timedelta(seconds=k), lat, lon, (None, None, None), heading,
                     speed, None, gps_hdop=hdop, gps_quality=quality, gps_sats=sats,
                     cog_deg=cog, sog_kn=sog)


# --------------------------------------------------------------------------------------------
# The weight of one fix


def _hdop_of(az_el_deg: list[tuple[float, float]]) -> tuple[float, np.ndarray]:
    """HDOP of a satellite geometry and its (GᵀG)⁻¹, from the textbook definition: rows
    G = (−unit line of sight in east/north/up, 1), HDOP² = D_EE + D_NN (independent of the
    engine: numpy on the geometry)."""
    rows = []
    for az, el in az_el_deg:
        a, e = math.radians(az), math.radians(el)
        los = np.array([math.cos(e) * math.sin(a), math.cos(e) * math.cos(a), math.sin(e)])
        rows.append(np.append(-los, 1.0))
    G = np.array(rows)
    D = np.linalg.inv(G.T @ G)
    return math.sqrt(D[0, 0] + D[1, 1]), D


def test_receiver_sigma_is_hdop_times_uere_over_root_two() -> None:
    """σ_E² + σ_N² of a least-squares GNSS fix with equal, independent range errors σ_UERE is
    σ_UERE²·(D_EE + D_NN) = (HDOP·σ_UERE)², the horizontal d_rms². The engine's per-axis σ,
    twice squared, must equal it (tolerance 1e-12 relative: the same product in floating
    point); the geometry's own split is printed in the docs (here D_EE/D_NN ≠ 1)."""
    hdop, D = _hdop_of([(0, 15), (70, 40), (140, 65), (200, 20), (260, 50), (320, 30)])
    cfg = _cfg()
    for quality, uere in ((1, 5.0), (2, 1.5), (3, 3.0), (None, 5.0)):
        w = gps_weight(cfg, _record(0, 52.8, 4.5, hdop=hdop, quality=quality, sats=6))
        assert w.receiver_weighted and w.uere_m == uere
        drms2 = uere**2 * (D[0, 0] + D[1, 1])
        assert 2.0 * w.sigma_m**2 == pytest.approx(drms2, rel=1e-12)
    # RTK fixed: 0.05 m UERE would give σ ~ 4 cm; the floor (0.5 m per axis) stands.
    w = gps_weight(cfg, _record(0, 52.8, 4.5, hdop=hdop, quality=4))
    assert w.floored and w.sigma_m == 0.5
    assert "→ floor" in w.describe() and "RTK fixed" in w.describe()


def _dated(rec: RunRecord, when: datetime) -> RunRecord:
    return replace(rec, time=when)


SA_ERA = datetime(1992, 9, 17, 10, 0, 0)
"""The thesis' sample date (naive UTC, as a 1993 .RUN record's time)."""


def test_fixed_weights_without_hdop_or_when_configured() -> None:
    """No HDOP (every 1993 .RUN), an unusable one (0, NaN) dated before Selective Availability
    was switched off, or weights = "fixed": the 1993 figure, C/A 50 m × √(gps_se_sf 0.67) =
    40.93 m (2500 m² × 0.67 = 1675 m², THEORY D5)."""
    cfg = _cfg()
    for hdop in (None, 0.0, float("nan"), -1.0):
        w = gps_weight(cfg, _dated(_record(0, 52.8, 4.5, hdop=hdop, quality=2), SA_ERA))
        assert not w.receiver_weighted and w.sigma_m**2 == pytest.approx(1675.0, rel=1e-15)
    fixed = _cfg('weights = "fixed"\n')
    w = gps_weight(fixed, _record(0, 52.8, 4.5, hdop=1.0, quality=2))
    assert not w.receiver_weighted
    assert w.describe() == "σ 40.93 m = C/A code 50 m × √SE_SF 0.67"


SPS_2008_SIGMA_M = 17.0 / 2.447746830680816
"""GPS SPS Performance Standard, 4th ed. (2008): ≤ 17 m 95 % horizontal at the worst site; as
a circular normal, R95 = σ √(−2 ln 0.05) = 2.4477 σ (hand calculation: 6.945 m per axis)."""


def test_no_hdop_after_sa_gets_the_sps_2008_weight() -> None:
    """A C/A fix without an HDOP (RMC, GLL) dated after 2 May 2000 04:00 UTC gets the SPS
    Performance Standard 2008's worst-site σ; dated before, the SA-era 40.93 m; with
    ``weights = "fixed"``, a P receiver or the thesis preset, the 1993 figure whatever the date."""
    cfg = _cfg()
    rmc = _record(0, 52.8, 4.5)
    for when in (datetime(2013, 7, 31, 8, 30), datetime(2013, 7, 31, 8, 30, tzinfo=UTC),
                 datetime(2000, 5, 2, 4, 0, tzinfo=UTC)):
        w = gps_weight(cfg, _dated(rmc, when))
        assert w.origin == "sps" and w.sa_free and not w.receiver_weighted
        assert w.sigma_m == pytest.approx(SPS_2008_SIGMA_M, rel=1e-12)
        assert w.sigma_m == pytest.approx(6.945, abs=5e-4)
    for when in (SA_ERA, datetime(2000, 5, 2, 3, 59, 59, tzinfo=UTC), datetime(1999, 12, 31)):
        w = gps_weight(cfg, _dated(rmc, when))
        assert w.origin == "fixed" and w.sigma_m == pytest.approx(math.sqrt(1675.0), rel=1e-15)
    after = _dated(rmc, datetime(2013, 7, 31, 8, 30))
    for extra in ('weights = "fixed"\n', 'receiver = "P"\n'):
        w = gps_weight(_cfg(extra), after)
        assert w.origin == "fixed"
    thesis = parse_config_text(BASE + '[filter]\npreset = "thesis"\n', base_dir=DATA)
    assert gps_weight(thesis, after).origin == "fixed"
    # a GGA with a quality but an unusable HDOP, after SA: the SPS figure too
    w = gps_weight(cfg, _record(0, 52.8, 4.5, hdop=float("nan"), quality=1))
    assert w.origin == "sps" and "SPS PS 2008 worst site 17 m" in w.describe()


def test_sps_fix_is_weighted_so_in_the_cycle() -> None:
    """In the cycle the "sps" fix's variance is σ² (not the 1993 one), and the filter models
    its error as a modern receiver's (fix source ("GNSS", "?"): τ FIX_TAU_GNSS_S)."""
    ctx = build_context(_cfg(), *load_data(_cfg()))
    nav = initial_state(ctx.config)
    for k in range(3):
        nav, r = step(ctx, nav, _record(k, 52.8, 4.5 + 1e-5 * k, heading=90.0, speed=1.0))
    assert r.gps is not None and r.gps.weight.origin == "sps"
    assert r.fix is not None
    assert np.diag(r.fix.cov) == pytest.approx([SPS_2008_SIGMA_M**2] * 2, rel=1e-9)
    assert nav.fix_source is not None and nav.fix_source[-1] == ("GNSS", "?")


@pytest.mark.parametrize(("text", "field"), [
    ('[gps]\nuere_sps_m = 0.0\n', "gps.uere_sps_m"),
    ('[gps]\nuere_rtk_fixed_m = -1\n', "gps.uere_rtk_fixed_m"),
    ('[gps]\nsigma_floor_m = 0.0\n', "gps.sigma_floor_m"),
    ('[gps]\nweights = "hdop"\n', "gps.weights"),
    ('[sensors]\ncog_sog = "on"\n', "sensors.cog_sog"),
    ('[sensors]\ncog_min_sog_kn = 11\n', "sensors.cog_min_sog_kn"),
])
def test_bad_keys_name_their_field(text: str, field: str) -> None:
    with pytest.raises(InputError) as err:
        parse_config_text(text, filename="x.toml")
    assert err.value.field == field and "x.toml" in str(err.value)


# --------------------------------------------------------------------------------------------
# Through the cycle


def _track(n: int, course_deg: float, speed_kn: float, ctx: RunContext,
           cur_set_deg: float = 90.0, cur_kn: float = 1.0) -> tuple[list[tuple[float, float]],
                                                                  float, float]:
    """True positions (lat, lon) at 1 s of a vessel steering ``course_deg`` through the water at
    ``speed_kn`` in a current: (positions, COG deg, SOG kn) over ground (flat grid, CM 5°)."""
    grid = ctx.grid(5.0)
    x0, y0 = grid.forward(52 + 50 / 60, 4.5)
    v = speed_kn * KNOT_MS
    c = cur_kn * KNOT_MS
    ve = v * math.sin(math.radians(course_deg)) + c * math.sin(math.radians(cur_set_deg))
    vn = v * math.cos(math.radians(course_deg)) + c * math.cos(math.radians(cur_set_deg))
    pos = [grid.inverse(x0 + ve * k, y0 + vn * k) for k in range(n)]
    return pos, math.degrees(math.atan2(ve, vn)) % 360.0, math.hypot(ve, vn) / KNOT_MS


def _run(ctx: RunContext, recs: list[RunRecord]) -> tuple[NavState, list]:
    nav = initial_state(ctx.config)
    out = []
    for rec in recs:
        nav, r = step(ctx, nav, rec)
        out.append(r)
    return nav, out


def test_hdop_weight_reaches_the_lse_and_a_quality_change_restarts_the_fix_states() -> None:
    """GPS-only fixes: the LSE VCV is the a priori one (two coordinate rows, no redundancy), so
    its diagonal must be (HDOP·UERE/√2)² exactly; the filter's fix-error pair takes τ =
    FIX_TAU_GNSS_S; SPS → DGPS restarts it with P_bb = 0.99·C_LSE(DGPS) and says so."""
    ctx = build_context(_cfg(), *load_data(_cfg()))
    pos, _cog, _sog = _track(40, 45.0, 6.0, ctx)
    recs = [_record(k, *pos[k], hdop=1.2, quality=1 if k < 30 else 2, sats=8, heading=45.0,
                    speed=6.0) for k in range(40)]
    nav, res = _run(ctx, recs)
    sps = (1.2 * 5.0 / math.sqrt(2.0)) ** 2
    np.testing.assert_allclose(np.diag(res[10].fix.cov), [sps, sps], rtol=1e-9)
    assert res[10].gps.weight.describe() == "σ 4.24 m = HDOP 1.2 × UERE 5 m (SPS) / √2"
    fs = res[29].filter_state
    assert fs.fix_states == ("fix_e", "fix_n") and fs.fix_tau_s == (FIX_TAU_GNSS_S,) * 2
    r = res[30]
    assert "GNSS fix SPS → DGPS: fix-error states restarted" in r.messages
    dgps = (1.2 * 1.5 / math.sqrt(2.0)) ** 2
    np.testing.assert_allclose(np.diag(r.fix.cov), [dgps, dgps], rtol=1e-9)
    _start, pred, _phi = r.smoother_link
    np.testing.assert_allclose(pred.P[11:, 11:], 0.99 * r.fix.cov, rtol=1e-9)
    np.testing.assert_array_equal(pred.x[11:], [0.0, 0.0])
    assert not any("restarted" in m for rr in res[31:] for m in rr.messages)
    assert nav.fix_source == ("GPS", "C/A", ("GNSS", "DGPS"))


def test_a_record_without_gps_keeps_the_receiver_part_of_the_source() -> None:
    """A gap in the fixes (no GPS in a record) is no new error process: nothing restarts."""
    ctx = build_context(_cfg(), *load_data(_cfg()))
    pos, _c, _s = _track(30, 45.0, 6.0, ctx)
    recs = [_record(k, *(pos[k] if k % 7 else (None, None)), hdop=1.0, quality=2,
                    heading=45.0, speed=6.0) for k in range(30)]
    _nav, res = _run(ctx, recs)
    assert not any("restarted" in m for r in res for m in r.messages)


def _standin_records(ctx: RunContext, n: int, gap: range) -> tuple[list[RunRecord],
                                                                   list[tuple[float, float]],
                                                                   float, float]:
    pos, cog, sog = _track(n, 30.0, 6.0, ctx)
    rng = np.random.default_rng(13)
    grid = ctx.grid(5.0)
    recs = []
    for k in range(n):
        x, y = grid.forward(*pos[k])
        ex, ey = rng.normal(0.0, 1.2 * 1.5 / math.sqrt(2.0), 2)  # DGPS at HDOP 1.2: the weight
        lat, lon = (None, None) if k in gap else grid.inverse(x + ex, y + ey)
        recs.append(_record(k, lat, lon, hdop=1.2, quality=2, sats=9,
                            cog=(cog + rng.normal(0.0, 1.0)) % 360.0,
                            sog=sog + rng.normal(0.0, 0.05)))
    return recs, pos, cog, sog


def test_without_the_standin_a_log_without_heading_is_lse_only() -> None:
    ctx = build_context(_cfg(), *load_data(_cfg()))
    recs, _pos, _cog, _sog = _standin_records(ctx, 20, range(0))
    _nav, res = _run(ctx, recs)
    assert res[0].messages[0].startswith("No gyro heading or log speed: no dead reckoning, LSE "
                                         "only (COG/SOG in the record")
    assert all(r.filter_state is None and r.mpp.source == "LSE" for r in res)
    assert sum("No gyro heading" in m for r in res for m in r.messages) == 1  # said once


def test_cog_sog_standin_starts_the_filter_and_dead_reckons_over_ground() -> None:
    """COG/SOG only (a yacht's log): with ``cog_sog = "standin"`` the filter starts over ground
    with the current at 0 (although 1 kn is configured: SOG/COG already hold it), the heading
    and speed rows carry the stand-in σ (:func:`standin_sigmas`), and through a 120-s gap in
    the fixes it dead-reckons: the truth stays inside 3σ of the filter's position (the DR error
    of 120 s at 1° COG noise and 0.05 kn SOG noise, averaged, is a few metres) — with the
    current double-counted it would be 1 kn × 120 s = 62 m off."""
    cfg = _cfg('[sensors]\ncog_sog = "standin"\n')
    ctx = build_context(cfg, *load_data(cfg))
    gap = range(200, 320)
    recs, pos, _cog, sog = _standin_records(ctx, 330, gap)
    _nav, res = _run(ctx, recs)
    first = res[0]
    assert first.sensors.reference == "ground" and first.filter_state is not None
    assert "COG/SOG stand in for the missing gyro/log" in first.messages[0]
    np.testing.assert_array_equal(first.filter_state.x[6:8], [0.0, 0.0])  # current
    h_sigma, s_sigma = standin_sigmas(recs[5].sog_kn)
    assert first.sensors.heading_sigma_deg == pytest.approx(standin_sigmas(recs[0].sog_kn)[0])
    u = res[5].sensor_update
    assert u.labels == ("v_m", "psi_m")
    # R of the rows the cycle used = S − H P Hᵀ, P the state the update started from (the
    # previous epoch's), H the 1s of v + log bias and ψ + gyro bias (eqs. 6.27–6.28).
    P = res[4].filter_state.P
    H = np.zeros((2, P.shape[0]))
    H[0, [3, 8]] = 1.0
    H[1, [4, 9]] = 1.0
    R = u.S - H @ P @ H.T
    np.testing.assert_allclose(np.sqrt(np.diag(R)), [s_sigma, math.radians(h_sigma)],
                               rtol=1e-6)
    assert h_sigma == 3.0  # 6.5 kn: atan(0.1/3.3) = 1.7° < the 3° floor
    assert s_sigma == pytest.approx(max(0.1, 0.03 * recs[5].sog_kn * KNOT_MS), rel=1e-12)
    grid = ctx.grid(5.0)
    for k in (gap[-1],):
        r = res[k]
        assert r.fix is None and r.filter_state is not None and r.mpp.source == "KF"
        tx, ty = grid.forward(*pos[k])
        e = np.array([r.mpp.x_m - tx, r.mpp.y_m - ty])
        d2 = float(e @ np.linalg.solve(r.mpp.cov, e))
        assert d2 < 9.0 * 2, (d2, e)  # inside ~3σ (χ²₂ 99.9 % is 13.8)
    # The accuracy of the stand-in itself, without the learnt fix factor: these synthetic fixes
    # are white (σ = the weight), not the receiver's 99 % Gauss–Markov model, so their NIS
    # drives λ towards its bound (47 by the gap: the factor cannot tell a whiter error from a
    # larger one) and the filter then learns the current from fixes 7 × wider (35 m here).
    cfg_fixed = _cfg('[sensors]\ncog_sog = "standin"\n[filter]\nadapt = false\n')
    ctx_fixed = build_context(cfg_fixed, *load_data(cfg_fixed))
    _nav, res_fixed = _run(ctx_fixed, recs)
    r = res_fixed[gap[-1]]
    tx, ty = grid.forward(*pos[gap[-1]])
    e = np.array([r.mpp.x_m - tx, r.mpp.y_m - ty])
    assert math.hypot(*e) < 30.0, e
    # The .OUT says it per cycle: SENS ref=ground with the σ used, GPS with the receiver weight.
    head, lines = cycle_block(res[5])
    sens = dict(lines)["SENS"]
    assert sens["ref"] == "ground" and sens["s_hdg"] == h_sigma
    gps = dict(lines)["GPS"]
    assert gps["hdop"] == 1.2 and gps["q"] == 2 and gps["sats"] == 9 and gps["uere"] == 1.5
    js = cycle_json(res[5])
    assert js["dr"] == "ground" and js["gps_weight"]["quality"] == 2
    assert head["n"] == 6


def test_a_1993_cycle_block_has_no_new_fields() -> None:
    """A .RUN record (no HDOP, no COG/SOG) writes exactly the keys it wrote before."""
    cfg = _cfg()
    ctx = build_context(cfg, *load_data(cfg))
    pos, _c, _s = _track(3, 45.0, 6.0, ctx)
    _nav, res = _run(ctx, [_record(k, *pos[k], heading=45.0, speed=6.0) for k in range(3)])
    _head, lines = cycle_block(res[2])
    d = dict(lines)
    assert set(d["SENS"]) == {"gyro", "log", "rudder", "incl", "depth", "echo", "conv"}
    assert set(d["GPS"]) == {"lat_in", "lon_in", "lat", "lon", "x", "y", "hg"}
    assert "dr" not in cycle_json(res[2]) and "gps_weight" not in cycle_json(res[2])


def test_first_fix_correlates_the_fix_states_and_a_rising_hdop_inflates_them() -> None:
    """Receiver weights, SPS (UERE 5 m): the filter's position is taken from the first LSE, so
    its error is that fix's error b + w: cov(x̂ − x, b̂ − b) = −0.99·C (hand: C = (1.0·5/√2)²
    = 12.5 m² per axis → −12.375). When the HDOP goes 1.0 → 2.0 the stationary VCV of the
    states grows by 0.99·(50 − 12.5) = 37.125 m² per axis, added to their predicted variance
    at once (tolerance 1e-9 relative: the same sums)."""
    ctx = build_context(_cfg(), *load_data(_cfg()))
    pos, _c, _s = _track(12, 45.0, 6.0, ctx)
    recs = [_record(k, *pos[k], hdop=1.0 if k < 10 else 2.0, quality=1, heading=45.0,
                    speed=6.0) for k in range(12)]
    _nav, res = _run(ctx, recs)
    first = next(r for r in res if r.filter_state is not None and r.filter_state.fix_states)
    P = first.filter_state.P
    np.testing.assert_allclose(P[11:, 11:], 0.99 * 12.5 * np.eye(2), rtol=1e-9)
    np.testing.assert_allclose(P[:2, 11:], -0.99 * 12.5 * np.eye(2), rtol=1e-9)
    start, pred, _phi = res[10].smoother_link
    plain = predict_step(start, 1.0, ctx.filter_params)[0]
    np.testing.assert_allclose(pred.P[11:, 11:] - plain.P[11:, 11:], 37.125 * np.eye(2),
                               rtol=1e-9)
    np.testing.assert_allclose(pred.x, plain.x, rtol=0, atol=0)  # the estimate is unchanged
    # Falling back to HDOP 1.0 adds nothing (the decay over τ is the cautious side).
    recs2 = [*recs[:11], *[_record(k, *pos[k], hdop=1.0, quality=1, heading=45.0, speed=6.0)
                           for k in (11,)]]
    _nav2, res2 = _run(ctx, recs2)
    start, pred, _phi = res2[11].smoother_link
    np.testing.assert_allclose(pred.P, predict_step(start, 1.0, ctx.filter_params)[0].P,
                               rtol=1e-12)

"""GPS-denied experiment (engine/assess/denied.py, ``uvnav denied``) on the simulated demo,
where the truth is known, so "the filter does better than extrapolating" can be checked.

Independent sources: the truth's WGS84 columns read with pandas (the experiment converts the
working-datum columns itself), the straight COG/SOG extrapolation recomputed here with
:class:`pyproj.Geod` from the ``.RUN`` fixes, and the window arithmetic by hand.
"""

from __future__ import annotations

import math
from dataclasses import fields
from datetime import UTC, datetime, timedelta

import pandas as pd
import pytest
from pyproj import Geod

from engine.assess.accuracy import read_truth
from engine.assess.denied import (
    DeniedReport,
    Reference,
    denied_experiment,
    hide_positions,
    truth_reference,
    window_starts,
)
from engine.io.runfile import RunRecord, iter_run_file
from engine.run.session import load_run_config
from tests.paths import DATA
from uvnav_tui.cli.main import main

GEOD = Geod(ellps="WGS84")
T0 = datetime(1992, 9, 17, 10, 0, 0, tzinfo=UTC)
# The demo's surfaced phase is 10:00–10:45 (data/DEMO.scenario.toml): windows of 10 min starting
# every 5 min from 10:05 to 10:35 lie inside it, across the turns at 10:10, 10:20 and 10:35.
STARTS = [T0 + timedelta(seconds=s) for s in range(300, 2101, 300)]


@pytest.fixture(scope="module")
def truth_wgs84() -> Reference:
    """The truth's own WGS84 columns, read with pandas."""
    df = pd.read_csv(DATA / "DEMO.truth.csv", comment="#")
    times = pd.to_datetime(df["time"], utc=True)
    return {t.to_pydatetime(): (la, lo) for t, la, lo in
            zip(times, df["lat_wgs84"], df["lon_wgs84"], strict=True)}


@pytest.fixture(scope="module")
def demo_report(truth_wgs84: Reference) -> DeniedReport:
    cfg, data = load_run_config(DATA / "DEMO.toml")
    return denied_experiment(cfg, data, iter_run_file(DATA / "DEMO.RUN"), [600.0],
                             starts=STARTS, checkpoints_s=(60.0, 300.0, 600.0), truth=truth_wgs84)


def test_hide_positions_removes_every_position_input_and_keeps_the_sensors() -> None:
    rec = RunRecord(7, T0, 52.8, 4.5, (0.1, 0.2, 0.3), 232.4, 10.2, 0.0, 0.4, 39938.4, 69.9,
                    "raw", gps_hdop=0.9, gps_quality=2, gps_sats=9, cog_deg=231.0, sog_kn=10.1)
    hidden = hide_positions(rec)
    assert (hidden.gps_lat_deg, hidden.gps_lon_deg, hidden.decca) == (None, None,
                                                                      (None, None, None))
    assert (hidden.gps_hdop, hidden.gps_quality, hidden.gps_sats) == (None, None, None)
    assert (hidden.cog_deg, hidden.sog_kn) == (None, None)
    kept = [f.name for f in fields(RunRecord) if f.name not in (
        "gps_lat_deg", "gps_lon_deg", "decca", "gps_hdop", "gps_quality", "gps_sats", "cog_deg",
        "sog_kn")]
    assert all(getattr(hidden, n) == getattr(rec, n) for n in kept)
    both = hide_positions(rec, hide_heading_speed=True)
    assert (both.heading_deg, both.speed_kn, both.rudder_deg) == (None, None, 0.0)


def test_window_starts_by_hand() -> None:
    times = [T0 + timedelta(seconds=s) for s in range(0, 2023)]  # 0 … 2022 s
    # 300 + k·300 + 600 ≤ 2022  →  k ≤ 3.74: starts at 300, 600, 900, 1200 s.
    assert window_starts(times, 600.0) == [T0 + timedelta(seconds=s) for s in (300, 600, 900,
                                                                                1200)]
    assert window_starts(times, 1800.0, warmup_s=120.0) == [T0 + timedelta(seconds=120)]
    assert window_starts(times, 1800.0) == []


def test_truth_reference_matches_the_truth_files_wgs84_columns(truth_wgs84: Reference) -> None:
    """The experiment converts the truth's ED50 columns to WGS84 (h = 0 on ED50); the
    simulator wrote the WGS84 point whose h = 0 conversion gives them. The two differ only by
    the height's effect (< 1 mm) and the CSV's 9 decimals (1e-9° ≈ 0.1 mm): 5 mm allowed."""
    _cfg, (datums, _chains) = load_run_config(DATA / "DEMO.toml")
    ref = truth_reference(read_truth(DATA / "DEMO.truth.csv"), datums)
    for t in (T0, T0 + timedelta(seconds=1234), T0 + timedelta(seconds=7199)):
        _a, _b, d = GEOD.inv(ref[t][1], ref[t][0], truth_wgs84[t][1], truth_wgs84[t][0])
        assert d < 0.005


def test_cog_sog_extrapolation_recomputed_with_pyproj(demo_report: DeniedReport,
                                                    truth_wgs84: Reference) -> None:
    """The straight extrapolation: the .RUN has no COG/SOG, so they come from the fixes 60 s
    apart ending at the last fix; recomputed here from the records with pyproj (same formula,
    written independently). Tolerance 1 mm: both are double-precision geodesics."""
    recs = {r.time: r for r in iter_run_file(DATA / "DEMO.RUN") if isinstance(r, RunRecord)}
    assert len(demo_report.windows) == len(STARTS)
    for w in demo_report.windows:
        a, b = recs[w.start - timedelta(seconds=60)], recs[w.start]
        az, _baz, dist = GEOD.inv(a.gps_lon_deg, a.gps_lat_deg, b.gps_lon_deg, b.gps_lat_deg)
        assert w.cogsog_source == "fixes"
        assert w.cog_deg == pytest.approx(az % 360.0, abs=1e-9)
        for p in w.points:
            lon, lat, _ = GEOD.fwd(b.gps_lon_deg, b.gps_lat_deg, az, dist / 60.0 * p.elapsed_s)
            ref = truth_wgs84[w.start + timedelta(seconds=p.elapsed_s)]
            _a, _b, err = GEOD.inv(lon, lat, ref[1], ref[0])
            assert p.cogsog_error_m == pytest.approx(err, abs=1e-3)
            assert p.elapsed_s == p.checkpoint_s  # 1 Hz records: every checkpoint has a record


def test_filter_beats_extrapolation_with_the_truth_known(demo_report: DeniedReport) -> None:
    """With the truth known, the filter's dead reckoning through a 10-min GPS + Decca outage
    must beat both extrapolations. Why it should: it has the same gyro and log as the
    heading/water-speed DR, plus the current (0.5 kn simulated, i.e. 154 m in 10 min) learnt
    while the fixes came in; the straight COG/SOG line cannot follow the demo's turns (232° →
    270° → 315° → 250°). Measured: medians 39 / 119 / 1053 m at 10 min."""
    rows = {r.checkpoint_s: r for r in demo_report.rows}
    assert set(rows) == {60.0, 300.0, 600.0} and all(r.n == len(STARTS) for r in rows.values())
    for cp in (300.0, 600.0):
        r = rows[cp]
        assert r.filter_m[0] < r.hdgstw_m[0] < r.cogsog_m[0]
        assert r.filter_m[1] < r.hdgstw_m[1]  # the 90th percentile too
    # The error grows with time since the last fix, for every estimator (medians).
    assert rows[60.0].hdgstw_m[0] < rows[600.0].hdgstw_m[0]
    assert rows[60.0].cogsog_m[0] < rows[600.0].cogsog_m[0]
    assert rows[60.0].a95_median_m < rows[600.0].a95_median_m  # the ellipse grows too


def test_filter_ellipse_holds_the_truth(demo_report: DeniedReport) -> None:
    """The console's 95 % ellipse after 5 and 10 min of dead reckoning holds the truth in at
    least 5 of the 7 windows: with an honest ellipse the chance of 4 or fewer is 0.4 %
    (binomial, 7 trials, p = 0.95; the windows overlap, so this is only indicative)."""
    for r in demo_report.rows:
        if r.checkpoint_s >= 300.0:
            assert r.coverage * r.n >= 5
    for w in demo_report.windows:
        assert all(p.mpp_source == "KF" and math.isfinite(p.filter_nees) for p in w.points)


def test_cli_prints_the_table_and_rejects_bad_input(capsys: pytest.CaptureFixture[str]) -> None:
    rc = main(["denied", str(DATA / "DEMO.RUN"), "--window", "600", "--start", "10:05:00",
               "--start", "1992-09-17T10:20:00", "--checkpoint", "60", "--checkpoint", "600",
               "--truth", str(DATA / "DEMO.truth.csv"), "--windows"])
    out = capsys.readouterr().out
    assert rc == 0
    assert "reference: truth" in out and "windows run 2" in out
    assert "window 10:05:00Z" in out and "window 10:20:00Z" in out
    rows = [ln.split() for ln in out.splitlines() if ln.startswith("10 min")]
    assert [r[2:5] for r in rows] == [["1", "min", "2"], ["10", "min", "2"]]
    assert main(["denied", str(DATA / "DEMO.RUN"), "--window", "-5"]) == 2
    assert "--window: Must be a number of seconds > 0 and at most 30 days (2592000) !" in \
        capsys.readouterr().err
    assert main(["denied", str(DATA / "DEMO.RUN"), "--start", "25:99"]) == 2
    assert "--start: Wrong start time" in capsys.readouterr().err
    assert main(["denied", str(DATA / "DEMO.RUN"), "--window", "86400"]) == 3
    assert "no window fits" in capsys.readouterr().err
    assert main(["denied", str(DATA / "nope.RUN")]) == 2
    assert "nope.RUN" in capsys.readouterr().err


def test_denied_reads_a_junk_log_in_bounded_memory(tmp_path, capsys) -> None:
    """30,000 junk ``$`` lines (no log, no .RUN): every one is a bad record, counted and not
    kept (the whole list was kept: 2.9 kB a line, 1.28 GB for 500,000 lines)."""
    import random
    import tracemalloc

    from tests.cli.test_replay_nmea import write_config

    rnd = random.Random(7)
    junk = tmp_path / "junk.nmea"
    junk.write_text("".join(
        "$" + "".join(rnd.choice("ABCDEFGHIJ0123456789,.*") for _ in range(rnd.randint(5, 70)))
        + "\n" for _ in range(30_000)))
    write_config(tmp_path / "junk.toml", "junk.nmea")
    small = tmp_path / "small.nmea"  # a first run loads every module outside the measurement
    small.write_text("$junk\n")
    write_config(tmp_path / "small.toml", "small.nmea")
    assert main(["denied", str(small)]) == 3
    tracemalloc.start()
    try:
        rc = main(["denied", str(junk)])
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert rc == 3
    assert "0 records , skipped 30000" in capsys.readouterr().out
    assert peak < 20e6  # bytes; the list of bad records alone was ~87 MB


def test_denied_counts_every_damaged_line_of_a_log(tmp_path, capsys) -> None:
    """231 damaged lines in an NMEA log: 'skipped 231' (it said 20: the bad records returned)."""
    from tests.cli.test_replay_nmea import write_config, write_log
    from tests.nmea_lines import nmea

    log = tmp_path / "trip.nmea"
    write_log(log, n=30)
    with open(log, "a") as fh:
        fh.write((nmea("HEHDT,12.0,T")[:-2] + "00\n") * 231)
    write_config(tmp_path / "trip.toml", "trip.nmea")
    assert main(["denied", str(log), "--window", "10", "--warmup", "5",
                 "--checkpoint", "10"]) == 0
    out = capsys.readouterr().out
    assert "30 records " in out and ", skipped 231" in out

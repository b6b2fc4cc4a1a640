"""Real NMEA 0183 logs of sailing yachts (data/nmea/, sources and licences in its README.md):
each replays end to end, and the GPS-denied experiment gives sane numbers on one of them
(docs/REALDATA.md).

Independent source: every log is read again here with pynmea2 directly (not through UVNAV's
reader): its own speed over ground, integrated over time, and its own first and last fix are
what the replayed track is held to.
"""

from __future__ import annotations

import dataclasses
import json
import math
from datetime import UTC, datetime, timedelta
from pathlib import Path

import pynmea2
import pytest
from pyproj import Geod

from engine.assess.denied import DeniedReport, denied_experiment, run_records
from engine.run.config import resolve_vessel
from engine.run.session import load_run_config
from tests.paths import DATA
from uvnav_tui.cli.main import main

GEOD = Geod(ellps="WGS84")
NMEA = DATA / "nmea"
LOGS = ("avnav-markermeer-20160815", "avnav-baltic-20130731", "signalk-plaka-gulf-of-finland")
# The two long logs (3.7 h and 4.1 h, 13 000–15 000 epochs) take 15–25 s each: slow tests.
LOG_PARAMS = [LOGS[0], *(pytest.param(n, marks=pytest.mark.slow) for n in LOGS[1:])]
KNOT_MS = 1852.0 / 3600.0


def pynmea2_track(path: Path, day: datetime | None = None
                  ) -> list[tuple[datetime, float, float, float]]:
    """(time, lat, lon, SOG kn) of every valid RMC, or of every valid GLL with the SOG of the
    VTG before it (a log without RMC), read with pynmea2; ``day`` dates a log without a date."""
    out: list[tuple[datetime, float, float, float]] = []
    sog = math.nan
    with open(path, encoding="ascii", errors="replace") as fh:
        for line in fh:
            try:
                m = pynmea2.parse(line.strip(), check=True)
            except pynmea2.ParseError:
                continue
            if isinstance(m, pynmea2.VTG) and m.spd_over_grnd_kts is not None:
                sog = float(m.spd_over_grnd_kts)
            elif isinstance(m, pynmea2.RMC) and m.status == "A":
                t = datetime.combine(m.datestamp, m.timestamp).replace(tzinfo=UTC)
                out.append((t, m.latitude, m.longitude, float(m.spd_over_grnd)))
            elif isinstance(m, pynmea2.GLL) and m.status == "A" and day is not None:
                t = datetime.combine(day.date(), m.timestamp).replace(tzinfo=UTC)
                out.append((t, m.latitude, m.longitude, sog))
    return out


def length_m(points: list[tuple[float, float]], every: int) -> float:
    """Geodesic length of the track through every ``every``-th point and the last (m)."""
    sub = points[::every] + [points[-1]]
    return sum(GEOD.inv(a[1], a[0], b[1], b[0])[2] for a, b in zip(sub, sub[1:], strict=False))


@pytest.mark.parametrize("name", LOG_PARAMS)
def test_real_log_replays_end_to_end(name: str, tmp_path: Path,
                                     capsys: pytest.CaptureFixture[str]) -> None:
    """Exit 0, sentences used, and the MPP track agrees with the log's own motion.

    Tolerances: the MPP track sampled every 60 epochs must have the length of the log's SOG
    integrated over time within 2 % (a yacht's turns cut by 60-s chords shorten it by well under
    1 %; SOG is printed to 0.1 kn, about 2 % of 5 kn, but its rounding averages out over
    thousands of sentences; measured 0.04 % and 0.3 %); its start must be the first fix within
    1 m (the first LSE is the MPP) and its end within 100 m of the last fix (the filter lags a
    moving fix by less than its 95 % ellipse, ~65 m here; measured 18 m)."""
    jsonl = tmp_path / f"{name}.jsonl"
    rc = main(["replay", str(NMEA / f"{name}.nmea"), "--no-out", "--jsonl", str(jsonl)])
    out = capsys.readouterr().out
    assert rc == 0
    used = next(ln for ln in out.splitlines() if "sentences used:" in ln)
    counts = [int(tok.strip(",")) for tok in used.split("sentences used:")[1].split()[1::2]]
    assert counts and min(counts) > 0
    mpp = [(o["mpp"]["lat"], o["mpp"]["lon"]) for o in map(json.loads, jsonl.open())]
    day = None if name != LOGS[2] else datetime(2014, 7, 18, tzinfo=UTC)
    ref = pynmea2_track(NMEA / f"{name}.nmea", day)
    sog_m = sum(a[3] * KNOT_MS * (b[0] - a[0]).total_seconds()
                for a, b in zip(ref, ref[1:], strict=False) if math.isfinite(a[3]))
    assert length_m(mpp, 60) == pytest.approx(sog_m, rel=0.02)
    assert GEOD.inv(mpp[0][1], mpp[0][0], ref[0][2], ref[0][1])[2] < 1.0
    assert GEOD.inv(mpp[-1][1], mpp[-1][0], ref[-1][2], ref[-1][1])[2] < 100.0


@pytest.fixture(scope="module")
def markermeer() -> DeniedReport:
    cfg, data = load_run_config(NMEA / "avnav-markermeer-20160815.toml")
    return denied_experiment(cfg, data, run_records(cfg), [600.0], every_s=120.0,
                             warmup_s=120.0, checkpoints_s=(60.0, 300.0, 600.0))


def test_denied_on_real_data_gives_sane_numbers(markermeer: DeniedReport) -> None:
    """The GPS-denied experiment on the Markermeer log (heading and water speed, 1 Hz fixes).

    Why these bounds: the filter has the same heading and water speed as the plain DR, plus the
    current / log-bias states it learnt from the fixes before the outage, so its median error
    must not be worse than the heading/water-speed DR (measured 41 m against 238 m at 10 min);
    the error grows with time for every estimator; and 10 minutes at ~4.8 kn is ~1500 m sailed,
    of which the filter must keep its median error under 10 % (measured 2.7 %)."""
    rows = {r.checkpoint_s: r for r in markermeer.rows}
    assert set(rows) == {60.0, 300.0, 600.0}
    assert all(r.n >= 10 for r in rows.values())  # starts 11:51:41 … 12:11:41, every 2 min
    for cp in (300.0, 600.0):
        assert rows[cp].filter_m[0] <= rows[cp].hdgstw_m[0]
    for est in ("filter_m", "cogsog_m", "hdgstw_m"):
        assert getattr(rows[60.0], est)[0] < getattr(rows[600.0], est)[0]
    assert rows[600.0].filter_m[0] < 150.0


def test_denied_ellipse_holds_the_hidden_fix_on_real_data(markermeer: DeniedReport) -> None:
    """The console's 95 % ellipse after 1, 5 and 10 minutes without GNSS holds the hidden fix in
    at least 9 of the 11 Markermeer windows (``filter.vessel = "surface"``, docs/CONFIG.md "The
    vessel decision"; measured 10–11 of 11). An honest ellipse misses with p = 0.05, so 8 or
    fewer of 11 independent windows has probability 1.5 % (binomial); the windows overlap and
    share one afternoon's leeway, so that is indicative only. With the thesis' submarine gyro
    and log σ the ellipse held it in 9 % of the windows at 5 and 10 minutes (every 60 s,
    docs/REALDATA.md): a filter that claims more than it knows fails here first. The fix's own
    error (HDOP 0.5: σ ≈ 1.8 m per axis) is not in the ellipse; it matters a little at 1 minute
    (a95 8 m), not at 5 and 10 (45 and 117 m)."""
    for r in markermeer.rows:
        assert r.n == 11
        assert r.coverage * r.n >= 9, r


@pytest.mark.slow
def test_standin_outage_ellipse_holds_the_hidden_fix_on_plaka() -> None:
    """COG/SOG stand-in (no heading in the log) through 10-minute GNSS outages on the Plaka log:
    the filter coasts on its process noise (the "surface" vessel's), and its 95 % ellipse must
    miss the hidden fix in at most 3 of the 23–24 windows at 1, 5 and 10 minutes (an honest
    ellipse misses 4 or more with probability 3.0 %, binomial n = 24, p = 0.05; measured 0–1
    misses); the windows are 10 minutes apart and do not overlap, though they share a day's
    wind). Before the vessel
    preset and with the log's water speed fed into the ground speed, 40 % at 10 minutes
    (docs/REALDATA.md)."""
    cfg, data = load_run_config(NMEA / "signalk-plaka-gulf-of-finland.toml")
    cfg = cfg.replace(sensors=dataclasses.replace(cfg.sensors, cog_sog="standin"))
    assert resolve_vessel(cfg).filter.vessel == "surface"
    rep = denied_experiment(cfg, data, run_records(cfg), [600.0], every_s=600.0,
                            warmup_s=300.0, checkpoints_s=(60.0, 300.0, 600.0))
    for r in rep.rows:
        assert r.n >= 23  # 24 starts; a checkpoint without a fix within 5 s is not scored
        assert r.n - round(r.coverage * r.n) <= 3, r


def gga_fixes(path: Path, day: datetime) -> dict[datetime, tuple[float, float]]:
    """Position of every GGA with a fix (quality > 0) by its own time tag, read with pynmea2."""
    out = {}
    with open(path, encoding="ascii", errors="replace") as fh:
        for line in fh:
            if line[3:6] != "GGA":
                continue
            m = pynmea2.parse(line.strip(), check=True)
            if m.gps_qual and int(m.gps_qual) > 0:
                t = datetime.combine(day.date(), m.timestamp).replace(tzinfo=UTC)
                out[t] = (m.latitude, m.longitude)
    return out


def test_denied_last_fixes_are_the_logs_own(markermeer: DeniedReport) -> None:
    """Each window's last fix is the log's RMC or GGA fix of that second, and its SOG the RMC's,
    read with pynmea2 (tolerances: the .RUN line that carries a fix rounds it to 0.001″ =
    3e-7°; SOG is kept to 0.1 kn). Either sentence: the GGA and RMC of one second differ by
    about half a metre in this log, and in a stretch after 12:09:54 the GGA carries the stamp of
    the second before the RMC with the same position (GGA 121140 = RMC 121141); the epoch of a
    second takes whichever came last (docs/REALDATA.md)."""
    path = NMEA / "avnav-markermeer-20160815.nmea"
    rmc = {t: (la, lo, s) for t, la, lo, s in pynmea2_track(path)}
    gga = gga_fixes(path, datetime(2016, 8, 15, tzinfo=UTC))
    for w in markermeer.windows:
        la, lo, sog = rmc[w.start]
        fix = (w.last_fix_lat_deg, w.last_fix_lon_deg)
        assert fix == pytest.approx((la, lo), abs=1e-6) or fix == pytest.approx(
            gga[w.start], abs=1e-6)
        assert w.cogsog_source == "log" and w.sog_kn == pytest.approx(sog, abs=0.051)
        assert w.start - markermeer.windows[0].start in {timedelta(seconds=120 * k)
                                                         for k in range(20)}


def _strip_variation(src: Path, dst: Path) -> None:
    """The Markermeer log as the compass-only yacht logs send it: HDG without its variation,
    RMC without the receiver's, VHW with its magnetic heading only (true field emptied);
    checksums recomputed, every other byte kept."""
    from functools import reduce
    from operator import xor

    with open(src, newline="") as f, open(dst, "w", newline="") as g:
        for line in f:
            body = line.rstrip("\r\n")
            kind = body[3:6]
            if body.startswith("$") and kind in ("HDG", "RMC", "VHW"):
                fields = body[1:body.rindex("*")].split(",")
                blank = {"HDG": (4, 5), "RMC": (10, 11), "VHW": (1,)}[kind]
                for i in blank:
                    fields[i] = ""
                b = ",".join(fields)
                body = f"${b}*{reduce(xor, b.encode(), 0):02X}"
            g.write(body + line[len(line.rstrip("\r\n")):])


def test_compass_only_log_gets_igrf_variation_and_dead_reckons(tmp_path: Path) -> None:
    """Magnetic headings without any variation in the log were dropped ("no heading in the
    log"): the filter ran without dead reckoning, 1.5 km off after 10 minutes without GNSS
    (median over the windows; measured 1531 m). With the IGRF-14 variation (1.17°E there and
    then) the headings are the log's own within the variations' difference: the log's HDG
    said 0.9°E, so every record's heading is 0.2–0.4° east of the original (rounded to 0.1°),
    and the 10-minute filter error is that of the original log (measured 33 m; bound as in
    test_denied_on_real_data_gives_sane_numbers)."""
    log = tmp_path / "compass.nmea"
    _strip_variation(NMEA / "avnav-markermeer-20160815.nmea", log)
    cfg, data = load_run_config(NMEA / "avnav-markermeer-20160815.toml")
    orig = {r.time: r.heading_deg for r in run_records(cfg) if hasattr(r, "heading_deg")}
    cfg = cfg.replace(run_file=str(log))
    reader = run_records(cfg)
    recs = [r for r in reader if hasattr(r, "heading_deg")]
    diffs = [(r.heading_deg - orig[r.time] + 180.0) % 360.0 - 180.0 for r in recs
             if r.heading_deg is not None and orig.get(r.time) is not None]
    assert len(diffs) > 2000
    assert all(0.15 < d < 0.45 for d in diffs), (min(diffs), max(diffs))
    lines = reader.stats.variation_lines()  # type: ignore[attr-defined]
    assert lines == ["magnetic headings without variation: 22032 made true with the IGRF-14 "
                     "variation 1.2°E at 52.49°N 5.30°E on 2016-08-15"]
    rep = denied_experiment(cfg, data, run_records(cfg), [600.0], every_s=120.0,
                            warmup_s=120.0, checkpoints_s=(600.0,))
    (row,) = rep.rows
    assert rep.has_heading_speed and row.n == 11
    assert row.filter_m[0] < 150.0 and math.isfinite(row.hdgstw_m[0])

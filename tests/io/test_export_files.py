"""``uvnav export``'s engine side (engine/io/export_read.py, export_geo.py, export_write.py):
bundled runs replayed, exported, and read back with independent libraries (gpxpy, pandas,
pyproj, xml.etree) against the .RUN text and pyproj's own geodesy."""

from __future__ import annotations

import json
import math
import re
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import gpxpy
import pandas as pd
import pytest
from pyproj import Geod, Proj

from engine.errors import InputError
from engine.io.datumfile import read_datum_file
from engine.io.export_geo import ELLIPSE_POINTS, ExportData, Wgs84Converter, build_export
from engine.io.export_read import (
    W_FLAG_BOUND,
    ExportLog,
    align_smoothed,
    logged_datum_file,
    read_export_log,
    read_smoothed,
)
from engine.io.export_write import KML_NS, csv_text, geojson_text, gpx_text, kml_text
from engine.lsq.statistics import REJECT_BOUND
from tests.paths import copy_data
from uvnav_tui.cli.replay import run_replay

WGS84 = Geod(ellps="WGS84")
N_DEMO = 60
"""Records of the demo mission replayed (the first minute: GPS, Decca and the filter)."""


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Replays of the thesis sample (10 records) and the demo's first minute, each with its
    .OUT, --jsonl and --smooth files."""
    d = copy_data(tmp_path_factory.mktemp("export") / "data")
    lines = (d / "DEMO.RUN").read_text(encoding="utf-8").splitlines(keepends=True)
    (d / "D60.RUN").write_text("".join(lines[:N_DEMO]), encoding="utf-8")
    shutil.copy(d / "DEMO.toml", d / "D60.toml")
    shutil.copy(d / "D60.RUN", d / "G60.RUN")  # the same minute with GPS alone: LSE = GPS
    cfg = (d / "DEMO.toml").read_text(encoding="utf-8")
    decca = cfg.index("[decca]")
    on = cfg.index("on = true", decca)
    (d / "G60.toml").write_text(cfg[:on] + "on = false" + cfg[on + 9:], encoding="utf-8")
    for name in ("920917_1", "D60", "G60"):
        assert run_replay([str(d / f"{name}.RUN"), "--jsonl", str(d / f"{name}.jsonl"),
                           "--smooth"]) == 0
    return d


def _export(log: ExportLog, tracks: list[str], smooth: Path | None = None) -> ExportData:
    datum_file = logged_datum_file(log)
    assert datum_file is not None
    smoothed = None
    if smooth is not None:
        points, _problems = read_smoothed(smooth)
        smoothed = align_smoothed(log.epochs, points, str(smooth))
    return build_export(log, tracks, Wgs84Converter(read_datum_file(datum_file)), smoothed)


def _no_constant(name: str) -> float:
    raise AssertionError(f"{name} in a JSON export")


def _dms(text: str) -> float:
    """'52 49 56.576 N' → decimal degrees (hand parsing of the .RUN text)."""
    d, m, s, h = text.split()
    v = int(d) + int(m) / 60 + float(s) / 3600
    return -v if h in "SW" else v


def test_w_flag_bound_is_the_rejection_bound() -> None:
    assert W_FLAG_BOUND == REJECT_BOUND


@pytest.mark.parametrize(("run", "track"), [("D60", "gps"), ("G60", "lse"), ("G60", "mpp")])
def test_exported_point_on_wgs84_is_the_gps_input(runs: Path, run: str, track: str) -> None:
    """The demo is on ED50 with WGS84 GPS input: the engine converted each fix WGS84 → ED50,
    the export converts it back (the engine's pure-Python Bursa–Wolf forward, the export's PROJ
    pipeline back). The GPS track of the demo, and with GPS alone (G60: Decca off) the LSE of
    the two GPS LOPs, which is the fix itself; the MPP is only checked to be filtered near it
    (30 m, measured 16.8 m: the filter smooths SA-era GPS). Compared with the .RUN text
    parsed here by hand.
    Tolerance 5 mm: the export takes height 0 on ED50 where the engine's point is at
    −Hg ≈ −39.6 m, which moves the horizontal result by about 1 mm (export_geo docstring);
    measured 0.78 mm. A missing or reversed shift would be ~100 m off."""
    log = read_export_log(runs / f"{run}.OUT")
    assert {e.datum for e in log.epochs} == {"ED50"}
    data = _export(log, ["gps", track])
    run_lines = (runs / f"{run}.RUN").read_text(encoding="utf-8").splitlines()
    worst = 0.0
    for e, p in zip(log.epochs, data.tracks[track], strict=True):
        assert p is not None and e.record is not None
        m = re.match(r"\d{6} \d{6} (\d+ \d+ [\d.]+ [NS]) (\d+ \d+ [\d.]+ [EW])",
                     run_lines[e.record - 1])
        assert m is not None
        lat, lon = _dms(m.group(1)), _dms(m.group(2))
        _a, _b, dist = WGS84.inv(lon, lat, p.lon_deg, p.lat_deg)
        worst = max(worst, dist)
        # and the ED50 position itself is ~100 m away: the conversion is really applied
        _a, _b, shift = WGS84.inv(lon, lat, e.gps.lon_deg, e.gps.lat_deg)  # type: ignore[union-attr]
        assert 80.0 < shift < 200.0
    assert worst < (30.0 if track == "mpp" else 0.005)
    if track == "mpp":
        assert worst > 0.5  # really the filtered position, not the fix


def test_ellipse_polygons_close_counter_clockwise_with_the_right_area(runs: Path) -> None:
    """Every ring closed, counter-clockwise (pyproj's signed area > 0), in range, and its area
    (pyproj geodesic) equals the inscribed 72-gon of the grid ellipse, π·a·b·72·sin(5°)/(2π),
    within 2e-4 relative. Budget: the grid's point scale (1 + 1.4e-5 half a degree off the CM)
    squared 2.8e-5; a95/b95 rounded to 1 mm in the properties, ≤ 5e-5 on a 22 m b95; ring
    vertices rounded to 1e-9° ~1e-5; height 0 on ED50 is ~40 m below WGS84, 1.3e-5. Measured
    7.1e-5. A 95 % ellipse taken for a 1σ one, or a lost semi-axis, is off by a factor."""
    log = read_export_log(runs / "D60.OUT")
    data = _export(log, ["mpp"])
    doc = json.loads(geojson_text(data))
    polys = [f for f in doc["features"] if f["geometry"]["type"] == "Polygon"]
    assert len(polys) == len(log.epochs)
    ratio = ELLIPSE_POINTS * math.sin(2 * math.pi / ELLIPSE_POINTS) / (2 * math.pi)
    for f in polys:
        ring = f["geometry"]["coordinates"][0]
        assert len(ring) == ELLIPSE_POINTS + 1 and ring[0] == ring[-1]
        assert all(-180 <= lo <= 180 and -90 <= la <= 90 for lo, la in ring)
        area, _perim = WGS84.polygon_area_perimeter([c[0] for c in ring], [c[1] for c in ring])
        pr = f["properties"]
        expected = math.pi * pr["a95_m"] * pr["b95_m"] * ratio
        assert area > 0  # counter-clockwise (RFC 7946 §3.1.6)
        assert area == pytest.approx(expected, rel=2e-4)


def test_ellipse_major_axis_points_to_true_azimuth(runs: Path) -> None:
    """Independent of the grid code: pyproj's TM (International 1924, the CM of the cycle) gives
    the meridian convergence γ, pyproj's geodesic goes a95 from the centre at Az_grid + γ. The
    first ring vertex (major-axis end) lands within 1 cm of it (point scale 1 + 1.4e-5 on
    ~65 m, datum change ppm; measured 1.8 mm); without γ (−0.40° here) it misses by ~0.45 m."""
    log = read_export_log(runs / "D60.OUT")
    data = _export(log, ["mpp"])
    for e, p in zip(log.epochs, data.tracks["mpp"], strict=True):
        assert p is not None and p.ring is not None and e.mpp is not None
        tm = Proj(proj="tmerc", lon_0=e.cm_deg, k=1.0, ellps="intl")
        gamma = tm.get_factors(e.mpp.lon_deg, e.mpp.lat_deg).meridian_convergence
        assert p.az_true_deg == pytest.approx((p.az_grid_deg + gamma) % 360, abs=1e-6)
        lon, lat, _ = WGS84.fwd(p.lon_deg, p.lat_deg, p.az_true_deg, p.a95_m)
        _a, _b, miss = WGS84.inv(lon, lat, *p.ring[0])
        assert miss < 0.01
        lon0, lat0, _ = WGS84.fwd(p.lon_deg, p.lat_deg, p.az_grid_deg, p.a95_m)
        assert WGS84.inv(lon0, lat0, *p.ring[0])[2] > 0.2


def test_gpx_reads_back_with_gpxpy(runs: Path) -> None:
    log = read_export_log(runs / "920917_1.OUT")
    data = _export(log, ["mpp", "lse", "smoothed"], runs / "920917_1.smooth.jsonl")
    gpx = gpxpy.parse(gpx_text(data))
    assert gpx.creator == "UVNAV export"
    assert [t.name for t in gpx.tracks] == ["MPP (most probable position)",
                                           "LSE (least-squares fix)", "Smoothed (RTS)"]
    mpp = [p for s in gpx.tracks[0].segments for p in s.points]
    assert len(mpp) == len(log.epochs) == 10
    for pt, e, g in zip(mpp, log.epochs, data.tracks["mpp"], strict=True):
        assert pt.time == e.time and pt.time.utcoffset().total_seconds() == 0
        assert g is not None and e.mpp is not None
        assert pt.latitude == pytest.approx(g.lat_deg, abs=1e-9)
        assert pt.elevation == pytest.approx(-(e.mpp.depth_m or 0.0), abs=1e-3)
    assert all(p.elevation is None for s in gpx.tracks[1].segments for p in s.points)
    assert sum(len(s.points) for s in gpx.tracks[2].segments) == 10


def test_csv_reads_back_with_pandas(runs: Path) -> None:
    log = read_export_log(runs / "D60.OUT")
    data = _export(log, ["mpp", "lse", "gps", "smoothed"], runs / "D60.smooth.jsonl")
    path = runs / "d60.csv"
    path.write_text(csv_text(data), encoding="utf-8")
    df = pd.read_csv(path, parse_dates=["time_utc"])
    assert len(df) == len(log.epochs) == N_DEMO
    assert str(df["time_utc"].dt.tz) == "UTC"
    for col in df.columns:
        if col not in ("time_utc", "source", "filter", "datum"):
            assert pd.api.types.is_numeric_dtype(df[col]), col
    assert df["mpp_lat_deg"].dtype == "float64" and df["mpp_lat_deg"].notna().all()
    assert df["gps_a95_m"].isna().all()  # GPS input has no ellipse: empty cells → NaN
    assert df["mpp_cm_deg"].eq(5.0).all() and (df["lse_depth_m"].isna()).all()
    assert df.loc[0, "mpp_lat_deg"] == pytest.approx(data.tracks["mpp"][0].lat_deg, abs=1e-9)


def test_kml_parses_as_kml_22(runs: Path) -> None:
    log = read_export_log(runs / "920917_1.OUT")
    data = _export(log, ["mpp", "lse"])
    root = ET.fromstring(kml_text(data))
    assert root.tag == f"{{{KML_NS}}}kml"
    ns = {"k": KML_NS}
    marks = root.findall("k:Document/k:Placemark", ns)
    assert [m.findtext("k:name", namespaces=ns) for m in marks] == [
        "MPP (most probable position)", "LSE (least-squares fix)"]
    for m in marks:
        coords = m.findtext("k:LineString/k:coordinates", namespaces=ns).split()
        assert len(coords) == 10
        for c in coords:
            lon, lat, alt = map(float, c.split(","))
            assert 4.5 < lon < 4.6 and 52.8 < lat < 52.9 and alt == 0.0


def test_jsonl_and_out_give_the_same_export(runs: Path) -> None:
    """The JSON lines round positions to 1e-9° and ellipses to 1 mm / 0.01°."""
    out = _export(read_export_log(runs / "D60.OUT"), ["mpp", "lse"])
    jl_log = read_export_log(runs / "D60.jsonl")
    assert jl_log.kind == "jsonl"
    conv = Wgs84Converter(read_datum_file(runs / "TO_WGS84.DAT"))
    jl = build_export(jl_log, ["mpp", "lse"], conv)
    for name in ("mpp", "lse"):
        for a, b in zip(out.tracks[name], jl.tracks[name], strict=True):
            assert (a is None) == (b is None)
            if a is not None and b is not None:
                assert a.lat_deg == pytest.approx(b.lat_deg, abs=2e-9)
                assert a.a95_m == pytest.approx(b.a95_m, abs=1e-3)
                assert b.ring is not None


def test_a_log_cut_short_is_read_to_its_last_cycle(runs: Path, tmp_path: Path) -> None:
    text = (runs / "D60.OUT").read_bytes()
    cut = tmp_path / "cut.OUT"
    cut.write_bytes(text[: len(text) // 2])  # mid-line, mid-block
    log = read_export_log(cut)
    assert log.truncated and 0 < len(log.epochs) < N_DEMO
    assert re.match(rf"{re.escape(str(cut))}:\d+: last cycle block is incomplete",
                    log.problems[0])
    jl = (runs / "D60.jsonl").read_bytes()
    cutj = tmp_path / "cut.jsonl"
    cutj.write_bytes(jl[: len(jl) // 2])
    logj = read_export_log(cutj)
    assert 0 < len(logj.epochs) < N_DEMO
    assert re.match(rf"{re.escape(str(cutj))}:\d+: last line is incomplete", logj.problems[0])


def test_bad_records_are_counted_and_damage_is_located(runs: Path, tmp_path: Path) -> None:
    lines = (runs / "920917_1.OUT").read_text(encoding="utf-8").splitlines(keepends=True)
    first = next(i for i, ln in enumerate(lines) if ln.startswith("CYCLE"))
    lines.insert(first, 'BAD record=2 field=heading message="x" raw="y"\n')
    ok = tmp_path / "bad.OUT"
    ok.write_text("".join(lines), encoding="utf-8")
    assert read_export_log(ok).bad_records == 1
    lines.insert(first + 3, '  LOP sys="unterminated\n')
    damaged = tmp_path / "damaged.OUT"
    damaged.write_text("".join(lines), encoding="utf-8")
    with pytest.raises(InputError) as err:
        read_export_log(damaged)
    assert err.value.file == str(damaged) and err.value.line == first + 4
    notlog = tmp_path / "notes.txt"
    notlog.write_text("hello\n", encoding="utf-8")
    with pytest.raises(InputError, match="Not a UVNAV"):
        read_export_log(notlog)


def test_smoothed_positions_align_to_the_filtered_cycles(runs: Path, tmp_path: Path) -> None:
    log = read_export_log(runs / "D60.OUT")
    points, problems = read_smoothed(runs / "D60.smooth.jsonl")
    assert problems == [] and len(points) == sum(e.has_filter for e in log.epochs)
    aligned = align_smoothed(log.epochs, points, "s")
    assert aligned[-1] == points[-1].point
    with pytest.raises(InputError, match="not the smoothed file of this run"):
        align_smoothed(log.epochs[:10], points, "s")
    timed = tmp_path / "timed.jsonl"  # lines with a time are matched by it
    rows = [json.loads(x) for x in (runs / "D60.smooth.jsonl").read_text().splitlines()]
    picked = [(log.epochs[i], rows[i]) for i in (3, 7)]
    timed.write_text("".join(json.dumps({**r, "time": e.time.strftime("%Y-%m-%dT%H:%M:%SZ")})
                             + "\n" for e, r in picked), encoding="utf-8")
    tp, _ = read_smoothed(timed)
    al = align_smoothed(log.epochs, tp, str(timed))
    assert [i for i, p in enumerate(al) if p is not None] == [3, 7]


def test_positions_on_another_datum_need_the_datum_file(runs: Path) -> None:
    log = read_export_log(runs / "920917_1.jsonl")
    assert logged_datum_file(log) is None
    with pytest.raises(InputError, match="not WGS84"):
        build_export(log, ["mpp"], Wgs84Converter(None))


def test_ellipse_ring_by_hand() -> None:
    """Az 90° (major axis east), a = 2 m, b = 1 m round (10, 20): the ring starts at the east
    end and turns counter-clockwise, north end a quarter later (hand values, 1e-12 m)."""
    from engine.io.export_geo import ellipse_grid_ring

    ring = ellipse_grid_ring(10.0, 20.0, 2.0, 1.0, 90.0, n=4)
    expected = [(12.0, 20.0), (10.0, 21.0), (8.0, 20.0), (10.0, 19.0)]
    for (x, y), (ex, ey) in zip(ring, expected, strict=True):
        assert x == pytest.approx(ex, abs=1e-12) and y == pytest.approx(ey, abs=1e-12)


def test_a_point_finds_its_grid_when_the_hint_is_wrong(runs: Path) -> None:
    """Smoothed positions are on the run's final CM, not the cycle's: the grid is found from
    the point itself. A point logged on CM 4° with a hint of 5° gets CM 4° and the same WGS84
    ellipse as with the right hint (ring vertices equal to 1e-9°)."""
    from engine.geodesy.tmgrid import TMGrid
    from engine.io.export_read import TrackPoint

    datums = read_datum_file(runs / "TO_WGS84.DAT")
    conv = Wgs84Converter(datums)
    lat, lon = 52.85, 4.45
    x, y = TMGrid(datums.datum("ED50").ellipsoid, 4.0).forward(lat, lon)
    p = TrackPoint(lat, lon, x, y, 3.0, 60.0, 20.0, 110.0)
    wrong, right = conv.point("ED50", p, 5.0), conv.point("ED50", p, 4.0)
    assert wrong.cm_deg == right.cm_deg == 4.0 and wrong.elevation_m == -3.0
    assert wrong.ring is not None and right.ring is not None
    for (a, b), (c, d) in zip(wrong.ring, right.ring, strict=True):
        assert a == pytest.approx(c, abs=1e-9) and b == pytest.approx(d, abs=1e-9)
    off = TrackPoint(lat, lon, x + 500.0, y, 3.0, 60.0, 20.0, 110.0)  # on no grid
    q = conv.point("ED50", off, 4.0)
    assert q.cm_deg is None and q.ring is None and q.az_true_deg is None


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("name", ["920917_1.OUT", "920917_1.jsonl", "920917_1.smooth.jsonl"])
def test_damaged_files_never_crash(runs: Path, tmp_path: Path, name: str) -> None:
    """300 seeded random damages (bytes replaced, deleted, duplicated, cut) of each input: the
    reader, the conversion and every writer either work — with valid JSON (no NaN) and no
    numeric warning — or raise InputError naming the file, nothing else."""
    import random

    rng = random.Random(13)
    good = (runs / name).read_bytes()
    datums = Wgs84Converter(read_datum_file(runs / "TO_WGS84.DAT"))
    target = tmp_path / name
    outcomes = {"ok": 0, "error": 0}
    for _ in range(300):
        data = bytearray(good)
        for _k in range(rng.randint(1, 4)):
            i = rng.randrange(len(data))
            op = rng.randrange(4)
            if op == 0:
                data[i] = rng.randrange(256)
            elif op == 1:
                del data[i:i + rng.randint(1, 40)]
            elif op == 2:
                data[i:i] = data[i:i + rng.randint(1, 40)]
            else:
                del data[i:]
        target.write_bytes(bytes(data))
        try:
            if "smooth" in name:
                read_smoothed(target)
            else:
                data = build_export(read_export_log(target), ["mpp", "lse"], datums)
                json.loads(geojson_text(data), parse_constant=_no_constant)
                gpxpy.parse(gpx_text(data))
                csv_text(data)
                ET.fromstring(kml_text(data))
            outcomes["ok"] += 1
        except InputError as exc:
            assert exc.file is not None and name in exc.file
            outcomes["error"] += 1
    assert outcomes["ok"] > 0 and outcomes["error"] > 0

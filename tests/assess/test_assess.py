"""``uvnav assess``: accuracy against truth (engine/assess/accuracy.py, uvnav_tui/cli/assess.py).

Synthetic truth and estimates with known errors check the statistics, the frame, the phases, the
time matching and the Pool of Errors; a short replay of data/DEMO.RUN checks the readers end to
end (.OUT and JSON lines must agree) and the command line.
"""

from __future__ import annotations

import json
import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from pathlib import Path

import numpy as np
import pytest

from engine.assess.accuracy import (
    K95_SQ,
    assess,
    cov_from_ellipse95,
    read_nav_log,
    read_truth,
)
from engine.errors import InputError
from engine.geodesy.ellipsoid import Ellipsoid
from engine.geodesy.tmgrid import TMGrid
from engine.io.outlog import OutLogWriter
from engine.lsq.confidence import error_ellipse
from tests.paths import DATA
from uvnav_tui.cli.assess_svg import render_svg
from uvnav_tui.cli.main import main

HAYFORD = Ellipsoid("HAYFORD 1909", 6378388.0, 297.0)
T0 = datetime(1992, 9, 17, 10, 0, 0, tzinfo=UTC)
CM = 4.0  # the cycles' grid; the truth header states CM 5 (its own grid is never used)
GRID = TMGrid(HAYFORD, CM)


# ---------------------------------------------------------------------------------- helpers


def _iso(t: datetime) -> str:
    return t.strftime("%Y-%m-%dT%H:%M:%SZ")


def _truth_track(n: int, step_s: int = 1) -> tuple[list[datetime], np.ndarray, np.ndarray]:
    """A straight track at about 5 m/s north-west of Den Helder, CM 4 grid."""
    times = [T0 + timedelta(seconds=step_s * k) for k in range(n)]
    k = np.arange(n) * step_s
    lat = 52.83 + k * 3.0e-5
    lon = 4.30 - k * 4.0e-5
    return times, lat, lon


def write_truth(path: Path, times: list[datetime], lat: np.ndarray, lon: np.ndarray,
                surfaced: list[int], *, header: bool = True,
                columns: tuple[str, ...] = ("time", "lat", "lon", "depth_m", "surfaced")) -> Path:
    lines = []
    if header:
        lines += [
            "# UVNAV simulator truth (synthetic, tests/assess/test_assess.py)",
            "# lat, lon: geodetic degrees on the working datum ED50 (ellipsoid HAYFORD 1909, "
            "a = 6378388.000 m, 1/f = 297)",
            "# x, y: TM grid on the working datum, k0 = 1, no false origin, CM 5 E "
            "(cm_deg = 5), metres",
        ]
    lines.append(",".join(columns))
    for t, la, lo, s in zip(times, lat, lon, surfaced, strict=True):
        cells = {"time": _iso(t), "lat": f"{la:.9f}", "lon": f"{lo:.9f}",
                 "depth_m": "0.000" if s else "50.000", "surfaced": str(s)}
        lines.append(",".join(cells[c] for c in columns))
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


@dataclass
class Est:
    lat: float
    lon: float
    cov: np.ndarray


@dataclass
class Cycle:
    time: datetime
    lse: Est | None
    kf: Est | None
    mpp: Est
    nis: tuple[float, int] | None = None
    datum: str = "ED50"


def offset(la: float, lo: float, e: np.ndarray, cov: np.ndarray) -> Est:
    """The estimate whose grid error (CM 4) relative to (la, lo) is e (m, x east / y north)."""
    x, y = GRID.forward(la, lo)
    lat, lon = GRID.inverse(x + float(e[0]), y + float(e[1]))
    return Est(lat, lon, cov)


def _pos_fields(e: Est) -> dict:
    x, y = GRID.forward(e.lat, e.lon)
    ell = error_ellipse(e.cov)
    a, b = ell.scaled(0.95)
    return {"lat": e.lat, "lon": e.lon, "x": x, "y": y, "depth": 0.0, "a95": a, "b95": b,
            "az": ell.az_deg, "cxx": float(e.cov[0, 0]), "cxy": float(e.cov[0, 1]),
            "cyy": float(e.cov[1, 1])}


def write_out(path: Path, cycles: list[Cycle], config_text: str = "") -> Path:
    with OutLogWriter.create(path, header=["engine test"], config_text=config_text,
                             force=True) as w:
        for n, c in enumerate(cycles, start=1):
            head = {"n": n, "t": _iso(c.time), "record": n,
                    "filter": "ON" if c.kf else "N/A", "source": "KF" if c.kf else "LSE",
                    "datum": c.datum, "cm": CM, "dt": 1.0}
            lines: list[tuple[str, dict]] = []
            if c.lse is not None:
                lines.append(("LSE", {"kind": "lse", "n": 4, **_pos_fields(c.lse)}))
            if c.nis is not None:
                lines.append(("TEST", {"lom": c.nis[0] / c.nis[1], "lo": 0.0, "hi": 9.9,
                                       "dof": c.nis[1], "verdict": "accept", "ls": ""}))
            lines.append(("MPP", {"source": head["source"], **_pos_fields(c.mpp)}))
            w.write_cycle(head, lines)
    return path


def _json_pos(e: Est | None) -> dict | None:
    """Like engine.run.records.position_json: lat/lon 1e-9°, a95/b95 1 mm, az 0.01°."""
    if e is None:
        return None
    x, y = GRID.forward(e.lat, e.lon)
    ell = error_ellipse(e.cov)
    a, b = ell.scaled(0.95)
    return {"lat": round(e.lat, 9), "lon": round(e.lon, 9), "x": round(x, 3), "y": round(y, 3),
            "depth": 0.0, "a95": round(a, 3), "b95": round(b, 3), "az_deg": round(ell.az_deg, 2)}


def write_jsonl(path: Path, cycles: list[Cycle]) -> Path:
    with open(path, "w", encoding="utf-8") as fh:
        for n, c in enumerate(cycles, start=1):
            fh.write(json.dumps({
                "n": n, "time": _iso(c.time), "record": n, "filter": "ON" if c.kf else "N/A",
                "source": "KF" if c.kf else "LSE", "datum": c.datum, "cm_deg": CM,
                "mpp": _json_pos(c.mpp), "lse": _json_pos(c.lse), "kf": _json_pos(c.kf),
                "lops": [], "messages": [],
            }) + "\n")
    return path


def _cov(a_sigma: float, b_sigma: float, az_deg: float) -> np.ndarray:
    az = math.radians(az_deg)
    u = np.array([math.sin(az), math.cos(az)])
    v = np.array([math.cos(az), -math.sin(az)])
    return a_sigma**2 * np.outer(u, u) + b_sigma**2 * np.outer(v, v)


# ---------------------------------------------------------------------------------- engine


def test_cov_from_ellipse95_inverts_error_ellipse() -> None:
    C = _cov(31.5, 9.1, 109.6)
    ell = error_ellipse(C)
    a, b = ell.scaled(0.95)
    assert np.allclose(cov_from_ellipse95(a, b, ell.az_deg), C, rtol=0, atol=1e-9)
    # isotropic and north-south cases
    assert np.allclose(cov_from_ellipse95(2.4477 * 3, 2.4477 * 3, 90.0),
                       np.diag([9.0, 9.0]), atol=1e-3)
    assert np.allclose(cov_from_ellipse95(math.sqrt(K95_SQ) * 4, math.sqrt(K95_SQ), 0.0),
                       np.diag([1.0, 16.0]), atol=1e-12)


def test_gaussian_errors_with_known_covariance(tmp_path: Path) -> None:
    """Errors drawn from C: coverage ≈ 95 %, NEES ≈ 2, RMS ≈ sqrt(trace C), errors recovered.

    Tolerances are 4 standard deviations for N = 4000 independent draws: coverage
    sqrt(0.95·0.05/N) = 0.0034 → 0.014; mean NEES sqrt(var χ²₂ / N) = sqrt(4/N) = 0.032 → 0.13;
    mean squared error sqrt(2 tr C² / N) relative to tr C.  The seed is fixed, so the test is
    deterministic; the tolerances say it would pass for (almost) any seed.
    """
    n = 4000
    times, lat, lon = _truth_track(n)
    truth = write_truth(tmp_path / "T.csv", times, lat, lon, [1] * n)
    C = _cov(20.0, 8.0, 30.0)
    rng = np.random.default_rng(1993)
    e = rng.multivariate_normal([0.0, 0.0], C, size=n)
    cycles = [Cycle(times[k], offset(lat[k], lon[k], e[k], C), None,
                    offset(lat[k], lon[k], e[k], C)) for k in range(n)]
    log = read_nav_log(write_out(tmp_path / "G.OUT", cycles))
    a = assess(log, read_truth(truth))
    # the frame: the injected grid errors come back to well under a millimetre
    assert np.max(np.abs(a.series.error["lse"] - e)) < 1e-4
    s = a.stat("surfaced", "lse")
    assert s.n == s.n_cov == n
    assert abs(s.coverage - 0.95) < 4 * math.sqrt(0.95 * 0.05 / n)
    assert abs(s.nees - 2.0) < 4 * math.sqrt(4.0 / n)
    tr = float(np.trace(C))
    assert abs(s.rms_m**2 - tr) < 4 * math.sqrt(2 * float(np.trace(C @ C)) / n)
    lo, hi = s.nees_band
    assert lo < 2.0 < hi and hi - lo == pytest.approx(2 * 1.96 * math.sqrt(4 / n) / 1.0, rel=0.05)
    assert a.stat("all", "lse").n == n and a.stat("submerged", "lse").n == 0
    assert math.isnan(a.stat("submerged", "lse").rms_m)
    assert a.stat("surfaced", "kf").n == 0  # no filter estimate in these cycles


def test_fixed_offset_gives_exact_statistics_from_json_lines(tmp_path: Path) -> None:
    """A 10 m east offset with σ = 5 m: RMS = P95 = max = 10 m, NEES = 100/25 = 4 (inside the
    95 % ellipse, k² = 5.99); a 30 m offset: NEES 36, outside.  Tolerance 1 mm: the JSON lines
    round lat/lon to 1e-9° (≤ 0.11 mm) and a95 to 1 mm (relative 4e-5 → NEES ± 4e-4)."""
    n = 50
    times, lat, lon = _truth_track(n)
    truth = write_truth(tmp_path / "T.csv", times, lat, lon, [1] * n)
    C = np.diag([25.0, 25.0])
    cycles = [Cycle(times[k], offset(lat[k], lon[k], np.array([10.0, 0.0]), C),
                    offset(lat[k], lon[k], np.array([0.0, -30.0]), C),
                    offset(lat[k], lon[k], np.array([0.0, -30.0]), C)) for k in range(n)]
    log = read_nav_log(write_jsonl(tmp_path / "F.jsonl", cycles))
    assert log.kind == "jsonl" and log.nis is None
    a = assess(log, read_truth(truth))
    s = a.stat("all", "lse")
    assert (s.rms_m, s.p95_m, s.max_m) == pytest.approx((10.0, 10.0, 10.0), abs=1e-3)
    assert s.nees == pytest.approx(4.0, abs=1e-3) and s.coverage == 1.0
    k = a.stat("all", "kf")
    assert k.rms_m == pytest.approx(30.0, abs=1e-3) and k.nees == pytest.approx(36.0, abs=1e-2)
    assert k.coverage == 0.0
    assert np.allclose(a.series.error["kf"], [0.0, -30.0], atol=1e-3)
    assert a.nis is None
    assert any("NIS skipped" in note for note in a.notes)


def test_phase_splitting_and_dives(tmp_path: Path) -> None:
    pattern = [1] * 5 + [0] * 4 + [1] * 3 + [0] * 2 + [1] * 2
    n = len(pattern)
    times, lat, lon = _truth_track(n, step_s=60)
    truth = write_truth(tmp_path / "T.csv", times, lat, lon, pattern)
    C = np.diag([16.0, 9.0])
    cycles = [Cycle(times[k], offset(lat[k], lon[k], np.zeros(2), C) if pattern[k] else None,
                    offset(lat[k], lon[k], np.array([3.0, 4.0]), C),
                    offset(lat[k], lon[k], np.array([3.0, 4.0]), C)) for k in range(n)]
    a = assess(read_nav_log(write_out(tmp_path / "P.OUT", cycles)), read_truth(truth))
    spans = {p.name: p for p in a.phases}
    assert {k: spans[k].n for k in spans} == {"surfaced": 5, "submerged": 6,
                                               "after resurfacing": 5, "all": 16}
    assert spans["submerged"].start == times[5] and spans["submerged"].end == times[13]
    assert spans["after resurfacing"].start == times[9]
    assert a.stat("after resurfacing", "lse").n == 5 and a.stat("submerged", "lse").n == 0
    assert a.stat("submerged", "kf").n == 6
    assert list(a.series.phase) == [0] * 5 + [1] * 4 + [2] * 3 + [1] * 2 + [2] * 2
    assert [(d.start, d.end) for d in a.dives] == [(times[5], times[8]), (times[12], times[13])]
    # --phases none: the whole run only
    b = assess(read_nav_log(tmp_path / "P.OUT"), read_truth(truth), split_phases=False)
    assert [p.name for p in b.phases] == ["all"] and {s.phase for s in b.stats} == {"all"}


def test_time_matching_with_gaps_and_repeats(tmp_path: Path) -> None:
    """Truth lacks 40–49 s, the log lacks 10–14 s, runs 20 s past the truth and repeats 30 s."""
    times, lat, lon = _truth_track(120)
    keep_t = [k for k in range(100) if not 40 <= k < 50]
    truth = write_truth(tmp_path / "T.csv", [times[k] for k in keep_t], lat[keep_t],
                        lon[keep_t], [1] * len(keep_t))
    C = np.diag([4.0, 4.0])
    log_k = [k for k in range(120) if not 10 <= k < 15]
    log_k.insert(log_k.index(31), 30)
    cycles = []
    for k in log_k:
        e = np.array([2.0, 0.0]) if k != 30 or cycles[-1].time != times[30] else np.array(
            [500.0, 0.0])  # the repeated cycle must be ignored
        cycles.append(Cycle(times[k], offset(lat[k], lon[k], e, C), None,
                            offset(lat[k], lon[k], e, C)))
    a = assess(read_nav_log(write_jsonl(tmp_path / "M.jsonl", cycles)), read_truth(truth))
    expected = len([k for k in range(100) if not 40 <= k < 50 and not 10 <= k < 15])
    assert a.n_matched == expected == 85
    assert a.n_log == 116 and a.n_log_unmatched == 116 - 85 - 1  # the repeat has a truth
    assert a.stat("all", "mpp").n == 85
    assert a.stat("all", "mpp").max_m == pytest.approx(2.0, abs=1e-3)
    assert any("repeat" in note for note in a.notes)
    assert np.all(np.diff(a.series.t_ms) > 0)


def test_pool_of_errors(tmp_path: Path) -> None:
    """R = a + ε·Δt: a = d_rms = sqrt(300 + 100) = 20 m of the last LSE (9 min), ε from the
    log's configuration (900 m/h) unless overridden; samples at 0, 10, …, 40 min and the end."""
    pattern = [1] * 10 + [0] * 46 + [1] * 4  # one epoch a minute; dive 10–55 min
    n = len(pattern)
    times, lat, lon = _truth_track(n, step_s=60)
    truth = read_truth(write_truth(tmp_path / "T.csv", times, lat, lon, pattern))
    C_lse = np.array([[300.0, 0.0], [0.0, 100.0]])
    cycles = []
    for k in range(n):
        C_kf = np.diag([1.0 + k, 1.0])  # 95 % a-axis = 2.4477·sqrt(1 + k)
        kf = offset(lat[k], lon[k], np.array([0.0, 2.0 * k]), C_kf)
        lse = offset(lat[k], lon[k], np.zeros(2), C_lse) if pattern[k] else None
        cycles.append(Cycle(times[k], lse, kf, kf, nis=(1.5, 2) if pattern[k] else None))
    cfg = "[demo]\npoe_expansion_m_h = 900.0\n"
    log = read_nav_log(write_out(tmp_path / "D.OUT", cycles, config_text=cfg))
    assert log.poe_rate_m_h == 900.0
    a = assess(log, truth)
    assert a.poe_rate_m_h == 900.0 and a.poe_rate_source == "log configuration"
    (d,) = a.dives
    assert d.fix_time == times[9] and d.a_m == pytest.approx(20.0, abs=1e-9)
    assert [r.t_dive_min for r in d.rows] == [0, 10, 20, 30, 40, 45]
    for r in d.rows:
        k = 10 + round(r.t_dive_min)
        assert r.dt_fix_min == pytest.approx(k - 9)
        assert r.poe_m == pytest.approx(20.0 + 900.0 * (k - 9) / 60.0, abs=1e-9)
        assert r.kf_a95_m == pytest.approx(math.sqrt(K95_SQ * (1.0 + k)), rel=1e-9)
        assert r.kf_error_m == pytest.approx(2.0 * k, abs=1e-4)
    assert d.frac_mpp_in_poe == 1.0
    b = assess(log, truth, poe_rate_m_h=1800.0)
    assert b.poe_rate_source == "option"
    assert b.dives[0].rows[1].poe_m == pytest.approx(20.0 + 1800.0 * 11 / 60.0)
    # NIS from the TEST lines: 1.5 per update, 2 dof, surfaced epochs only
    nis = {s.phase: s for s in a.nis or ()}
    assert nis["surfaced"].n == 10 and nis["surfaced"].mean_nis == pytest.approx(1.5)
    assert nis["submerged"].n == 0 and nis["after resurfacing"].n == 4
    assert nis["all"].mean_dof == 2.0


def test_datum_mismatch_is_refused(tmp_path: Path) -> None:
    times, lat, lon = _truth_track(5)
    truth = read_truth(write_truth(tmp_path / "T.csv", times, lat, lon, [1] * 5))
    C = np.eye(2)
    cycles = [Cycle(times[k], None, None, Est(lat[k], lon[k], C), datum="WGS84")
              for k in range(5)]
    with pytest.raises(InputError, match="not the truth's working datum"):
        assess(read_nav_log(write_jsonl(tmp_path / "W.jsonl", cycles)), truth)


def test_svg_is_well_formed(tmp_path: Path) -> None:
    pattern = [1] * 10 + [0] * 46 + [1] * 4
    n = len(pattern)
    times, lat, lon = _truth_track(n, step_s=60)
    truth = read_truth(write_truth(tmp_path / "T.csv", times, lat, lon, pattern))
    C = np.diag([100.0, 50.0])
    cycles = [Cycle(times[k], offset(lat[k], lon[k], np.ones(2), C) if pattern[k] else None,
                    offset(lat[k], lon[k], np.array([5.0, k]), C),
                    offset(lat[k], lon[k], np.array([5.0, k]), C)) for k in range(n)]
    a = assess(read_nav_log(write_out(tmp_path / "S.OUT", cycles)), truth)
    root = ET.fromstring(render_svg(a))
    ns = "{http://www.w3.org/2000/svg}"
    assert root.tag == f"{ns}svg"
    texts = [t.text or "" for t in root.iter(f"{ns}text")]
    assert any("[min]" in t for t in texts) and any("[m]" in t for t in texts)
    assert {"LSE error", "filter error", "MPP error", "POE radius"} <= set(texts)
    # LSE: two surfaced stretches → two polylines; three shaded phase rectangles
    lse = [p for p in root.iter(f"{ns}polyline") if p.get("stroke") == "#9ca3af"]
    assert len(lse) == 2
    fills = [r.get("fill") for r in root.iter(f"{ns}rect")]
    assert {"#dbeafe", "#e5e7eb", "#dcfce7"} <= set(fills)


# ---------------------------------------------------------------------------------- replay


@pytest.fixture(scope="module")
def short_replay(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The first 600 records of data/DEMO.RUN replayed with data/DEMO.toml (.OUT and JSONL)."""
    d = tmp_path_factory.mktemp("replay")
    run = d / "SHORT.RUN"
    with open(DATA / "DEMO.RUN", encoding="utf-8") as fh:
        run.write_text("".join(next(fh) for _ in range(600)), encoding="utf-8")
    out, jl = d / "SHORT.OUT", d / "SHORT.jsonl"
    rc = main(["replay", str(run), "--config", str(DATA / "DEMO.toml"), "--out", str(out),
               "--jsonl", str(jl), "--force"])
    assert rc == 0
    return out, jl


def test_out_and_json_lines_agree_to_the_printed_rounding(short_replay: tuple[Path, Path]) -> None:
    """Same run, both readers: errors agree to 1 mm (JSONL lat/lon 1e-9°), the rebuilt
    covariances give NEES within 0.1 % (a95/b95 1 mm, az 0.01°) and coverage within one epoch
    (an epoch can sit on the ellipse boundary)."""
    out, jl = short_replay
    truth = read_truth(DATA / "DEMO.truth.csv")
    a, b = assess(read_nav_log(out), truth), assess(read_nav_log(jl), truth)
    assert a.n_matched == b.n_matched == 600
    assert a.log_kind == "out" and b.log_kind == "jsonl"
    for sa, sb in zip(a.stats, b.stats, strict=True):
        assert (sa.phase, sa.estimator, sa.n, sa.n_cov) == (sb.phase, sb.estimator, sb.n, sb.n_cov)
        if sa.n == 0:
            continue
        assert sa.rms_m == pytest.approx(sb.rms_m, abs=1e-3)
        assert sa.p95_m == pytest.approx(sb.p95_m, abs=1e-3)
        assert sa.max_m == pytest.approx(sb.max_m, abs=1e-3)
        assert sa.nees == pytest.approx(sb.nees, rel=1e-3)
        assert abs(sa.coverage - sb.coverage) <= 1.0 / sa.n_cov + 1e-12
    for e in ("lse", "kf", "mpp"):
        ea, eb = a.series.error[e], b.series.error[e]
        ok = np.isfinite(ea[:, 0])
        assert np.array_equal(ok, np.isfinite(eb[:, 0]))
        assert np.max(np.abs(ea[ok] - eb[ok])) < 1e-3
    assert a.nis is not None and b.nis is None
    assert {p.name: p.n for p in a.phases}["surfaced"] == 600


def test_cli_prints_the_tables_and_writes_the_svg(short_replay: tuple[Path, Path], tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    out, jl = short_replay
    svg = tmp_path / "plot.svg"
    rc = main(["assess", str(out), str(DATA / "DEMO.truth.csv"), "--svg", str(svg)])
    text = capsys.readouterr().out
    assert rc == 0
    assert "Horizontal error against truth (m)" in text
    assert "matched 600" in text and "NIS" in text
    for word in ("surfaced", "LSE", "filter", "MPP", "NEES", "in 95 % ell."):
        assert word in text
    ET.parse(svg)
    rc = main(["assess", str(jl), str(DATA / "DEMO.truth.csv"), "--phases", "none",
               "--poe-rate", "900"])
    text = capsys.readouterr().out
    assert rc == 0 and "NIS skipped" in text and "phases: whole run only" in text


# ---------------------------------------------------------------------------------- bad input


def _run_bad(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    rc = main(["assess", *argv])
    err = capsys.readouterr().err
    assert rc == 2, err
    assert "Traceback" not in err
    return err


def test_bad_inputs_exit_2_with_a_message(tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    times, lat, lon = _truth_track(10)
    truth = write_truth(tmp_path / "T.csv", times, lat, lon, [1] * 10)
    C = np.eye(2)
    log = write_jsonl(tmp_path / "L.jsonl", [Cycle(times[k], None, None, Est(lat[k], lon[k], C))
                                            for k in range(10)])
    err = _run_bad([str(tmp_path / "nope.OUT"), str(truth)], capsys)
    assert "nope.OUT" in err and "File not found" in err
    err = _run_bad([str(log), str(tmp_path / "nope.csv")], capsys)
    assert "nope.csv" in err and "File not found" in err
    no_col = write_truth(tmp_path / "N.csv", times, lat, lon, [1] * 10,
                         columns=("time", "lat", "lon", "depth_m"))
    err = _run_bad([str(log), str(no_col)], capsys)
    assert "N.csv:4: surfaced: Truth column 'surfaced' missing" in err
    later = write_truth(tmp_path / "Late.csv", [t + timedelta(days=1) for t in times], lat, lon,
                        [1] * 10)
    err = _run_bad([str(log), str(later)], capsys)
    assert "No epochs in common" in err
    bad = tmp_path / "B.jsonl"
    bad.write_text(log.read_text().splitlines()[0] + "\n{not json\n")
    err = _run_bad([str(bad), str(truth)], capsys)
    assert "B.jsonl:2" in err
    no_ell = write_truth(tmp_path / "E.csv", times, lat, lon, [1] * 10, header=False)
    err = _run_bad([str(log), str(no_ell)], capsys)
    assert "ellipsoid" in err
    err = _run_bad([str(log), str(truth), "--poe-rate", "-5"], capsys)
    assert "--poe-rate" in err
    err = _run_bad([str(log), str(truth), "--svg", str(tmp_path / "plot.png")], capsys)
    assert "plot.png: the plot is SVG only" in err and not (tmp_path / "plot.png").exists()
    # the datum file fills in a missing ellipsoid
    rc = main(["assess", str(log), str(no_ell), "--datum-file", str(DATA / "TO_WGS84.DAT")])
    assert rc == 0 and "matched 10" in capsys.readouterr().out


def test_a_log_cut_or_damaged_is_named_by_line(tmp_path: Path) -> None:
    """JSON lines cut in the middle of the last line (a run interrupted) are read as a cut
    .OUT is, with a note; a line that is not UTF-8, or a CYCLE line with a bad time, is an
    error naming file and line (they were unlocated, and a cut JSON line was refused)."""
    n = 20
    times, lat, lon = _truth_track(n)
    C = np.diag([25.0, 25.0])
    est = [offset(lat[k], lon[k], np.array([1.0, 0.0]), C) for k in range(n)]
    cycles = [Cycle(times[k], est[k], est[k], est[k]) for k in range(n)]
    whole = write_jsonl(tmp_path / "W.jsonl", cycles).read_bytes()
    cut = tmp_path / "C.jsonl"
    cut.write_bytes(whole[: whole.index(b"\n", len(whole) // 2) + 30])
    log = read_nav_log(cut)
    assert 0 < len(log.t_ms) < n
    assert f"{cut}:{len(log.t_ms) + 1}: last line is incomplete (run interrupted)" in log.notes
    out = write_out(tmp_path / "D.OUT", cycles).read_bytes().split(b"\n")
    first = next(i for i, ln in enumerate(out) if ln.startswith(b"CYCLE"))
    inner = first + 2
    bad_utf8 = out.copy()
    bad_utf8[inner] = b"garbage \xff"
    (tmp_path / "U.OUT").write_bytes(b"\n".join(bad_utf8))
    with pytest.raises(InputError) as err:
        read_nav_log(tmp_path / "U.OUT")
    assert str(err.value).startswith(f"{tmp_path / 'U.OUT'}:{inner + 1}: line: Not UTF-8 text !")
    bad_time = out.copy()
    bad_time[first] = re.sub(rb"t=\d{4}-\d\d", b"t=1992-99", bad_time[first])
    (tmp_path / "T.OUT").write_bytes(b"\n".join(bad_time))
    with pytest.raises(InputError) as err:
        read_nav_log(tmp_path / "T.OUT")
    assert str(err.value).startswith(f"{tmp_path / 'T.OUT'}:{first + 1}: CYCLE n=1 t: ")


def test_a_position_that_is_no_number_is_named(tmp_path: Path) -> None:
    """An MPP whose latitude was damaged to ``1e999`` (infinite) or to text is left out of the
    track, as before, but no longer silently: a note names the cycle's line and counts them.
    NaN, the engine's own "no value", is not reported."""
    n = 10
    times, lat, lon = _truth_track(n)
    C = np.diag([25.0, 25.0])
    est = [offset(lat[k], lon[k], np.array([1.0, 0.0]), C) for k in range(n)]
    out = write_out(tmp_path / "D.OUT", [Cycle(times[k], est[k], est[k], est[k])
                                         for k in range(n)]).read_bytes().split(b"\n")
    cycle_lines = [i for i, ln in enumerate(out) if ln.startswith(b"CYCLE")]
    mpp = [i for i, ln in enumerate(out) if ln.lstrip().startswith(b"MPP")]
    for k, bad in ((2, b"1e999"), (5, b"north"), (7, b"nan")):
        out[mpp[k]] = re.sub(rb" lat=\S+", b" lat=" + bad, out[mpp[k]])
    (tmp_path / "B.OUT").write_bytes(b"\n".join(out))
    log = read_nav_log(tmp_path / "B.OUT")
    assert not np.isfinite(log.tracks["mpp"].lat_deg[[2, 5, 7]]).any()  # out of the statistics
    assert (f"{tmp_path / 'B.OUT'}:{cycle_lines[2] + 1}: the cycle's MPP lat/lon is not a "
            "number (got inf): that position is left out, and 1 more such") in log.notes


def test_a_file_that_is_no_log_is_named_as_such(tmp_path: Path) -> None:
    """assess on a text file that is no log says so, as export does (it said 'token without
    key=value' about its first word)."""
    notes = tmp_path / "notes.txt"
    notes.write_text("notes about the trip\n", encoding="utf-8")
    with pytest.raises(InputError) as err:
        read_nav_log(notes)
    assert str(err.value).startswith(f"{notes}:1: log: Not a UVNAV .OUT log or JSON-lines log")

"""``uvnav simulate --nmea``: the simulated mission as an NMEA 0183 log (engine/sim/nmea.py).

Independent sources: pynmea2 parses every line with its checksum verified; the noise-free
truth (lat_wgs84, heading, speed, depth) and hand-computed velocities over ground. Tolerances:
half a step of the NMEA format — position 0.5e-4′ = 0.5e-4/60° (≈ 0.093 m), heading, speed and
depth 0.05 (one decimal) — plus 1e-9 for floating point.
"""

from __future__ import annotations

import math
from pathlib import Path

import pynmea2
import pytest

from engine.io.runfile import BadRecord, iter_run_file
from engine.sim.nmea import SIM_GGA_HDOP, SIM_GGA_QUALITY, SIM_GGA_SATS, ground_velocity
from engine.sim.scenario import parse_scenario_text
from engine.sim.simulate import read_data_files, simulate, write_simulation
from engine.systems.sensors import KNOT_MS
from tests.paths import DATA
from uvnav_tui.cli.simulate import run_simulate

HALF_STEP_DEG = 0.5e-4 / 60.0 + 1e-12

# 60 s surfaced (GPS), 60 s dived to 20 m (no GPS), with a current and an echo sounder.
MISSION = """start_time = "1992-09-17T23:59:30Z"
start_position = "52 50 00 N 004 30 00 E"
water_depth_m = 70
[current]
set_deg = 30
speed_kn = 0.5
[sensors]
echosounder = true
[[leg]]
duration_s = 60
course_deg = 232
speed_kn = 10
[[leg]]
duration_s = 60
course_deg = 232
speed_kn = 10
depth_m = 20
surfaced = false
"""


@pytest.fixture(scope="module")
def data_files():
    return read_data_files(DATA)


def _write(tmp: Path, text: str, data_files, seed: int = 5, name: str = "S") -> Path:
    datums, chains = data_files
    sc = parse_scenario_text(text)
    write_simulation(sc, tmp / f"{name}.RUN", tmp / f"{name}.truth.csv", seed, datums=datums,
                     chains=chains, nmea_path=tmp / f"{name}.nmea")
    return tmp / f"{name}.nmea"


def _sentences(path: Path) -> list[pynmea2.NMEASentence]:
    raw = path.read_bytes()
    assert raw.endswith(b"\r\n") and b"\n" not in raw.replace(b"\r\n", b"")
    return [pynmea2.parse(line, check=True) for line in raw.decode("ascii").split("\r\n")[:-1]]


def _epochs(sentences: list[pynmea2.NMEASentence]) -> list[list[pynmea2.NMEASentence]]:
    """One list per second: an epoch starts with its GGA, or with its ZDA when it has no fix."""
    groups: list[list[pynmea2.NMEASentence]] = []
    for s in sentences:
        kind = s.sentence_type
        if kind == "GGA" or (kind == "ZDA" and not (groups and groups[-1][-1].sentence_type
                                                    == "RMC")):
            groups.append([s])
        else:
            groups[-1].append(s)
    return groups


def test_noise_free_log_matches_the_truth(tmp_path: Path, data_files) -> None:
    datums, chains = data_files
    sc = parse_scenario_text(MISSION).without_errors()
    pairs = list(simulate(sc, datums, chains, seed=3))
    write_simulation(sc, tmp_path / "N.RUN", None, 3, datums=datums, chains=chains,
                     nmea_path=tmp_path / "N.nmea")
    epochs = _epochs(_sentences(tmp_path / "N.nmea"))
    assert len(epochs) == len(pairs) == 120
    for (truth, _rec), group in zip(pairs, epochs, strict=True):
        kinds = [s.sentence_type for s in group]
        if truth.surfaced:
            assert kinds == ["GGA", "RMC", "ZDA", "HDT", "VHW", "DBT"]
            gga, rmc = group[0], group[1]
            for s in (gga, rmc):
                assert abs(s.latitude - truth.lat_wgs84_deg) <= HALF_STEP_DEG
                assert abs(s.longitude - truth.lon_wgs84_deg) <= HALF_STEP_DEG
            assert (gga.gps_qual, int(gga.num_sats), float(gga.horizontal_dil)) == (
                SIM_GGA_QUALITY, SIM_GGA_SATS, SIM_GGA_HDOP)
            assert rmc.status == "A" and rmc.mode_indicator == "A"
            # hand calculation: 10 kn along 232° plus 0.5 kn towards 030°, level
            ve = 10 * math.sin(math.radians(232)) + 0.5 * math.sin(math.radians(30))
            vn = 10 * math.cos(math.radians(232)) + 0.5 * math.cos(math.radians(30))
            assert rmc.spd_over_grnd == pytest.approx(math.hypot(ve, vn), abs=0.05 + 1e-9)
            cog = math.degrees(math.atan2(ve, vn)) % 360.0
            assert rmc.true_course == pytest.approx(cog, abs=0.05 + 1e-9)
        else:
            assert kinds == ["ZDA", "HDT", "VHW", "DBT"]
        zda = group[kinds.index("ZDA")]
        t = truth.time
        assert (zda.year, zda.month, zda.day) == (t.year, t.month, t.day)  # midnight roll-over
        assert zda.timestamp.replace(tzinfo=None) == t.time().replace(tzinfo=None)
        by = {s.sentence_type: s for s in group}
        assert float(by["HDT"].heading) == pytest.approx(truth.heading_true_deg, abs=0.05 + 1e-9)
        assert float(by["VHW"].water_speed_knots) == pytest.approx(truth.speed_kn, abs=0.05 + 1e-9)
        assert float(by["VHW"].heading_true) == float(by["HDT"].heading)
        assert float(by["DBT"].depth_meters) == pytest.approx(70.0 - truth.depth_m,
                                                              abs=0.05 + 1e-9)
    # the first epoch after midnight carries the new date in RMC too
    rmcs = [g[1] for g in epochs if g[0].sentence_type == "GGA"]
    assert rmcs[0].datestamp.day == 17 and rmcs[-1].datestamp.day == 18


def test_log_follows_the_readings_of_the_run(tmp_path: Path, data_files) -> None:
    """With errors: every NMEA value is the .RUN's reading at NMEA's precision (the .RUN is
    quantised to 0.001″ = ±0.0155 m, 0.1°, 0.1 kn, 0.01 m, so the two differ by at most the sum
    of both half steps)."""
    path = _write(tmp_path, MISSION, data_files)
    recs = [r for r in iter_run_file(tmp_path / "S.RUN")]
    assert not any(isinstance(r, BadRecord) for r in recs)
    epochs = _epochs(_sentences(path))
    assert len(epochs) == len(recs)
    run_half_deg = 0.0005 / 3600.0
    for rec, group in zip(recs, epochs, strict=True):
        by = {s.sentence_type: s for s in group}
        assert ("GGA" in by) == (rec.gps_lat_deg is not None)
        if rec.gps_lat_deg is not None:
            assert abs(by["GGA"].latitude - rec.gps_lat_deg) <= HALF_STEP_DEG + run_half_deg
            assert abs(by["GGA"].longitude - rec.gps_lon_deg) <= HALF_STEP_DEG + run_half_deg
        assert float(by["HDT"].heading) == pytest.approx(rec.heading_deg, abs=0.1 + 1e-9)
        assert float(by["VHW"].water_speed_knots) == pytest.approx(rec.speed_kn, abs=0.1 + 1e-9)
        assert float(by["DBT"].depth_meters) == pytest.approx(rec.echo_m, abs=0.055 + 1e-9)


def test_nmea_log_changes_nothing_in_the_run(tmp_path: Path, data_files) -> None:
    datums, chains = data_files
    sc = parse_scenario_text(MISSION)
    write_simulation(sc, tmp_path / "A.RUN", tmp_path / "A.csv", 9, datums=datums, chains=chains)
    write_simulation(sc, tmp_path / "B.RUN", tmp_path / "B.csv", 9, datums=datums, chains=chains,
                     nmea_path=tmp_path / "B.nmea")
    assert (tmp_path / "A.RUN").read_bytes() == (tmp_path / "B.RUN").read_bytes()
    assert (tmp_path / "A.csv").read_bytes() == (tmp_path / "B.csv").read_bytes()


def test_gps_on_another_datum_is_written_on_wgs84(tmp_path: Path, data_files) -> None:
    """Same seed, the receiver on ED50 instead of WGS84: the same grid errors (same draws), so
    the NMEA positions agree; the two conversions differ only by h = 0 on ED50 rather than on
    WGS84 (tens of metres of height through a 3-parameter shift: well below 1 mm horizontally),
    so the bound is the format's full step (0.185 m)."""
    a = _sentences(_write(tmp_path, MISSION, data_files, name="W"))
    b = _sentences(_write(tmp_path, 'run_gps_datum = "ED50"\n' + MISSION, data_files,
                          name="E"))
    ggas_a = [s for s in a if s.sentence_type == "GGA"]
    ggas_b = [s for s in b if s.sentence_type == "GGA"]
    assert len(ggas_a) == len(ggas_b) == 60
    for sa, sb in zip(ggas_a, ggas_b, strict=True):
        assert abs(sa.latitude - sb.latitude) <= 2 * HALF_STEP_DEG
        assert abs(sa.longitude - sb.longitude) <= 2 * HALF_STEP_DEG
    # and the .RUN of the ED50 run is not on WGS84: ED50 differs by ~100 m here
    run_e = [r for r in iter_run_file(tmp_path / "E.RUN") if r.gps_lat_deg is not None]
    assert abs(run_e[0].gps_lat_deg - ggas_b[0].latitude) * 111e3 > 50.0


def test_ground_velocity_hand_calculation() -> None:
    # 90° at 10 kn, level, in 1 kn of current towards north: √101 kn towards atan2(10, 1)
    sog, cog = ground_velocity(90.0, 10.0, 0.0, 0.0, KNOT_MS)
    assert sog == pytest.approx(math.sqrt(101.0), rel=1e-12)
    assert cog == pytest.approx(math.degrees(math.atan2(10.0, 1.0)), abs=1e-9)
    # pitched 60° down: half the water speed is horizontal
    assert ground_velocity(0.0, 10.0, 60.0, 0.0, 0.0)[0] == pytest.approx(5.0, rel=1e-12)
    assert ground_velocity(0.0, 0.0, 0.0, 0.0, 0.0) == (0.0, None)


def test_cli_nmea_output_rule(tmp_path: Path) -> None:
    scen = tmp_path / "s.toml"
    scen.write_text(f'data_dir = "{DATA}"\n' + MISSION, encoding="utf-8")
    out, nmea = tmp_path / "o.RUN", tmp_path / "o.nmea"
    base = [str(scen), "--out", str(out), "--nmea", str(nmea)]
    assert run_simulate(base) == 0
    first = nmea.read_bytes()
    assert first.startswith(b"$GPGGA,235930.00,")
    out.unlink()
    assert run_simulate(base) == 2  # exists, no --force: refused
    assert nmea.read_bytes() == first
    assert run_simulate([*base, "--force", "--seed", "4"]) == 0  # an earlier NMEA log
    assert nmea.read_bytes() != first
    notes = tmp_path / "notes.txt"
    notes.write_text("my notes\n", encoding="utf-8")
    assert run_simulate([str(scen), "--out", str(out), "--nmea", str(notes), "--force"]) == 2
    assert notes.read_text(encoding="utf-8") == "my notes\n"
    assert run_simulate([str(scen), "--out", str(tmp_path / "p.RUN"), "--nmea",
                         str(tmp_path / "p.RUN")]) == 2  # same file as --out
    assert run_simulate([str(scen), "--out", str(tmp_path / "q.RUN"), "--nmea",
                         str(scen), "--force"]) == 2  # the scenario


def test_record_hdop_and_quality_are_written_when_modelled() -> None:
    """A record that carries the receiver's HDOP and fix quality (a scenario with an HDOP model)
    writes them; DGPS (2) makes RMC's mode D."""
    from datetime import UTC, datetime

    from engine.geodesy.ellipsoid import WGS84
    from engine.io.runfile import RunRecord
    from engine.sim.nmea import SimNmea

    rec = RunRecord(1, datetime(2026, 12, 2, 12, 0, 0, tzinfo=UTC), 52.5, 4.5,
                    (None, None, None), 90.0, 5.0, None, gps_hdop=2.3, gps_quality=2)
    lines = SimNmea(WGS84).epoch(rec, heading_true_deg=90.0, speed_kn=5.0, pitch_deg=0.0,
                                 current_e_ms=0.0, current_n_ms=0.0)
    gga, rmc = (pynmea2.parse(x, check=True) for x in lines[:2])
    assert gga.gps_qual == 2 and float(gga.horizontal_dil) == 2.3
    assert rmc.mode_indicator == "D"
    assert rmc.spd_over_grnd == 5.0 and rmc.true_course == 90.0

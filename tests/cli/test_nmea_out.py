"""``uvnav replay --nmea-out``: the integrated position (MPP) as NMEA 0183, over a real UDP
socket on localhost and to a file (engine/run/nmea_out.py, engine/io/nmea_send.py).

Independent sources: pynmea2 (parse with the checksum verified); pyproj with a PROJ string
written here (``+towgs84`` from the ED50 line of TO_WGS84.DAT) for ED50 → WGS84, and pyproj's
own meridian convergence of the TM grid; the JSON-lines log of the same run for the MPP, its
95 % ellipse and the filter state. Tolerances: the NMEA position step, 0.5e-4′ = 0.5e-4/60°
(0.093 m), plus 2e-9° for the JSONL's 1e-9° rounding; one decimal (±0.05) for HDOP, course and
heading; two decimals (±0.005 m) plus the JSONL's 1 mm rounding of the 95 % axes for GST.
"""

from __future__ import annotations

import json
import math
import socket
import threading
from pathlib import Path

import numpy as np
import pynmea2
import pyproj
import pytest

from engine.run.nmea_out import NMEA_OUT_UERE_M, _gst, _rotate_cov
from engine.sim.scenario import parse_scenario_text
from engine.sim.simulate import read_data_files, write_simulation
from tests.paths import DATA
from uvnav_tui.cli.main import main

HALF_STEP_DEG = 0.5e-4 / 60.0
K95 = math.sqrt(-2.0 * math.log(0.05))
"""95 % ellipse factor for two dimensions: P(χ²₂ ≤ k²) = 1 − e^(−k²/2) = 0.95."""

# 90 s surfaced with GPS, then 90 s dived (no fix: dead reckoning), gyro and log on.
MISSION = """start_time = "1992-09-17T10:00:00Z"
start_position = "52 50 00 N 004 30 00 E"
[current]
set_deg = 30
speed_kn = 0.5
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
run_file = "DIVE.RUN"
run_gps_datum = "WGS84"
data_dir = "{DATA}"
[gps]
on = true
[decca]
on = false
"""

TO_WGS84 = pyproj.Transformer.from_crs(
    pyproj.CRS.from_proj4("+proj=longlat +a=6378388 +rf=297 +towgs84=-87,-98,-121 +no_defs"),
    pyproj.CRS.from_proj4("+proj=longlat +datum=WGS84 +no_defs"), always_xy=True)


@pytest.fixture(scope="module")
def dive(tmp_path_factory) -> Path:
    """The simulated surfaced-then-dived run, its configuration beside it."""
    d = tmp_path_factory.mktemp("dive")
    datums, chains = read_data_files(DATA)
    write_simulation(parse_scenario_text(MISSION), d / "DIVE.RUN", None, 21, datums=datums,
                     chains=chains)
    (d / "DIVE.toml").write_text(CONFIG, encoding="utf-8")
    return d


class Receiver:
    """A UDP socket on 127.0.0.1 drained by a thread while the replay sends."""

    def __init__(self) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.2)
        self.port = self.sock.getsockname()[1]
        self.datagrams: list[bytes] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, daemon=True)
        self._thread.start()

    def _loop(self) -> None:
        while True:
            try:
                self.datagrams.append(self.sock.recv(65536))
            except TimeoutError:
                if self._stop.is_set():
                    return

    def stop(self) -> list[bytes]:
        self._stop.set()
        self._thread.join(5.0)
        self.sock.close()
        return self.datagrams


def _groups(lines: list[str]) -> list[dict[str, pynmea2.NMEASentence]]:
    """One dict per cycle (a cycle starts with its ZDA, then GGA)."""
    out: list[dict[str, pynmea2.NMEASentence]] = []
    for line in lines:
        s = pynmea2.parse(line, check=True)
        assert s.talker == "IN"
        if s.sentence_type == "ZDA":
            out.append({})
        assert s.sentence_type not in out[-1]
        out[-1][s.sentence_type] = s
    return out


def _convergence_deg(lat: float, lon: float, cm: float) -> float:
    """pyproj's meridian convergence of the TM grid (k0 = 1, no false origin) on Intl 1924."""
    tm = pyproj.Proj(f"+proj=tmerc +lon_0={cm} +k=1 +x_0=0 +y_0=0 +a=6378388 +rf=297")
    return tm.get_factors(lon, lat).meridian_convergence


def _check_against_jsonl(groups: list[dict[str, pynmea2.NMEASentence]], jsonl: Path) -> None:
    cycles = [json.loads(line) for line in jsonl.read_text(encoding="utf-8").splitlines()]
    assert len(groups) == len(cycles) == 180
    qualities = []
    for g, c in zip(groups, cycles, strict=True):
        gga, rmc = g["GGA"], g["RMC"]
        m = c["mpp"]
        lon_w, lat_w = TO_WGS84.transform(m["lon"], m["lat"])
        for s in (gga, rmc):
            assert abs(s.latitude - lat_w) <= HALF_STEP_DEG + 2e-9
            assert abs(s.longitude - lon_w) <= HALF_STEP_DEG + 2e-9
        assert gga.timestamp.strftime("%H:%M:%S") == c["time"][11:19]
        assert rmc.datestamp.isoformat() == c["time"][:10]
        z = g["ZDA"]
        assert f"{z.year:04d}-{z.month:02d}-{z.day:02d}T{z.timestamp:%H:%M:%S}Z" == c["time"]
        assert list(g)[:3] == ["ZDA", "GGA", "RMC"]
        fix_used = c["lse"] is not None
        quality = 1 if fix_used else 6
        qualities.append(gga.gps_qual)
        assert gga.gps_qual == quality
        assert (rmc.status, rmc.mode_indicator) == (("A", "A") if fix_used else ("V", "E"))
        # pseudo HDOP = drms / UERE, drms² = a² + b² of the 1 σ ellipse = (a95² + b95²)/k95²
        drms = math.hypot(m["a95"], m["b95"]) / K95
        assert float(gga.horizontal_dil) == pytest.approx(
            min(max(drms / NMEA_OUT_UERE_M, 0.1), 99.9), abs=0.05 + 1e-3)
        gamma = _convergence_deg(m["lat"], m["lon"], c["cm_deg"])
        gst = g["GST"]
        assert gst.std_dev_major == pytest.approx(m["a95"] / K95, abs=0.005 + 1e-3)
        assert gst.std_dev_minor == pytest.approx(m["b95"] / K95, abs=0.005 + 1e-3)
        d_az = (gst.orientation - (m["az_deg"] + gamma)) % 180.0
        if gst.std_dev_major - gst.std_dev_minor > 0.1:  # a round ellipse has no orientation
            assert min(d_az, 180.0 - d_az) <= 0.05 + 0.01
        if c["state"] is not None:
            psi = math.degrees(c["state"][4])
            hdt = float(g["HDT"].heading)
            d = (hdt - (psi + gamma)) % 360.0
            assert min(d, 360.0 - d) <= 0.05 + 1e-4
    assert 1 in qualities and 6 in qualities  # surfaced fixes and the dive's dead reckoning
    assert qualities.index(6) > 80  # DR only after the dive (plus the odd gated fix)


def test_udp_to_localhost(dive: Path, tmp_path: Path, capsys) -> None:
    rx = Receiver()
    jsonl = tmp_path / "d.jsonl"
    rc = main(["replay", str(dive / "DIVE.RUN"), "--no-out", "--jsonl", str(jsonl),
               "--nmea-out", f"udp://127.0.0.1:{rx.port}"])
    datagrams = rx.stop()
    assert rc == 0
    out = capsys.readouterr().out
    assert f"nmea out {len(datagrams)} sentences to udp://127.0.0.1:{rx.port}" in out
    for d in datagrams:  # one sentence per datagram, CR LF ended
        assert d.endswith(b"\r\n") and d.count(b"$") == 1 and d.count(b"\n") == 1
    _check_against_jsonl(_groups([d.decode("ascii").rstrip("\r\n") for d in datagrams]), jsonl)


def test_file_follows_the_output_rule(dive: Path, tmp_path: Path) -> None:
    jsonl = tmp_path / "f.jsonl"
    path = tmp_path / "f.nmea"
    args = ["replay", str(dive / "DIVE.RUN"), "--no-out", "--nmea-out", str(path),
            "--nmea-gll"]
    assert main([*args, "--jsonl", str(jsonl)]) == 0
    raw = path.read_bytes()
    assert raw.endswith(b"\r\n") and b"\n" not in raw.replace(b"\r\n", b"")
    lines = raw.decode("ascii").split("\r\n")[:-1]
    groups = _groups(lines)
    _check_against_jsonl(groups, jsonl)
    for g in groups:  # GLL carries the same position and status as RMC
        assert (g["GLL"].lat, g["GLL"].lon, g["GLL"].status) == (
            g["RMC"].lat, g["RMC"].lon, g["RMC"].status)
    # an existing log is kept: the next run writes f_1.nmea
    assert main(args) == 0
    assert path.read_bytes() == raw and (tmp_path / "f_1.nmea").read_bytes() == raw
    # --force replaces an earlier NMEA log, never anything else
    assert main([*args, "--force"]) == 0
    notes = tmp_path / "notes.txt"
    notes.write_text("mine\n", encoding="utf-8")
    assert main(["replay", str(dive / "DIVE.RUN"), "--no-out", "--nmea-out", str(notes),
                 "--force"]) == 2
    assert notes.read_text(encoding="utf-8") == "mine\n"
    assert main(["replay", str(dive / "DIVE.RUN"), "--no-out", "--nmea-out",
                 str(dive / "DIVE.RUN"), "--force"]) == 2  # the run file itself


@pytest.mark.parametrize("dest", ["tcp://127.0.0.1:10110", "udp://127.0.0.1:0",
                                  "udp://127.0.0.1:70000", "udp://:10110", "udp://h:x", ""])
def test_bad_destination_is_refused(dive: Path, tmp_path: Path, dest: str, capsys) -> None:
    assert main(["replay", str(dive / "DIVE.RUN"), "--no-out", "--nmea-out", dest]) == 2
    assert "--nmea-out" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_gst_hand_calculation() -> None:
    """σ_E = 3 m, σ_N = 4 m, no correlation, on a grid turned γ = 0: major 4 m north (0°);
    with ρ: λ from the closed form; turned by γ = 30°: the ellipse turns with it."""
    from datetime import UTC, datetime

    class _R:
        time = datetime(2026, 1, 1, tzinfo=UTC)

    cov = np.array([[9.0, 0.0], [0.0, 16.0]])
    s = pynmea2.parse(_gst(_R(), _rotate_cov(cov, 0.0), "IN"), check=True)  # type: ignore[arg-type]
    assert (s.std_dev_major, s.std_dev_minor, s.orientation) == (4.0, 3.0, 0.0)
    assert (s.std_dev_latitude, s.std_dev_longitude) == (4.0, 3.0)
    s = pynmea2.parse(_gst(_R(), _rotate_cov(cov, 30.0), "IN"), check=True)  # type: ignore[arg-type]
    assert (s.std_dev_major, s.std_dev_minor, s.orientation) == (4.0, 3.0, 30.0)
    # σ_N² = 16 cos² 30° + 9 sin² 30° = 14.25, σ_E² = 16 sin² 30° + 9 cos² 30° = 10.75
    assert s.std_dev_latitude == pytest.approx(math.sqrt(14.25), abs=0.005)
    assert s.std_dev_longitude == pytest.approx(math.sqrt(10.75), abs=0.005)
    corr = np.array([[4.0, 2.0], [2.0, 4.0]])  # λ = 6, 2; major axis towards 045°
    s = pynmea2.parse(_gst(_R(), corr, "IN"), check=True)  # type: ignore[arg-type]
    assert s.std_dev_major == pytest.approx(math.sqrt(6.0), abs=0.005)
    assert s.std_dev_minor == pytest.approx(math.sqrt(2.0), abs=0.005)
    assert s.orientation == 45.0


def test_output_read_back_by_the_nmea_reader(dive: Path, tmp_path: Path) -> None:
    """The NMEA reader (engine/io/nmea_log.py) takes the quality-1 cycles of the output as
    fixes and never a dead-reckoned (quality 6, RMC status V) one; positions back on WGS84
    within the NMEA step. HDT comes back as the heading of every cycle."""
    from engine.io.nmea_epochs import NmeaOptions
    from engine.io.nmea_log import NmeaLog

    path, jsonl = tmp_path / "back.nmea", tmp_path / "back.jsonl"
    assert main(["replay", str(dive / "DIVE.RUN"), "--no-out", "--jsonl", str(jsonl),
                 "--nmea-out", str(path)]) == 0
    cycles = [json.loads(line) for line in jsonl.read_text(encoding="utf-8").splitlines()]
    records = list(NmeaLog(path, NmeaOptions(position_stale_s=0.5)))
    assert len(records) == len(cycles) == 180
    for rec, c in zip(records, cycles, strict=True):
        assert rec.time.strftime("%Y-%m-%dT%H:%M:%SZ") == c["time"]
        if c["lse"] is None:
            assert rec.gps_lat_deg is None  # dead reckoning is not a fix
        else:
            lon_w, lat_w = TO_WGS84.transform(c["mpp"]["lon"], c["mpp"]["lat"])
            assert abs(rec.gps_lat_deg - lat_w) <= HALF_STEP_DEG + 2e-9
            assert abs(rec.gps_lon_deg - lon_w) <= HALF_STEP_DEG + 2e-9
            assert rec.gps_quality == 1
        assert rec.heading_deg is not None

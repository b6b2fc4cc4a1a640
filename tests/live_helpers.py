"""Shared helpers of the live-source tests: a synthetic 1 Hz NMEA stream and its senders
(tests/cli/test_live.py, tests/tui/test_console_live.py). The checksums are computed by
tests/nmea_lines.py, independently of the code under test."""

from __future__ import annotations

import socket
import threading
import time
from pathlib import Path

from tests.nmea_lines import ddmm, hhmmss, nmea
from tests.paths import DATA

DEADLINE_S = 60.0
LAT0 = 52.8333333333  # 52°50'N
LON0 = 4.5
T0 = 43200  # 12:00:00 UTC


def epoch_lines(k: int) -> list[str]:
    """The sentences of second ``k``: GGA + RMC (position, time, date), HDT, VHW."""
    t = T0 + k
    lat = LAT0 + k * 5.0 / 3600.0 / 60.0
    return [
        nmea(f"GPGGA,{hhmmss(t)},{ddmm(lat)},N,{ddmm(LON0, 3)},E,1,09,0.8,3.0,M,46.0,M,,"),
        nmea(f"GPRMC,{hhmmss(t)},A,{ddmm(lat)},N,{ddmm(LON0, 3)},E,5.0,0.0,021226,,,A"),
        nmea("HEHDT,0.0,T"),
        nmea("VWVHW,,T,,M,5.0,N,,K"),
    ]


def expected_lat(k: int) -> float:
    """The GGA latitude of second ``k`` as sent (``ddmm.mmmm``: 4 decimals of minutes)."""
    return float(ddmm(LAT0 + k * 5.0 / 216000.0)[:2]) + float(
        ddmm(LAT0 + k * 5.0 / 216000.0)[2:]) / 60.0


def write_config(path: Path, run_file: str = "unused.RUN") -> Path:
    """A WGS84 configuration with GPS on and Decca off (the stream has no Decca)."""
    path.write_text(
        f'datum = "WGS84"\ndr_position = "52 50 00 N 004 30 00 E"\nrun_file = "{run_file}"\n'
        f'run_gps_datum = "WGS84"\ndata_dir = "{DATA}"\n[gps]\non = true\n[decca]\non = false\n')
    return path


def free_port(kind: int) -> int:
    """A port nobody uses now (bound and released: the command binds it again)."""
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def wait_bound_udp(port: int, stop: threading.Event) -> bool:
    """Wait until someone has bound UDP ``port`` (our own bind then fails)."""
    deadline = time.monotonic() + DEADLINE_S
    while time.monotonic() < deadline and not stop.is_set():
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            try:
                probe.bind(("127.0.0.1", port))
            except OSError:
                return True
        stop.wait(0.05)
    return False


def send_udp(port: int, seconds: range, stop: threading.Event, pace_s: float = 0.01) -> None:
    """Each second's sentences as one datagram (as OpenCPN and multiplexers send)."""
    if not wait_bound_udp(port, stop):
        return
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as out:
        for k in seconds:
            out.sendto("".join(s + "\r\n" for s in epoch_lines(k)).encode(), ("127.0.0.1", port))
            if stop.wait(pace_s):
                return

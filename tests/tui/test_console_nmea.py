"""``uvnav --nmea-out udp://HOST:PORT``: the console sends every cycle's MPP as NMEA 0183 to a
real UDP socket on localhost (the same sentences as ``uvnav replay --nmea-out``, whose values
tests/cli/test_nmea_out.py checks against the JSON lines; here: that the console sends them,
one cycle's GGA at each cycle, with the cycle's time, position within the NMEA step
0.5e-4′ = 0.5e-4/60° of the WGS84 MPP computed by pyproj from the console's ED50 MPP)."""

from __future__ import annotations

import socket
from pathlib import Path

import pynmea2
import pyproj

from engine.api import open_nmea_sender, parse_nmea_destination
from tests.tui.test_console_support import drive, make_app, start
from uvnav_tui.cli.console import run_console

TO_WGS84 = pyproj.Transformer.from_crs(
    pyproj.CRS.from_proj4("+proj=longlat +a=6378388 +rf=297 +towgs84=-87,-98,-121 +no_defs"),
    pyproj.CRS.from_proj4("+proj=longlat +datum=WGS84 +no_defs"), always_xy=True)


def test_console_sends_each_cycle(data_dir: Path) -> None:
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    rx.settimeout(5.0)
    sender = open_nmea_sender(parse_nmea_destination(f"udp://127.0.0.1:{rx.getsockname()[1]}"))
    app = make_app(data_dir, nmea_sender=sender)
    mpps = []

    async def script(pilot) -> None:  # type: ignore[no-untyped-def]
        await start(pilot)
        for _ in range(3):
            await app.wait_cycles(1)
            r = app.control.latest
            mpps.append((r.time, r.mpp.lat_deg, r.mpp.lon_deg, r.datum))

    try:
        drive(app, script)
    finally:
        sender.close()
    ggas = []
    while len(ggas) < 3:
        s = pynmea2.parse(rx.recv(4096).decode("ascii").rstrip("\r\n"), check=True)
        if s.sentence_type == "GGA":
            ggas.append(s)
    rx.close()
    for gga, (t, lat, lon, datum) in zip(ggas, mpps, strict=True):
        assert datum == "ED50"
        lon_w, lat_w = TO_WGS84.transform(lon, lat)
        assert gga.timestamp.strftime("%H%M%S") == t.strftime("%H%M%S")
        assert abs(gga.latitude - lat_w) <= 0.5e-4 / 60 + 1e-12
        assert abs(gga.longitude - lon_w) <= 0.5e-4 / 60 + 1e-12


def test_console_refuses_a_file(capsys) -> None:
    assert run_console(["--nmea-out", "x.nmea"]) == 2
    assert "udp://HOST:PORT only" in capsys.readouterr().err

"""NMEA destinations and the UDP sender (engine/io/nmea_send.py), on real localhost sockets."""

from __future__ import annotations

import socket
from pathlib import Path

import pynmea2
import pytest

from engine.errors import InputError
from engine.io.nmea_send import (
    DEFAULT_NMEA_PORT,
    UdpNmeaSender,
    parse_nmea_destination,
)
from engine.io.nmea_write import hdt


@pytest.mark.parametrize(
    ("text", "host", "port"),
    [("udp://127.0.0.1:10111", "127.0.0.1", 10111), ("udp://[::1]:2000", "::1", 2000),
     ("UDP://plotter.local", "plotter.local", DEFAULT_NMEA_PORT)],
)
def test_udp_destinations(text: str, host: str, port: int) -> None:
    d = parse_nmea_destination(text)
    assert (d.kind, d.host, d.port) == ("udp", host, port)


def test_file_destination() -> None:
    d = parse_nmea_destination("out/MPP.nmea")
    assert d.kind == "file" and d.path == Path("out/MPP.nmea")


@pytest.mark.parametrize("text", ["tcp://h:1", "udp://h:0", "udp://h:65536", "udp://:5",
                                  "udp://h:5/x", "udp://h:5?a=1", "  "])
def test_bad_destinations(text: str) -> None:
    with pytest.raises(InputError) as err:
        parse_nmea_destination(text)
    assert err.value.field == "--nmea-out"


def test_unknown_host_is_input_error() -> None:
    with pytest.raises(InputError):
        UdpNmeaSender("no-such-host.invalid", 10110)


@pytest.mark.parametrize("family, host", [(socket.AF_INET, "127.0.0.1"),
                                          (socket.AF_INET6, "::1")])
def test_one_datagram_per_sentence(family: int, host: str) -> None:
    try:
        rx = socket.socket(family, socket.SOCK_DGRAM)
        rx.bind((host, 0))
    except OSError:
        pytest.skip(f"no {host} on this machine")
    rx.settimeout(5.0)
    tx = UdpNmeaSender(host, rx.getsockname()[1])
    tx.send([hdt(1.0), hdt(2.0)])
    got = [rx.recv(4096), rx.recv(4096)]
    tx.close()
    rx.close()
    # checksums by hand: XOR of "HEHDT,1.0,T" = 0x2E; "2" instead of "1" flips 0x03: 0x2D
    assert got == [b"$HEHDT,1.0,T*2E\r\n", b"$HEHDT,2.0,T*2D\r\n"]
    assert [float(pynmea2.parse(g.decode().strip(), check=True).heading) for g in got] == [1, 2]
    assert (tx.sent, tx.errors) == (2, 0)

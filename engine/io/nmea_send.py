"""Sending NMEA 0183 sentences: to a UDP port or to a log file (docs/NMEA_OUT.md).

A destination is ``udp://HOST:PORT`` (``udp://127.0.0.1:10110``, ``udp://[::1]:10110``, a
broadcast address such as ``udp://192.168.1.255:10110``) or a file path. Each sentence ends in
CR LF, as NMEA 0183 prescribes on the wire; over UDP every sentence is one datagram (what
OpenCPN, gpsd and Signal K expect from an NMEA-over-UDP source; port 10110 is the registered
NMEA-0183 port). A file follows the ``.OUT`` rule (:mod:`engine.io.outputs`: never an input,
never overwritten, ``NAME_N``; ``--force`` replaces an earlier NMEA log only).

A UDP send that fails (no route, a full buffer) does not stop the run: it is counted in
:attr:`UdpNmeaSender.errors` with the first message kept; UDP has no delivery guarantee anyway
and a plotter that is not listening is not an error. A file that cannot be written raises the
:class:`OSError` naming it (:class:`~engine.io.outputs.OutputFile`).
"""

from __future__ import annotations

import socket
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol
from urllib.parse import urlsplit

from engine.errors import InputError
from engine.io.outputs import OutputFile, OutputGuard

__all__ = [
    "DEFAULT_NMEA_PORT",
    "FileNmeaSender",
    "NmeaDestination",
    "NmeaSender",
    "UdpNmeaSender",
    "open_nmea_sender",
    "parse_nmea_destination",
]

DEFAULT_NMEA_PORT = 10110
"""IANA's registered port for NMEA 0183 over IP (``nmea-0183``)."""
BAD_DEST_MESSAGE = "Expected udp://HOST:PORT or a file name !"


class NmeaSender(Protocol):
    """Where the sentences of a cycle go."""

    description: str
    """For the summary: ``udp://127.0.0.1:10110`` or the file actually written."""
    sent: int
    """Sentences handed over so far."""

    def send(self, sentences: list[str]) -> None:
        """Send one cycle's sentences (no line endings; CR LF is added)."""

    def close(self) -> None:
        """Release the socket / close the file (flushed)."""


@dataclass(frozen=True, slots=True)
class NmeaDestination:
    """A parsed destination: ``udp`` with host and port, or ``file`` with a path."""

    kind: str
    host: str = ""
    port: int = 0
    path: Path | None = None


def parse_nmea_destination(text: str, field: str = "--nmea-out") -> NmeaDestination:
    """``udp://HOST:PORT`` → UDP (port 1–65535; the port may be left out: 10110); anything
    else without ``://`` → a file. Raises InputError (``field``) for another scheme, a missing
    host or a bad port."""
    if "://" not in text:
        if not text.strip():
            raise InputError(BAD_DEST_MESSAGE, field=field, text=text)
        return NmeaDestination("file", path=Path(text))
    parts = urlsplit(text)
    if parts.scheme.lower() != "udp" or parts.path not in ("", "/") or parts.query:
        raise InputError(BAD_DEST_MESSAGE, field=field, text=text)
    try:
        port = parts.port
    except ValueError:
        raise InputError("Port must be a whole number 1–65535 !", field=field,
                         text=text) from None
    host = parts.hostname
    if not host:
        raise InputError(BAD_DEST_MESSAGE, field=field, text=text)
    if port == 0:
        raise InputError("Port must be a whole number 1–65535 !", field=field, text=text)
    return NmeaDestination("udp", host=host, port=DEFAULT_NMEA_PORT if port is None else port)


class UdpNmeaSender:
    """One datagram per sentence to ``host:port`` (IPv4 or IPv6; broadcast allowed)."""

    def __init__(self, host: str, port: int) -> None:
        try:
            infos = socket.getaddrinfo(host, port, type=socket.SOCK_DGRAM)
        except socket.gaierror as exc:
            raise InputError(f"Unknown host: {exc.strerror} !", field="--nmea-out",
                             text=f"udp://{host}:{port}") from None
        family, _type, proto, _name, addr = infos[0]
        self._sock = socket.socket(family, socket.SOCK_DGRAM, proto)
        if family == socket.AF_INET:
            self._sock.setsockopt(socket.SOL_SOCKET, socket.SO_BROADCAST, 1)
        self._addr = addr
        self.description = f"udp://{host}:{port}"
        self.sent = 0
        self.errors = 0
        self.first_error: str | None = None

    def send(self, sentences: list[str]) -> None:
        """Send each sentence + CR LF as one datagram; a failure is counted, not raised."""
        for s in sentences:
            try:
                self._sock.sendto((s + "\r\n").encode("ascii"), self._addr)
                self.sent += 1
            except OSError as exc:
                self.errors += 1
                if self.first_error is None:
                    self.first_error = f"{self.description}: {exc.strerror or exc}"

    def close(self) -> None:
        """Close the socket."""
        self._sock.close()


class FileNmeaSender:
    """Sentences + CR LF to an NMEA log file, flushed after every cycle."""

    def __init__(self, fh: OutputFile) -> None:
        self._fh = fh
        self.path = fh.path
        self.description = str(fh.path)
        self.sent = 0

    def send(self, sentences: list[str]) -> None:
        """Append the sentences and flush (an OSError names the file)."""
        self._fh.write("".join(s + "\r\n" for s in sentences))
        self._fh.flush()
        self.sent += len(sentences)

    def close(self) -> None:
        """Flush and close."""
        self._fh.close()


def open_nmea_sender(dest: NmeaDestination, guard: OutputGuard | None = None, *,
                     force: bool = False,
                     label: str = "--nmea-out") -> UdpNmeaSender | FileNmeaSender:
    """Open the sender of ``dest``; a file by the ``.OUT`` rule (kind ``nmea``) through
    ``guard``, so it is never an input or another output of the run. (The file is opened with
    ``newline="\\n"``, which translates nothing: the CR LF written stays CR LF.)"""
    if dest.kind == "udp":
        return UdpNmeaSender(dest.host, dest.port)
    assert dest.path is not None
    g = guard if guard is not None else OutputGuard()
    return FileNmeaSender(g.open(dest.path, label=label, kind="nmea", force=force))

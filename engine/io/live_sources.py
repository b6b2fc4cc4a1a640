"""Live NMEA 0183 sources by URL: UDP, TCP client and serial device (issue 13 item 6).

A source is named by a URL (docs/LIVE.md):

* ``udp://0.0.0.0:10110`` — bind that address and port and receive datagrams; one datagram may
  hold several sentences (OpenCPN, Signal K and most multiplexers broadcast so).
* ``tcp://host:10110`` — connect as a client (OpenCPN's NMEA TCP server, Signal K's NMEA 0183
  TCP port 10110, a multiplexer), reconnecting with a growing back-off after a loss.
* ``gpsd://host:2947`` — the same to gpsd, which first has to be asked for NMEA
  (:data:`GPSD_WATCH` is sent on each connection); its JSON replies are received lines like
  any other (kept in the raw log; the live feed does not pass lines starting with ``{`` to the
  epoch builder).
* ``serial:///dev/ttyUSB0?baud=4800`` — a serial device via pyserial (4800 baud when not
  given, the NMEA 0183 rate; 38400 for NMEA 0183-HS).

:class:`LiveSource` reads in one background thread and hands over, in arrival order,
:class:`ReceivedLine` items (each line as received, with its monotonic and UTC receive time)
and :class:`SourceState` items (each change of state). The state is one of ``connecting`` (no
line yet), ``receiving``, ``lost`` (the connection broke, or no line for
``lost_after_s`` seconds), ``reconnecting`` (re-opening after a loss) and ``closed``; ``since``
is when the state began (for ``lost``/``reconnecting``: when the source was lost). Nothing is
global: every source owns its socket or device and its thread; :meth:`LiveSource.close` closes
them and joins the thread.

Lines are split at LF, CR LF or CR; each line keeps its characters exactly, without the line
ending. Bytes outside printable ASCII are kept as well (decoded as Latin-1, one character per
byte) so the parser can report binary noise; a line longer than :data:`MAX_LINE_BYTES` is cut
there and passed on (the parser rejects it as too long).
"""

from __future__ import annotations

import contextlib
import queue
import socket
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Protocol
from urllib.parse import parse_qs, urlsplit

from engine.errors import InputError

DEFAULT_BAUD = 4800
"""NMEA 0183 serial rate [baud] when the URL gives none."""
BAUD_RATES = (1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400, 460800)
"""Baud rates a ``serial://`` URL may ask for."""
MAX_LINE_BYTES = 4096
"""A line is cut at this length (an NMEA sentence is at most 82 characters)."""
READ_SLICE_S = 0.1
"""Longest blocking read [s]: how soon the reader notices :meth:`LiveSource.close` or silence."""
QUEUE_LINES = 100_000
"""Lines waiting for the consumer before the oldest new ones are dropped (counted)."""

URL_FIELD = "source"
URL_FORMS = ("udp://ADDRESS:PORT, tcp://HOST:PORT, gpsd://HOST:PORT or "
             "serial:///dev/DEVICE?baud=N")

STATUS_CONNECTING = "connecting"
STATUS_RECEIVING = "receiving"
STATUS_LOST = "lost"
STATUS_RECONNECTING = "reconnecting"
STATUS_CLOSED = "closed"


@dataclass(frozen=True)
class SourceSpec:
    """A parsed source URL: ``kind`` is ``udp``, ``tcp``, ``gpsd`` or ``serial``;
    ``host``/``port`` the bind address (UDP) or server (TCP, gpsd); ``device``/``baud`` the
    serial device and rate."""

    url: str
    kind: str
    host: str = ""
    port: int = 0
    device: str = ""
    baud: int = DEFAULT_BAUD


def _url_error(message: str, field: str, text: str) -> InputError:
    return InputError(message, field=field, text=text)


SCHEMES = ("udp", "tcp", "gpsd", "serial")
"""The kinds of live source."""


def is_source_url(text: str) -> bool:
    """True when ``text`` names a live source (``udp://``, ``tcp://``, ``serial://``, any
    case) rather than a file; whether it is a good one is :func:`parse_source_url`'s job."""
    scheme, sep, _rest = text.strip().partition("://")
    return bool(sep) and scheme.lower() in SCHEMES


def parse_source_url(url: str) -> SourceSpec:
    """Parse a live-source URL (module docstring); a bad one is an :class:`InputError` naming
    the part at fault (``source``, ``source host``, ``source port``, ``source device``,
    ``source baud``) and quoting it."""
    text = url.strip()
    if "\0" in text:
        raise _url_error("A source URL cannot contain a NUL character !", URL_FIELD, url)
    try:
        parts = urlsplit(text)
    except ValueError as exc:
        raise _url_error(f"Not a source URL ({exc}): use {URL_FORMS} !", URL_FIELD, url) from None
    scheme = parts.scheme.lower()
    if scheme in ("udp", "tcp", "gpsd"):
        if parts.path not in ("", "/") or parts.query or parts.fragment:
            raise _url_error(f"Nothing may follow the port: use {scheme}://HOST:PORT !",
                             URL_FIELD, url)
        netloc = parts.netloc
        host, sep, port_text = netloc.rpartition(":")
        if not sep or not port_text:
            raise _url_error(f"No port: use {scheme}://HOST:PORT (NMEA over IP: 10110) !",
                             "source port", netloc)
        if host.startswith("[") and host.endswith("]"):
            host = host[1:-1]
        if not host:
            if scheme != "udp":
                raise _url_error(f"No host: use {scheme}://HOST:PORT !", "source host", netloc)
            host = "0.0.0.0"
        if not port_text.isascii() or not port_text.isdigit() or not 1 <= int(port_text) <= 65535:
            raise _url_error("Port must be a number from 1 to 65535 !", "source port", port_text)
        return SourceSpec(url=text, kind=scheme, host=host, port=int(port_text))
    if scheme == "serial":
        device = parts.netloc + parts.path if parts.netloc else parts.path
        if not device:
            raise _url_error("No device: use serial:///dev/DEVICE?baud=N !", "source device",
                             url)
        baud = DEFAULT_BAUD
        query = parse_qs(parts.query, keep_blank_values=True)
        unknown = sorted(set(query) - {"baud"})
        if unknown:
            raise _url_error("Unknown option: a serial source takes only baud= !",
                             URL_FIELD, unknown[0])
        if "baud" in query:
            value = query["baud"][-1]
            if not value.isascii() or not value.isdigit() or int(value) not in BAUD_RATES:
                raise _url_error(f"Baud rate must be one of {', '.join(map(str, BAUD_RATES))} !",
                                 "source baud", value)
            baud = int(value)
        return SourceSpec(url=text, kind="serial", device=device, baud=baud)
    raise _url_error(f"Unknown source kind: use {URL_FORMS} !", URL_FIELD, url)


@dataclass(frozen=True)
class ReceivedLine:
    """One received line: its characters without the line ending, when it was received
    (``mono_s``: :func:`time.monotonic` seconds; ``utc_s``: POSIX seconds, UTC) and its
    1-based number in the stream (the line number of the raw log)."""

    text: str
    mono_s: float
    utc_s: float
    number: int


@dataclass(frozen=True)
class SourceState:
    """The state of a source (module docstring). ``since_mono_s`` is when it began
    (monotonic seconds; for ``lost``/``reconnecting`` the moment the source was lost),
    ``detail`` says why (the system's error, ``no data for 5 s``), ``lines`` counts the lines
    received so far, ``connects`` the successful opens, ``dropped`` the lines dropped because
    the consumer fell :data:`QUEUE_LINES` behind."""

    status: str
    since_mono_s: float
    detail: str = ""
    lines: int = 0
    connects: int = 0
    dropped: int = 0

    @property
    def is_lost(self) -> bool:
        """True while the source is lost (``lost`` or ``reconnecting``)."""
        return self.status in (STATUS_LOST, STATUS_RECONNECTING)

    def describe(self, now_mono_s: float | None = None) -> str:
        """A short status text: ``receiving``, ``SOURCE LOST 12 s (connection refused)`` …"""
        if self.is_lost:
            now = time.monotonic() if now_mono_s is None else now_mono_s
            lost_s = max(0.0, now - self.since_mono_s)
            why = f" ({self.detail})" if self.detail else ""
            again = ", reconnecting" if self.status == STATUS_RECONNECTING else ""
            return f"SOURCE LOST {lost_s:.0f} s{why}{again}"
        if self.status == STATUS_CONNECTING and self.detail:
            return f"connecting ({self.detail})"
        return self.status


class Transport(Protocol):
    """What the reader thread needs of a socket or device."""

    def read(self) -> bytes | None:
        """Bytes received (one datagram for UDP), None after :data:`READ_SLICE_S` without any;
        raises :class:`OSError` (or b"" for TCP end of stream) when the connection is lost."""

    def close(self) -> None:
        """Release the socket or device (idempotent)."""


class _UdpTransport:
    def __init__(self, spec: SourceSpec) -> None:
        family = socket.AF_INET6 if ":" in spec.host else socket.AF_INET
        sock = socket.socket(family, socket.SOCK_DGRAM)
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            sock.bind((spec.host, spec.port))
            sock.settimeout(READ_SLICE_S)
        except BaseException:
            sock.close()
            raise
        self.sock = sock

    def read(self) -> bytes | None:
        try:
            data, _addr = self.sock.recvfrom(65535)
        except TimeoutError:
            return None
        return data

    def close(self) -> None:
        self.sock.close()


GPSD_WATCH = b'?WATCH={"enable":true,"nmea":true};\n'
"""Sent to gpsd on connecting (gpsd(8), "?WATCH"): stream the receivers' NMEA sentences."""


class _TcpTransport:
    def __init__(self, spec: SourceSpec, connect_timeout_s: float) -> None:
        sock = socket.create_connection((spec.host, spec.port), timeout=connect_timeout_s)
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_KEEPALIVE, 1)
            if spec.kind == "gpsd":
                sock.sendall(GPSD_WATCH)
            sock.settimeout(READ_SLICE_S)
        except BaseException:
            sock.close()
            raise
        self.sock = sock

    def read(self) -> bytes | None:
        try:
            data = self.sock.recv(65536)
        except TimeoutError:
            return None
        if not data:
            raise ConnectionError("connection closed by the server")
        return data

    def close(self) -> None:
        with contextlib.suppress(OSError):
            self.sock.shutdown(socket.SHUT_RDWR)
        self.sock.close()


class _SerialTransport:
    def __init__(self, spec: SourceSpec) -> None:
        import serial  # pyserial: only when a serial source is used

        self._error = serial.SerialException
        try:
            self.port = serial.Serial(spec.device, spec.baud, timeout=READ_SLICE_S)
        except (serial.SerialException, ValueError) as exc:
            raise OSError(str(exc)) from None

    def read(self) -> bytes | None:
        try:
            data: bytes = self.port.read(1)  # blocks up to READ_SLICE_S for the first byte
            if data:
                waiting = self.port.in_waiting
                if waiting:
                    data += self.port.read(waiting)
        except (self._error, TypeError, AttributeError) as exc:  # Type/Attr: closed meanwhile
            raise OSError(str(exc)) from None
        return data or None

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self.port.close()


class LineSplitter:
    """Bytes to lines (LF, CR LF or CR ends a line), a partial line kept until its end."""

    def __init__(self) -> None:
        self._partial = b""
        self._cr = False

    def feed(self, data: bytes, *, end_of_message: bool = False) -> list[str]:
        """The complete lines in ``data`` (with what was kept before); ``end_of_message``
        (a UDP datagram) ends the last line too."""
        out: list[str] = []
        text = self._partial + data
        if self._cr and text.startswith(b"\n"):
            text = text[1:]  # the LF of a CR LF split across two reads
        self._cr = text.endswith(b"\r")
        pieces = text.replace(b"\r\n", b"\n").replace(b"\r", b"\n").split(b"\n")
        self._partial = pieces.pop()
        if end_of_message and self._partial:
            pieces.append(self._partial)
            self._partial = b""
        if len(self._partial) > MAX_LINE_BYTES:
            pieces.append(self._partial[:MAX_LINE_BYTES])
            self._partial = b""
        for piece in pieces:
            if piece:
                out.append(piece[:MAX_LINE_BYTES].decode("latin-1"))
        return out


Item = ReceivedLine | SourceState
"""What :meth:`LiveSource.poll` returns: lines and state changes in arrival order."""


class LiveSource:
    """One live source read by a background thread (module docstring).

    ``lost_after_s``: silence [s] after which a source that was receiving is ``lost``;
    ``reconnect_after_s``: silence [s] after which a TCP connection is dropped and re-opened
    (a half-open connection never reports its loss); ``backoff_s``: first and longest wait [s]
    between attempts to (re)open, doubling in between. ``clock`` is the monotonic clock (a
    test may pass its own).
    """

    def __init__(
        self,
        spec: SourceSpec | str,
        *,
        lost_after_s: float = 5.0,
        reconnect_after_s: float = 15.0,
        backoff_s: tuple[float, float] = (0.5, 8.0),
        connect_timeout_s: float = 3.0,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.spec = parse_source_url(spec) if isinstance(spec, str) else spec
        self.lost_after_s = lost_after_s
        self.reconnect_after_s = reconnect_after_s
        self.backoff_s = backoff_s
        self.connect_timeout_s = connect_timeout_s
        self._clock = clock
        self._queue: queue.Queue[Item] = queue.Queue()
        self._queued_lines = 0
        self._count_lock = threading.Lock()
        self._stop = threading.Event()
        self._transport: Transport | None = None
        self._transport_lock = threading.Lock()
        self._state = SourceState(STATUS_CONNECTING, clock())
        self._lines = 0
        self._thread: threading.Thread | None = None

    # ------------------------------------------------------------------ consumer side
    @property
    def url(self) -> str:
        """The source's URL as given."""
        return self.spec.url

    @property
    def state(self) -> SourceState:
        """The current state, with the lines received so far (a snapshot)."""
        state = self._state
        return state if state.lines == self._lines else replace(state, lines=self._lines)

    @property
    def local_port(self) -> int | None:
        """The UDP port bound (useful with port 0 in a :class:`SourceSpec`: any free port);
        None for other sources or before :meth:`start`."""
        transport = self._transport
        if isinstance(transport, _UdpTransport):
            return int(transport.sock.getsockname()[1])
        return None

    @property
    def running(self) -> bool:
        """True while the reader thread is alive."""
        return self._thread is not None and self._thread.is_alive()

    def start(self) -> LiveSource:
        """Start the reader thread (once); returns self. For UDP the port is bound here, so a
        port in use is an :class:`OSError` at once rather than a state later."""
        if self._thread is not None:
            return self
        if self.spec.kind == "udp":
            self._set_transport(self._open())
            self._set_state(STATUS_CONNECTING, detail="listening, waiting for data",
                            connected=True)
        self._thread = threading.Thread(target=self._run, name=f"uvnav-live {self.spec.url}",
                                        daemon=True)
        self._thread.start()
        return self

    def poll(self, timeout_s: float) -> list[Item]:
        """Everything received since the last poll, waiting up to ``timeout_s`` seconds for the
        first item (an empty list if nothing came)."""
        items: list[Item] = []
        try:
            items.append(self._queue.get(timeout=max(0.0, timeout_s)) if timeout_s > 0
                         else self._queue.get_nowait())
            while True:
                items.append(self._queue.get_nowait())
        except queue.Empty:
            pass
        n = sum(isinstance(i, ReceivedLine) for i in items)
        if n:
            with self._count_lock:
                self._queued_lines -= n
        return items

    def close(self, timeout_s: float = 5.0) -> bool:
        """Stop the reader, close the socket or device and join the thread; True if the thread
        ended within ``timeout_s``. Idempotent."""
        self._stop.set()
        self._set_transport(None)
        joined = True
        if self._thread is not None:
            self._thread.join(timeout_s)
            joined = not self._thread.is_alive()
        self._set_transport(None)  # one the thread opened while closing
        if self._state.status != STATUS_CLOSED:
            self._state = replace(self._state, status=STATUS_CLOSED, since_mono_s=self._clock(),
                                  detail="")
        return joined

    def __enter__(self) -> LiveSource:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ reader thread
    def _open(self) -> Transport:
        if self.spec.kind == "udp":
            return _UdpTransport(self.spec)
        if self.spec.kind in ("tcp", "gpsd"):
            return _TcpTransport(self.spec, self.connect_timeout_s)
        return _SerialTransport(self.spec)

    def _set_transport(self, transport: Transport | None) -> None:
        with self._transport_lock:
            old, self._transport = self._transport, transport
            if transport is not None and self._stop.is_set():
                self._transport = None
                old, transport = transport, None
        if old is not None:
            old.close()

    def _set_state(self, status: str, *, since: float | None = None, detail: str = "",
                   connected: bool = False) -> None:
        old = self._state
        new = SourceState(status, old.since_mono_s if since is None else since, detail,
                          self._lines, old.connects + int(connected), old.dropped)
        if new != old:
            self._state = new
            self._queue.put(new)

    def _run(self) -> None:
        try:
            self._loop()
        finally:
            self._set_transport(None)

    def _loop(self) -> None:
        backoff = self.backoff_s[0]
        while not self._stop.is_set():
            transport = self._transport
            if transport is not None:
                if not self._read_until_lost(transport):
                    return
                self._set_transport(None)
                if self.spec.kind == "udp":  # a bound socket is never lost: it failed; wait
                    self._stop.wait(backoff)
                    backoff = min(backoff * 2.0, self.backoff_s[1])
                continue
            again = self._state.connects > 0
            try:
                self._set_transport(self._open())
            except OSError as exc:
                reason = exc.strerror or str(exc)
                self._set_state(STATUS_RECONNECTING if again else STATUS_CONNECTING,
                                detail=reason)
                self._stop.wait(backoff)
                backoff = min(backoff * 2.0, self.backoff_s[1])
                continue
            backoff = self.backoff_s[0]
            self._set_state(STATUS_RECONNECTING if again else STATUS_CONNECTING,
                            detail="connected, waiting for data", connected=True)

    def _read_until_lost(self, transport: Transport) -> bool:
        """Read until the connection is lost (True: re-open) or the source is closed (False)."""
        splitter = LineSplitter()
        last_mono = self._clock()
        datagram = self.spec.kind == "udp"
        while not self._stop.is_set():
            try:
                data = transport.read()
            except OSError as exc:
                if self._stop.is_set():
                    return False
                # Lost since now, or still since the first loss when no line came in between
                # (a reconnection that broke again at once).
                since = self._state.since_mono_s if self._state.is_lost else self._clock()
                self._set_state(STATUS_LOST, since=since,
                                detail=exc.strerror or str(exc) or type(exc).__name__)
                return True
            now = self._clock()
            if data is None:
                silent_s = now - last_mono
                if self._state.status == STATUS_RECEIVING and silent_s >= self.lost_after_s:
                    self._set_state(STATUS_LOST, since=last_mono,
                                    detail=f"no data for {self.lost_after_s:g} s")
                if self.spec.kind != "udp" and silent_s >= self.reconnect_after_s:
                    if not self._state.is_lost:
                        self._set_state(STATUS_LOST, since=last_mono,
                                        detail=f"no data for {self.reconnect_after_s:g} s")
                    return True
                continue
            utc = time.time()
            last_mono = now
            lines = splitter.feed(data, end_of_message=datagram)
            if lines and self._state.status != STATUS_RECEIVING:
                self._set_state(STATUS_RECEIVING, since=now)
            for text in lines:
                self._lines += 1
                self._put_line(ReceivedLine(text, now, utc, self._lines))
        return False

    def _put_line(self, line: ReceivedLine) -> None:
        with self._count_lock:
            if self._queued_lines >= QUEUE_LINES:
                self._state = replace(self._state, dropped=self._state.dropped + 1)
                return
            self._queued_lines += 1
        self._queue.put(line)


__all__ = [
    "DEFAULT_BAUD",
    "LineSplitter",
    "LiveSource",
    "ReceivedLine",
    "SourceSpec",
    "SourceState",
    "is_source_url",
    "parse_source_url",
]

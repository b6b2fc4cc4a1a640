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
byte) so the parser can report binary noise; a line longer than :data:`MAX_LINE_BYTES` is one
*over-long* line: its first :data:`MAX_LINE_BYTES` bytes are passed on (the parser rejects them
as too long) and the rest up to its line end is not kept (counted in bytes).

**Overload.** The lines waiting for the consumer are bounded in bytes (:data:`QUEUE_BYTES`,
each line counted as its length plus :data:`LINE_ITEM_BYTES`); while that is full, newly
received lines are dropped, counted (:attr:`SourceState.dropped`) and the count handed on with
the next line that is kept (:attr:`ReceivedLine.dropped_before`), so the consumer knows where
the gap is. On Linux a UDP source also counts the datagrams the system dropped because the
socket's receive buffer was full (``SO_RXQ_OVFL``, :attr:`SourceState.sys_dropped`).

**Liveness** counts complete lines, not bytes: a source that sends bytes without a line end is
lost after ``lost_after_s`` as a silent one is. After a lost connection (and after a failed
open) the next attempt waits the back-off, which only returns to its shortest after a
connection has given a complete line, so a server that accepts and closes at once is retried
every 0.5, 1, 2, 4, 8, 8 … s.
"""

from __future__ import annotations

import contextlib
import socket
import struct
import sys
import threading
import time
from collections import deque
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
"""A longer line is one over-long line cut at this length (an NMEA sentence is at most 82
characters)."""
READ_SLICE_S = 0.1
"""Longest blocking read [s]: how soon the reader notices :meth:`LiveSource.close` or silence."""
QUEUE_BYTES = 4 * 1024 * 1024
"""Most bytes of lines waiting for the consumer (module docstring "Overload"): about 14,000
NMEA sentences, several seconds of a flood the consumer cannot keep up with."""
POLL_LINES = 2000
"""Most lines one :meth:`LiveSource.poll` hands over, so a consumer behind a flood still gets
back to its own checks (a run's end, the console's keys) every few hundredths of a second."""
SO_RXQ_OVFL = getattr(socket, "SO_RXQ_OVFL", 40 if sys.platform.startswith("linux") else None)
"""Linux socket(7) option: each datagram received carries the count of datagrams the socket
has dropped so far (receive buffer full)."""

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


@dataclass(frozen=True, slots=True)
class ReceivedLine:
    """One received line: its characters without the line ending, when it was received
    (``mono_s``: :func:`time.monotonic` seconds; ``utc_s``: POSIX seconds, UTC) and its
    1-based number in the stream (lines dropped under overload included). ``dropped_before``:
    lines dropped (the waiting lines' bytes full) between the previous line handed over and
    this one; ``sys_dropped_before``: datagrams the system dropped in that time (UDP, Linux);
    ``overlong``: the line was longer than :data:`MAX_LINE_BYTES` and is cut there."""

    text: str
    mono_s: float
    utc_s: float
    number: int
    dropped_before: int = 0
    sys_dropped_before: int = 0
    overlong: bool = False


LINE_ITEM_BYTES = (sys.getsizeof(ReceivedLine("", 0.0, 0.0, 1 << 40)) + sys.getsizeof("")
                   + 2 * sys.getsizeof(0.0) + sys.getsizeof(1 << 40) + 8)
"""Bytes a waiting line takes beyond its characters (the item, its empty string, two floats,
its number and a slot of the queue; CPython's sizes, measured at import)."""


@dataclass(frozen=True)
class SourceState:
    """The state of a source (module docstring). ``since_mono_s`` is when it began
    (monotonic seconds; for ``lost``/``reconnecting`` the moment the source was lost),
    ``detail`` says why (the system's error, ``no data for 5 s``), ``lines`` counts the lines
    received so far, ``connects`` the successful opens, ``dropped`` the lines dropped because
    the consumer fell :data:`QUEUE_BYTES` behind, ``sys_dropped`` the datagrams the system
    dropped (UDP on Linux), ``overlong`` the over-long lines and ``cut_bytes`` their bytes not
    kept, ``clock`` what the consumer says of the stream's clock (empty: nothing wrong; set by
    a live run, engine/run/live.py)."""

    status: str
    since_mono_s: float
    detail: str = ""
    lines: int = 0
    connects: int = 0
    dropped: int = 0
    sys_dropped: int = 0
    overlong: int = 0
    cut_bytes: int = 0
    clock: str = ""

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
            return f"SOURCE LOST {lost_s:.0f} s{why}{again}{self.trouble()}"
        if self.status == STATUS_CONNECTING and self.detail:
            return f"connecting ({self.detail}){self.trouble()}"
        return f"{self.status}{self.trouble()}"

    @property
    def drops(self) -> int:
        """Lines dropped by the reader plus datagrams dropped by the system."""
        return self.dropped + self.sys_dropped

    def trouble(self) -> str:
        """``, 1234 DROPPED, CLOCK …`` when anything was dropped or the stream's clock is in
        doubt (the state line and the cycle lines show it); "" otherwise."""
        out = f", {self.drops} DROPPED" if self.drops else ""
        if self.clock:
            out += f", {self.clock}"
        return out


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
        self.sys_dropped = 0
        """Datagrams the system dropped so far (receive buffer full; Linux only, else 0)."""
        self._anc = 0
        if SO_RXQ_OVFL is not None:
            try:
                sock.setsockopt(socket.SOL_SOCKET, SO_RXQ_OVFL, 1)
                self._anc = socket.CMSG_SPACE(4)
            except OSError:
                self._anc = 0

    def read(self) -> bytes | None:
        try:
            if not self._anc:
                data, _addr = self.sock.recvfrom(65535)
                return data
            data, anc, _flags, _addr = self.sock.recvmsg(65535, self._anc)
        except TimeoutError:
            return None
        for level, kind, value in anc:
            if level == socket.SOL_SOCKET and kind == SO_RXQ_OVFL and len(value) >= 4:
                self.sys_dropped = struct.unpack("=I", value[:4])[0]
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
    """Bytes to lines (LF, CR LF or CR ends a line), a partial line kept until its end.

    A line longer than :data:`MAX_LINE_BYTES` is handed on once, cut there, as soon as it is
    that long; the rest of it, up to its line end, is skipped (:attr:`cut_bytes` counts the
    bytes not kept), so a 50 MB line is one over-long line, not thousands of fragments.
    :attr:`overlong` counts them.
    """

    def __init__(self) -> None:
        self._partial = b""
        self._cr = False
        self._skipping = False
        self.overlong = 0
        self.cut_bytes = 0
        self.flags: list[bool] = []
        """Per line of the last :meth:`feed`: True for an over-long one."""

    def feed(self, data: bytes, *, end_of_message: bool = False) -> list[str]:
        """The complete lines in ``data`` (with what was kept before); ``end_of_message``
        (a UDP datagram) ends the last line too. :attr:`flags` marks the over-long ones."""
        out: list[str] = []
        flags: list[bool] = []
        self.flags = flags
        if self._cr and data.startswith(b"\n"):
            data = data[1:]  # the LF of a CR LF split across two reads
        if data:
            self._cr = data.endswith(b"\r")
        if self._skipping:  # the rest of an over-long line, up to its line end
            end = _line_end(data)
            if end < 0:
                self.cut_bytes += len(data)
                if end_of_message:
                    self._skipping = False
                return out
            self.cut_bytes += end
            self._skipping = False
            data = data[end:]
        text = self._partial + data
        pieces = text.replace(b"\r\n", b"\n").replace(b"\r", b"\n").split(b"\n")
        self._partial = pieces.pop()
        if end_of_message and self._partial:
            pieces.append(self._partial)
            self._partial = b""
        if len(self._partial) > MAX_LINE_BYTES:  # over-long already: handed on now, the rest
            pieces.append(self._partial)  # of it skipped up to its line end
            self._partial = b""
            self._skipping = True
        for piece in pieces:
            if piece:
                long = len(piece) > MAX_LINE_BYTES
                if long:
                    self.overlong += 1
                    self.cut_bytes += len(piece) - MAX_LINE_BYTES
                out.append(piece[:MAX_LINE_BYTES].decode("latin-1"))
                flags.append(long)
        return out


def _line_end(data: bytes) -> int:
    """Index of the first CR or LF in ``data`` (-1: none)."""
    ends = [i for i in (data.find(b"\n"), data.find(b"\r")) if i >= 0]
    return min(ends) if ends else -1


Item = ReceivedLine | SourceState
"""What :meth:`LiveSource.poll` returns: lines and state changes in arrival order."""


class LiveSource:
    """One live source read by a background thread (module docstring).

    ``lost_after_s``: time [s] without a complete line after which a source that was receiving
    is ``lost``; ``reconnect_after_s``: time [s] without a complete line after which a TCP
    connection is dropped and re-opened (a half-open connection never reports its loss, a
    trickling one never ends); ``backoff_s``: first and longest wait [s] between attempts to
    (re)open, doubling in between (module docstring); ``queue_bytes``: the bound of the
    waiting lines (:data:`QUEUE_BYTES`). ``clock`` is the monotonic clock (a test may pass its
    own).
    """

    def __init__(
        self,
        spec: SourceSpec | str,
        *,
        lost_after_s: float = 5.0,
        reconnect_after_s: float = 15.0,
        backoff_s: tuple[float, float] = (0.5, 8.0),
        connect_timeout_s: float = 3.0,
        queue_bytes: int = QUEUE_BYTES,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.spec = parse_source_url(spec) if isinstance(spec, str) else spec
        self.lost_after_s = lost_after_s
        self.reconnect_after_s = reconnect_after_s
        self.backoff_s = backoff_s
        self.connect_timeout_s = connect_timeout_s
        self.queue_bytes = queue_bytes
        self._clock = clock
        self._items: deque[Item] = deque()
        self._queued_bytes = 0
        self._ready = threading.Condition(threading.Lock())
        self._stop = threading.Event()
        self._transport: Transport | None = None
        self._transport_lock = threading.Lock()
        self._state = SourceState(STATUS_CONNECTING, clock())
        self._lines = 0
        self._dropped = 0
        self._pending_drop = 0
        self._sys_dropped = 0
        self._pending_sys = 0
        self._overlong = 0
        self._cut_bytes = 0
        self.peak_queued_bytes = 0
        """The most bytes that waited at once (bench/bench_live.py reports it)."""
        self._thread: threading.Thread | None = None

    # ------------------------------------------------------------------ consumer side
    @property
    def url(self) -> str:
        """The source's URL as given."""
        return self.spec.url

    @property
    def state(self) -> SourceState:
        """The current state with the counts so far (a snapshot)."""
        state = self._state
        return replace(state, lines=self._lines, dropped=self._dropped,
                       sys_dropped=self._sys_dropped, overlong=self._overlong,
                       cut_bytes=self._cut_bytes)

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

    def poll(self, timeout_s: float, max_lines: int = POLL_LINES) -> list[Item]:
        """What was received since the last poll, in order, at most ``max_lines`` lines (the
        rest waits for the next poll), waiting up to ``timeout_s`` seconds for the first item
        (an empty list if nothing came)."""
        items: list[Item] = []
        with self._ready:
            if not self._items and timeout_s > 0:
                self._ready.wait(timeout_s)
            n = 0
            freed = 0
            while self._items and n < max_lines:
                item = self._items.popleft()
                items.append(item)
                if isinstance(item, ReceivedLine):
                    n += 1
                    freed += len(item.text) + LINE_ITEM_BYTES
            self._queued_bytes -= freed
        return items

    @property
    def queued_bytes(self) -> int:
        """Bytes of the lines waiting now (bounded by ``queue_bytes``)."""
        return self._queued_bytes

    def close(self, timeout_s: float = 5.0) -> bool:
        """Stop the reader, close the socket or device and join the thread; True if the thread
        ended within ``timeout_s``. Idempotent. What was received and not yet polled stays
        for :meth:`poll`."""
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

    @property
    def trailing_drops(self) -> tuple[int, int]:
        """Lines and datagrams dropped after the last line handed over (not yet reported with
        a line: at the end of a run)."""
        return self._pending_drop, self._pending_sys

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
                          self._lines, old.connects + int(connected), self._dropped,
                          self._sys_dropped, self._overlong, self._cut_bytes)
        if (new.status, new.since_mono_s, new.detail, new.connects) != (
                old.status, old.since_mono_s, old.detail, old.connects):
            self._state = new
            with self._ready:  # a state is never dropped (a few per back-off at most)
                self._items.append(new)
                self._ready.notify()

    def _run(self) -> None:
        try:
            self._loop()
        finally:
            self._set_transport(None)

    def _loop(self) -> None:
        backoff = self.backoff_s[0]
        while not self._stop.is_set():
            transport = self._transport
            if transport is None:
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
                self._set_state(STATUS_RECONNECTING if again else STATUS_CONNECTING,
                                detail="connected, waiting for data", connected=True)
                continue
            outcome = self._read_until_lost(transport)
            if outcome is None:
                return
            self._set_transport(None)
            if outcome:  # this connection gave lines: the next attempt waits the least
                backoff = self.backoff_s[0]
            # Wait before re-opening after a loss too: a server that accepts and closes at
            # once (or a device that fails at once) is not hammered.
            self._stop.wait(backoff)
            backoff = min(backoff * 2.0, self.backoff_s[1])

    def _read_until_lost(self, transport: Transport) -> bool | None:
        """Read until the connection is lost (True: it gave complete lines; False: none) or
        the source is closed (None)."""
        splitter = LineSplitter()
        start = self._clock()
        last_line = start  # the last complete line (liveness counts lines, not bytes)
        last_data = start
        got_lines = False
        cut_seen = 0
        sys_seen = 0
        datagram = self.spec.kind == "udp"
        udp = transport if isinstance(transport, _UdpTransport) else None
        while not self._stop.is_set():
            try:
                data = transport.read()
            except OSError as exc:
                if self._stop.is_set():
                    return None
                # Lost since now, or still since the first loss when no line came in between
                # (a reconnection that broke again at once).
                since = self._state.since_mono_s if self._state.is_lost else self._clock()
                self._set_state(STATUS_LOST, since=since,
                                detail=exc.strerror or str(exc) or type(exc).__name__)
                return got_lines
            now = self._clock()
            if data is not None:
                last_data = now
                if udp is not None and udp.sys_dropped > sys_seen:  # counted per socket
                    self._pending_sys += udp.sys_dropped - sys_seen
                    self._sys_dropped += udp.sys_dropped - sys_seen
                    sys_seen = udp.sys_dropped
                lines = splitter.feed(data, end_of_message=datagram)
                self._cut_bytes += splitter.cut_bytes - cut_seen
                cut_seen = splitter.cut_bytes
                if lines:
                    if not all(splitter.flags):
                        last_line = now
                        got_lines = True
                        if self._state.status != STATUS_RECEIVING:
                            self._set_state(STATUS_RECEIVING, since=now)
                    self._take(lines, splitter, now)
            silent_s = now - last_line
            if silent_s < self.lost_after_s:
                continue
            what = ("no complete line" if now - last_data < self.lost_after_s
                    else "no data")
            if self._state.status == STATUS_RECEIVING:
                self._set_state(STATUS_LOST, since=last_line,
                                detail=f"{what} for {self.lost_after_s:g} s")
            if not datagram and silent_s >= self.reconnect_after_s:
                if not self._state.is_lost:
                    self._set_state(STATUS_LOST, since=last_line,
                                    detail=f"{what} for {self.reconnect_after_s:g} s")
                return got_lines
        return None

    def _take(self, lines: list[str], splitter: LineSplitter, now: float) -> None:
        """Queue the lines of one read (those that do not fit the bound are dropped,
        counted)."""
        utc = time.time()
        flags = splitter.flags
        self._overlong += sum(flags)
        limit = self.queue_bytes
        with self._ready:
            for text, long in zip(lines, flags, strict=True):
                self._lines += 1
                size = len(text) + LINE_ITEM_BYTES
                if self._queued_bytes + size > limit:
                    self._dropped += 1
                    self._pending_drop += 1
                    continue
                self._queued_bytes += size
                self._items.append(ReceivedLine(text, now, utc, self._lines, self._pending_drop,
                                                self._pending_sys, long))
                self._pending_drop = self._pending_sys = 0
            self.peak_queued_bytes = max(self.peak_queued_bytes, self._queued_bytes)
            self._ready.notify()


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

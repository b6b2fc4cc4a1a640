"""The raw log of a live source and the feed to the epoch builder, over a real UDP socket.

The builder here is a stand-in with the epoch builder's interface (``feed(line, line_no)``): it
returns one record per GGA, so the test checks what the feed does (numbering, raw log, receive
times), not how epochs are formed (tests/io/test_nmea_epochs.py). The raw log is read back
independently: the bytes with ``open(..., 'rb')``, the receive times with pandas.
"""

from __future__ import annotations

import socket
import threading
import time
from datetime import UTC, datetime
from pathlib import Path

import pandas as pd
import pytest

from engine.errors import InputError
from engine.io.live_feed import LiveFeed
from engine.io.live_log import RAW_SUFFIX, TIMES_SUFFIX, RawLog, raw_log_stem
from engine.io.live_sources import LiveSource, ReceivedLine, SourceSpec, SourceState
from engine.io.runfile import BadRecord, RunRecord

DEADLINE_S = 20.0
GGA = "$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47"
HDT = "$HEHDT,274.07,T*03"


class GgaCounter:
    """Stand-in epoch builder: one record per GGA line, a BadRecord for a line with a byte
    outside printable ASCII."""

    def __init__(self) -> None:
        self.fed: list[tuple[str, int]] = []

    def feed(self, line: str, line_no: int) -> list[RunRecord | BadRecord]:
        self.fed.append((line, line_no))
        if any(not " " <= c <= "~" for c in line):
            return [BadRecord(line_no, line, InputError("noise", line=line_no))]
        if line.startswith("$GPGGA"):
            return [RunRecord(line_no, datetime(2026, 12, 2, tzinfo=UTC), 48.1, 11.5,
                              (None, None, None), None, None, None)]
        return []

    def finish(self) -> list[RunRecord | BadRecord]:
        return []


def test_raw_log_stem_and_names(tmp_path: Path) -> None:
    assert raw_log_stem(tmp_path / "RUN1.OUT") == tmp_path / "RUN1"
    assert raw_log_stem(tmp_path / "a.b.OUT") == tmp_path / "a.b"
    log = RawLog.create(tmp_path / "RUN1", source_url="udp://x:1", origin_mono_s=0.0)
    log.close()
    assert log.path == tmp_path / ("RUN1" + RAW_SUFFIX)
    assert log.times_path == tmp_path / ("RUN1" + TIMES_SUFFIX)


def test_raw_log_is_never_overwritten(tmp_path: Path) -> None:
    keep = tmp_path / "RUN1.raw.nmea"
    keep.write_bytes(b"precious\r\n")
    (tmp_path / "RUN1_1.raw.times.csv").write_text("also kept\n")  # either file takes a stem
    log = RawLog.create(tmp_path / "RUN1", source_url="udp://x:1", origin_mono_s=0.0)
    log.close()
    assert log.path == tmp_path / "RUN1_2.raw.nmea"
    assert log.times_path == tmp_path / "RUN1_2.raw.times.csv"
    assert keep.read_bytes() == b"precious\r\n"
    assert (tmp_path / "RUN1_1.raw.times.csv").read_text() == "also kept\n"


def test_raw_log_refuses_a_missing_directory(tmp_path: Path) -> None:
    with pytest.raises(InputError) as info:
        RawLog.create(tmp_path / "nope" / "RUN1", source_url="udp://x:1", origin_mono_s=0.0)
    assert info.value.field == "raw log"


def test_feed_writes_every_line_and_numbers_them_as_the_raw_log(tmp_path: Path) -> None:
    spec = SourceSpec(url="udp://127.0.0.1:0", kind="udp", host="127.0.0.1", port=0)
    # What is sent: sentences, a line of binary noise, a line ending in LF only.
    datagrams = [f"{GGA}\r\n{HDT}\r\n".encode(), b"\x00\xff$GPXXX\r\n", f"{HDT}\n".encode(),
                 f"{GGA}\r\n".encode()]
    expected = [GGA, HDT, "\x00\xff$GPXXX", HDT, GGA]
    source = LiveSource(spec).start()
    origin = time.monotonic()
    raw = RawLog.create(tmp_path / "LIVE", source_url=spec.url, origin_mono_s=origin)
    builder = GgaCounter()
    feed = LiveFeed(source, builder, raw)
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as out:
            for d in datagrams:
                out.sendto(d, ("127.0.0.1", source.local_port))
        records = []
        states: list[SourceState] = []
        deadline = time.monotonic() + DEADLINE_S
        while feed.lines < len(expected):
            assert time.monotonic() < deadline, f"only {feed.lines} lines"
            batch = feed.poll(0.1)
            records += batch.records
            states += batch.states
    finally:
        feed.close()
    assert not source.running
    assert [line for line, _ in builder.fed] == expected
    assert [n for _, n in builder.fed] == [1, 2, 3, 4, 5]
    # Records: two GGA (lines 1 and 5), one bad line (3), each with its line's receive time.
    assert [(type(r.item).__name__, r.item.line_no) for r in records] == [
        ("RunRecord", 1), ("BadRecord", 3), ("RunRecord", 5)]
    assert all(r.received_mono_s >= origin for r in records)
    # The raw log holds the lines byte for byte, each ended by CR LF: an NMEA log.
    assert raw.path.read_bytes() == b"".join(x.encode("latin-1") + b"\r\n" for x in expected)
    # The receive times, read back by pandas (comment lines: the source's states).
    times = pd.read_csv(raw.times_path, comment="#")
    assert list(times.columns) == ["line", "lines", "utc", "mono_s"]
    # A row per 0.1 s at most: the rows cover lines 1..5, each once, in order.
    firsts, counts = times["line"].tolist(), times["lines"].tolist()
    assert firsts[0] == 1 and sum(counts) == 5
    assert all(firsts[i + 1] == firsts[i] + counts[i] for i in range(len(firsts) - 1))
    assert (times["mono_s"].diff().dropna() >= 0).all()
    utc = pd.to_datetime(times["utc"], utc=True)
    assert abs((utc.iloc[-1] - pd.Timestamp.now(tz="UTC")).total_seconds()) < DEADLINE_S
    text = raw.times_path.read_text().splitlines()
    assert text[0].startswith("# UVNAV live receive times: source udp://127.0.0.1:0")
    assert any(t.startswith("# state ") and t.endswith(" receiving") for t in text)
    assert feed.received_mono_s(5) == records[-1].received_mono_s
    assert feed.received_mono_s(99) is None


def test_received_line_numbers_without_a_raw_log() -> None:
    """Without a raw log the source's own numbering is used."""
    spec = SourceSpec(url="udp://127.0.0.1:0", kind="udp", host="127.0.0.1", port=0)
    source = LiveSource(spec).start()
    builder = GgaCounter()
    feed = LiveFeed(source, builder)
    try:
        def send() -> None:
            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as out:
                out.sendto(f"{HDT}\r\n{GGA}\r\n".encode(), ("127.0.0.1", source.local_port))

        threading.Thread(target=send).start()
        deadline = time.monotonic() + DEADLINE_S
        got = []
        while len(got) < 1:
            assert time.monotonic() < deadline
            got += feed.poll(0.1).records
    finally:
        feed.close()
    assert got[0].item.line_no == 2


def test_gpsd_is_asked_for_nmea_and_its_json_kept_out_of_the_epochs(tmp_path: Path) -> None:
    """A stand-in gpsd on localhost: it must receive the ?WATCH command of gpsd(8) ("nmea":
    true) before it sends anything; its JSON replies go to the raw log, not to the builder."""
    listener = socket.create_server(("127.0.0.1", 0))
    port = listener.getsockname()[1]
    got: list[bytes] = []
    version = '{"class":"VERSION","release":"3.25","proto_major":3,"proto_minor":15}'

    def gpsd() -> None:
        listener.settimeout(DEADLINE_S)
        client, _ = listener.accept()
        with client:
            client.settimeout(DEADLINE_S)
            data = b""
            while not data.endswith(b"\n"):
                data += client.recv(100)
            got.append(data)
            client.sendall(f"{version}\r\n{GGA}\r\n{HDT}\r\n".encode())
            client.recv(1)  # until the client closes

    server = threading.Thread(target=gpsd)
    server.start()
    source = LiveSource(f"gpsd://127.0.0.1:{port}").start()
    raw = RawLog.create(tmp_path / "G", source_url=source.url, origin_mono_s=time.monotonic())
    builder = GgaCounter()
    feed = LiveFeed(source, builder, raw)
    try:
        deadline = time.monotonic() + DEADLINE_S
        while feed.lines < 3:
            assert time.monotonic() < deadline
            feed.poll(0.1)
    finally:
        feed.close()
        server.join(DEADLINE_S)
        listener.close()
    assert got == [b'?WATCH={"enable":true,"nmea":true};\n']
    assert [line for line, _ in builder.fed] == [GGA, HDT]
    assert [n for _, n in builder.fed] == [2, 3]  # numbered as in the raw log
    assert raw.path.read_bytes() == f"{version}\r\n{GGA}\r\n{HDT}\r\n".encode()


def test_times_are_compact_and_parts_rotate_by_size(tmp_path: Path) -> None:
    """A row of receive times per 0.1 s at most (found: a row per line, the times file larger
    than the raw log), and the raw log goes on in a new part at part_bytes, line numbers
    counting on."""
    raw = RawLog.create(tmp_path / "R", source_url="udp://x:1", origin_mono_s=100.0,
                        part_bytes=20 * (len(GGA) + 2))
    n = 0
    for second in range(3):  # 3 s of 1000 lines each, received in 10 bursts a second
        for k in range(1000):
            n += 1
            mono = 100.0 + second + (k // 100) * 0.1 + (k % 100) * 1e-5
            raw.write_line(ReceivedLine(GGA, mono, 1.7e9 + mono, n))
    raw.close()
    parts = raw.paths
    assert len(parts) == 150 and parts[1] == tmp_path / "R.2.raw.nmea"  # 3000 / 20 lines
    assert all(p.stat().st_size == 20 * (len(GGA) + 2) for p in parts)
    rows = pd.concat([pd.read_csv(p.with_name(p.name.replace(".raw.nmea", TIMES_SUFFIX)),
                                  comment="#") for p in parts])
    # 30 bursts, cut at the 150 part boundaries (a boundary inside a burst cuts its row).
    assert raw.rows == len(rows) <= 30 + 150
    assert rows["lines"].sum() == 3000
    firsts, counts = rows["line"].tolist(), rows["lines"].tolist()
    assert firsts[0] == 1
    assert all(firsts[i + 1] == firsts[i] + counts[i] for i in range(len(firsts) - 1))
    head = (tmp_path / "R.2.raw.times.csv").read_text().splitlines()[0]
    assert "part 2 of R.raw.nmea, first line 21" in head
    total = sum(p.stat().st_size for p in parts)
    times_total = sum(p.with_name(p.name.replace(".raw.nmea", TIMES_SUFFIX)).stat().st_size
                      for p in parts)
    assert times_total < total  # was larger than the raw log


def test_flood_drops_are_noted_where_they_happened_and_nothing_waiting_is_lost(
        tmp_path: Path) -> None:
    """A feed whose source drops lines (a small byte bound, nobody polling during a burst):
    the times file says how many were dropped before which line; lines still waiting when
    the feed closes are written to the raw log (counted as not run)."""
    spec = SourceSpec(url="udp://127.0.0.1:0", kind="udp", host="127.0.0.1", port=0)
    source = LiveSource(spec, queue_bytes=16 * 1024).start()
    raw = RawLog.create(tmp_path / "F", source_url=spec.url, origin_mono_s=time.monotonic())
    builder = GgaCounter()
    feed = LiveFeed(source, builder, raw)
    sent = 400
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as out:
            for _ in range(sent):
                out.sendto(f"{HDT}\r\n".encode(), ("127.0.0.1", source.local_port))
            deadline = time.monotonic() + DEADLINE_S
            seen = -1
            # Until the reader has taken what came, and has dropped (what the test is about): a
            # reader thread starved for 0.3 s on a loaded machine must not pass for a drained
            # socket, nor the poll below make room before the bound was ever reached.
            while source.state.lines != seen or source.state.dropped == 0:
                assert time.monotonic() < deadline
                seen = source.state.lines
                time.sleep(0.3)
            feed.poll(0.0)  # one poll: some lines run, the rest still wait
            assert feed.lines > 0
            out.sendto(f"{GGA}\r\n".encode(), ("127.0.0.1", source.local_port))
            while source.state.lines + source.state.sys_dropped < sent + 1:
                assert time.monotonic() < deadline
                time.sleep(0.02)
    finally:
        feed.close()
    st = source.state
    assert st.dropped > 0
    written = raw.path.read_bytes().count(b"\r\n")
    assert written == feed.lines + feed.unrun == st.lines - st.dropped
    assert written + st.dropped + st.sys_dropped == sent + 1
    assert (feed.dropped, feed.sys_dropped) == (st.dropped, st.sys_dropped)
    notes = [t for t in raw.times_path.read_text().splitlines() if t.startswith("# dropped")]
    noted = [int(t.split()[4]) for t in notes]
    assert sum(noted) == st.dropped
    assert all(" lines (UVNAV: waiting lines full), " in t and " before line " in t
               for t in notes)
    times = pd.read_csv(raw.times_path, comment="#")
    assert times["lines"].sum() == written

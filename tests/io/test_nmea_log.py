"""NMEA log files: sniffing by content, bounded streaming, .RUN-or-NMEA (engine/io/nmea_log.py)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from engine.errors import InputError
from engine.io.nmea_log import MAX_LINE_CHARS, NmeaLog, is_nmea_file, open_records, scan_nmea_log
from engine.io.runfile import BadRecord, RunRecord
from tests.nmea_lines import nmea, voyage
from tests.paths import DATA


def test_sniffing_by_content_not_suffix(tmp_path: Path) -> None:
    log = tmp_path / "trip.RUN"  # an NMEA log with a misleading suffix
    log.write_text("\n\n" + "\n".join(voyage(3, damage=False)) + "\n")
    assert is_nmea_file(log)
    assert not is_nmea_file(DATA / "920917_1.RUN")
    assert not is_nmea_file(tmp_path / "missing.nmea")
    assert not is_nmea_file(tmp_path)  # a directory
    (tmp_path / "empty").write_text("")
    assert not is_nmea_file(tmp_path / "empty")
    one = tmp_path / "one.nmea"
    one.write_text(nmea("HEHDT,1.0,T") + "\r\n")
    assert is_nmea_file(one)
    mostly_text = tmp_path / "notes.txt"
    mostly_text.write_text("see the log:\n" + nmea("HEHDT,1.0,T") + "\nand more text\n")
    assert not is_nmea_file(mostly_text)


def test_open_records_picks_the_reader(tmp_path: Path) -> None:
    log = tmp_path / "v.txt"
    log.write_text("\n".join(voyage(5, damage=False)) + "\n")
    records = open_records(log)
    assert isinstance(records, NmeaLog)
    assert sum(isinstance(r, RunRecord) for r in records) == 5
    assert records.stats.epochs == 5
    run = open_records(DATA / "920917_1.RUN")
    assert not isinstance(run, NmeaLog) and isinstance(next(run), RunRecord)


def test_missing_and_non_regular_files_fail_before_reading(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="File not found"):
        NmeaLog(tmp_path / "missing.nmea")
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    with pytest.raises(InputError, match="Not a regular file"):
        NmeaLog(fifo)
    assert not is_nmea_file(fifo)  # never opened (it would block)


def test_long_line_and_binary_noise_are_bad_records_not_crashes(tmp_path: Path) -> None:
    log = tmp_path / "v.nmea"
    lines = voyage(3, damage=False)
    data = ("\n".join(lines[:4]) + "\n").encode() + b"$" + b"A" * (3 * MAX_LINE_CHARS) + \
        b"\n\x00\xff\xfe\x81garbage\n" + ("\n".join(lines[4:]) + "\n").encode()
    log.write_bytes(data)
    out = list(NmeaLog(log))
    bad = [r for r in out if isinstance(r, BadRecord)]
    assert [b.line_no for b in bad] == [5, 6]
    assert "Line too long" in str(bad[0].error) and str(bad[0].error).startswith(f"{log}:5:")
    assert bad[1].error.field == "binary noise/non-ASCII"
    assert sum(isinstance(r, RunRecord) for r in out) == 3


def test_scan_counts_the_whole_log(tmp_path: Path) -> None:
    log = tmp_path / "v.nmea"
    log.write_text("\n".join(voyage(40)) + "\n")
    stats = scan_nmea_log(log)
    # voyage(40): k % 17 == 5 → k = 5, 22, 39 bad checksums; k % 23 == 7 → k = 7 repeats a
    # whole HDT (16 characters, used), k = 30 cuts a VHW before its '*' ("no checksum");
    # k % 29 == 3 → 3, 32 AIS; k % 31 == 11 → 11 empty HDT
    assert stats.skipped["bad checksum"] == 3
    assert stats.skipped["no checksum"] == 1 and stats.used["HDT"] == 41
    assert stats.skipped["AIS/encapsulated (!)"] == 2
    assert stats.skipped["empty fields"] == 1
    assert stats.used["GGA"] == 40 and stats.used["DBT"] == 20
    assert stats.skipped_types == {"GSV": 40}
    assert stats.first_fix is not None and stats.first_fix[0] == pytest.approx(52.8333333,
                                                                               abs=1e-7)
    assert stats.missing_sensors() == []


def _records(log: NmeaLog) -> list[tuple[int, object]]:
    """(line, record text) of the good records: what a replay processes."""
    return [(r.line_no, r.raw) for r in log if isinstance(r, RunRecord)]


def test_first_line_over_64_kib_does_not_hide_a_valid_log(tmp_path: Path) -> None:
    """A 100 KiB junk first line (a logger's binary header) is one damaged line: the log is
    still recognised (it was not: the sniff read 64 KiB of that one line) and read."""
    log = tmp_path / "v.nmea"
    lines = voyage(5, damage=False)
    log.write_bytes(b"#" + b"x" * 100_000 + b"\n" + ("\n".join(lines) + "\n").encode())
    assert is_nmea_file(log)
    out = list(NmeaLog(log))
    bad = [r for r in out if isinstance(r, BadRecord)]
    assert [b.line_no for b in bad] == [1] and "Line too long" in str(bad[0].error)
    assert sum(isinstance(r, RunRecord) for r in out) == 5


@pytest.mark.parametrize("end", ["\r", "\r\n", "\n"])
def test_any_line_end_reads_the_same_records(tmp_path: Path, end: str) -> None:
    """CR alone (old Mac-style loggers) was read as one line: no record at all."""
    lines = voyage(6)
    ref = tmp_path / "lf.nmea"
    ref.write_text("\n".join(lines) + "\n")
    log = tmp_path / "v.nmea"
    log.write_bytes((end.join(lines) + end).encode())
    assert is_nmea_file(log)
    got = _records(NmeaLog(log))
    assert len(got) == 6 and got == _records(NmeaLog(ref))


def test_gzip_log_is_read_as_the_plain_one(tmp_path: Path) -> None:
    """A rotated log (``.nmea.gz``) gives the records of its plain text, line numbers too."""
    import gzip

    text = ("\r\n".join(voyage(8)) + "\r\n").encode()
    plain = tmp_path / "v.nmea"
    plain.write_bytes(text)
    packed = tmp_path / "v.nmea.gz"
    packed.write_bytes(gzip.compress(text))
    assert is_nmea_file(packed)
    assert isinstance(open_records(packed), NmeaLog)
    log = NmeaLog(packed)
    assert _records(log) == _records(NmeaLog(plain))
    assert log.stats.epochs == 8


def test_cut_gzip_log_keeps_what_came_before(tmp_path: Path) -> None:
    """A .gz cut short (a logger killed mid-write): the records before the cut are used and
    the cut is one bad record naming the file and line, never an exception."""
    import gzip

    text = ("\n".join(voyage(400, damage=False)) + "\n").encode()
    packed = gzip.compress(text)
    cut = tmp_path / "cut.nmea.gz"
    cut.write_bytes(packed[: len(packed) // 2])
    out = list(NmeaLog(cut))
    bad = [r for r in out if isinstance(r, BadRecord) and "gzip" in str(r.error)]
    assert len(bad) == 1 and str(bad[0].error).startswith(f"{cut}:")
    assert "the rest of the log cannot be read" in str(bad[0].error)
    good = sum(isinstance(r, RunRecord) for r in out)
    assert 50 < good < 400


@pytest.mark.parametrize(("data", "what"), [
    (b"", "an empty file"),
    ("\ufeff$GPGGA,1*00\n".encode("utf-16"), "UTF-16 text, byte-order mark FF FE"),
    (b"\n  \n\n", "a file of blank lines only"),
    (b"PK\x03\x04rest", "a ZIP archive"),
    (b"BZh91AY&SY", "bzip2-compressed"),
    (b"\x00\x01\x02\x03" * 40 + b"\n", "binary data with NUL bytes"),
    (bytes(range(128, 256)) + b"\n" + bytes(range(160, 250)) + b"\n", "binary data: 2 of"),
    (b"hello\nworld\n", "text: 0 of its first 2 non-empty lines are NMEA 0183 sentences"),
    (b"Date\tTime\n920917\t083538\n", "text: 0 of its first 2"),  # a .RUN's tabs are text
], ids=["empty", "utf16", "blank", "zip", "bzip2", "binary", "non-ascii", "text", "tabs"])
def test_a_file_that_is_no_log_is_named(tmp_path: Path, data: bytes, what: str) -> None:
    from engine.io.nmea_log import not_nmea_message, sniff_log

    path = tmp_path / "x.nmea"
    path.write_bytes(data)
    sniff = sniff_log(path)
    assert not sniff.nmea and what in sniff.what
    assert not_nmea_message(sniff).startswith("Not an NMEA 0183 log (")
    assert sniff.text == what.startswith("text")  # only plain text may be a .RUN


def test_gzip_of_something_else_is_named(tmp_path: Path) -> None:
    import gzip

    from engine.io.nmea_log import sniff_log

    path = tmp_path / "x.nmea.gz"
    path.write_bytes(gzip.compress(b"just a note\n"))
    s = sniff_log(path)
    assert (s.nmea, s.text, s.gzip) == (False, False, True)
    assert s.what.startswith("gzip-compressed text: 0 of its first 1")
    path.write_bytes(gzip.compress(b"")[:5])
    assert "gzip-compressed data that cannot be read" in sniff_log(path).what


def test_damaged_lines_beyond_the_listed_ones_are_counted(tmp_path: Path) -> None:
    """231 bad-checksum lines: 20 come back as BAD records, all 231 are counted (the replay's
    'skipped records' read 20)."""
    from engine.io.nmea_epochs import MAX_BAD_PER_KIND

    lines = voyage(5, damage=False)
    bad_line = nmea("HEHDT,12.0,T")[:-2] + "00"
    log = tmp_path / "v.nmea"
    log.write_text("\n".join(lines + [bad_line] * 231) + "\n")
    reader = NmeaLog(log)
    out = list(reader)
    assert sum(isinstance(r, BadRecord) for r in out) == MAX_BAD_PER_KIND
    assert reader.stats.skipped["bad checksum"] == 231
    assert reader.stats.bad_unlisted == 231 - MAX_BAD_PER_KIND
    assert any("211 more than the first 20" in ln for ln in reader.stats.summary_lines())


def test_unused_types_are_counted_in_bounded_memory(tmp_path: Path) -> None:
    """A log of random junk addresses (valid checksums) must not grow one counter per name."""
    from engine.io.nmea_epochs import MAX_TYPES_COUNTED, OTHER_TYPES

    names = [f"XX{a}{b}{c}" for a in "JKLMNOPQ" for b in "JKLMNOPQ" for c in "JKLM"]  # 256
    log = tmp_path / "v.nmea"
    log.write_text("\n".join(voyage(2, damage=False) + [nmea(f"{n},1") for n in names]) + "\n")
    stats = scan_nmea_log(log)
    assert len(stats.skipped_types) == MAX_TYPES_COUNTED + 1
    assert sum(stats.skipped_types.values()) == 256 + 2  # + the voyage's two GSV
    assert stats.skipped_types[OTHER_TYPES] == 256 + 1 - MAX_TYPES_COUNTED

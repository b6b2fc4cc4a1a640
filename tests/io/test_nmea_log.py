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

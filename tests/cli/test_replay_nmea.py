"""`uvnav replay LOG.nmea`: an NMEA 0183 log replays like a .RUN (docs/NMEA.md)."""

from __future__ import annotations

from pathlib import Path

import pytest

from engine.io.outlog import read_out_log
from tests.nmea_lines import ddmm, hhmmss, nmea
from tests.paths import DATA
from uvnav_tui.cli.main import main

LAT0 = 52.8333333333  # 52°50'N
LON0 = 4.5


def write_log(path: Path, n: int = 60, heading: bool = True) -> None:
    """n seconds of a vessel steaming north at 5 kn (5/60 ′ of latitude per minute)."""
    lines = []
    for k in range(n):
        t = 43200 + k
        lat = LAT0 + k * 5.0 / 3600.0 / 60.0
        lines.append(nmea(f"GPGGA,{hhmmss(t)},{ddmm(lat)},N,{ddmm(LON0, 3)},E,1,09,0.8,3.0,M,"
                          "46.0,M,,"))
        lines.append(nmea(f"GPRMC,{hhmmss(t)},A,{ddmm(lat)},N,{ddmm(LON0, 3)},E,5.0,0.0,"
                          "021226,,,A"))
        if heading:
            lines.append(nmea("HEHDT,0.0,T"))
        lines.append(nmea("VWVHW,,T,,M,5.0,N,,K"))
        lines.append(nmea("GPGSV,3,1,11,03,03,111,00"))
    path.write_text("\n".join(lines) + "\n")


def write_config(path: Path, run: str) -> None:
    path.write_text(
        f'datum = "WGS84"\ndr_position = "52 50 00 N 004 30 00 E"\nrun_file = "{run}"\n'
        f'run_gps_datum = "WGS84"\ndata_dir = "{DATA}"\n[gps]\non = true\n[decca]\non = false\n')


def test_replay_nmea_log_with_config(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "trip.log"  # not a .nmea suffix: the content decides
    write_log(log)
    write_config(tmp_path / "trip.toml", "trip.log")
    out = tmp_path / "trip.OUT"
    assert main(["replay", str(log), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "epochs 60  fixes 60" in text
    assert "nmea: NMEA 300 lines, 60 epochs; sentences used: GGA 60, HDT 60, RMC 60, VHW 60" \
        in text
    assert "nmea: unused sentence types: GSV 60" in text
    cycles = read_out_log(out).cycles
    assert len(cycles) == 60
    # the last GPS fix: 52°50' + 59 s × 5 kn = 52.8333333 + 59 × 5 / 216000 deg; the MPP is
    # a KF estimate within its σ of it (C/A 50 m → a few tens of metres)
    mpp = cycles[-1].first("MPP")
    assert mpp["lat"] == pytest.approx(LAT0 + 59 * 5.0 / 216000.0, abs=60.0 / 111_000.0)
    assert mpp["lon"] == pytest.approx(LON0, abs=60.0 / 67_000.0)


def test_replay_nmea_log_without_config_derives_one(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "yacht.nmea"
    write_log(log, n=20, heading=False)  # a yacht log: no heading, no depth
    assert main(["replay", str(log)]) == 0
    text = capsys.readouterr().out
    assert "derived from the NMEA log" in text
    assert "config: datum WGS84, GNSS datum WGS84, DR position 52 50 00.000 N 004 30 00.000 E" \
        in text
    assert ("config: GPS on (C/A), Decca off, filter on (honest preset, surface vessel)"
            in text)
    assert "config: sensors: gyro n/a, log on, echo sounder n/a" in text
    assert "nmea: no heading (HDT/HDG/VHW) in the log" in text
    assert "nmea: no depth (DBT/DPT) in the log" in text
    out = read_out_log(tmp_path / "yacht.OUT")
    assert len(out.cycles) == 20
    assert "nmea no heading (HDT/HDG/VHW) in the log" in out.header
    assert 'datum = "WGS84"' in out.config_text and 'gyro = "n/a"' in out.config_text


def test_explicit_config_wins_and_no_fix_is_reported(tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "nofix.nmea"
    log.write_text("\n".join([nmea("GPRMC,120000,V,,,,,,,021226,,,N"), nmea("HEHDT,10.0,T"),
                              nmea("GPRMC,120001,V,,,,,,,021226,,,N")]) + "\n")
    assert main(["replay", str(log)]) == 2
    assert "No valid position fix in the NMEA log" in capsys.readouterr().err
    write_config(tmp_path / "other.toml", "nofix.nmea")
    assert main(["replay", str(log), "--config", str(tmp_path / "other.toml"), "--no-out"]) == 3
    assert "derived" not in capsys.readouterr().out


def test_log_without_date_needs_date_option(tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    """GLL + ZDA without a date (as some instrument buses send): no date, so the derived
    configuration asks for --date; with it the log replays."""
    lines = []
    for k in range(5):
        t = 36000 + 2 * k  # every 2 s
        lines += [nmea(f"GPZDA,{hhmmss(t)},,,,00,"),
                  nmea(f"GPGLL,{ddmm(LAT0)},N,{ddmm(LON0, 3)},E,{hhmmss(t)},A,D"),
                  nmea("IIVHW,,T,,M,05.10,N,09.45,K")]
    log = tmp_path / "nodate.nmea"
    log.write_text("\n".join(lines) + "\n")
    assert main(["replay", str(log), "--no-out"]) == 2
    assert "No date in the NMEA log" in capsys.readouterr().err
    assert main(["replay", str(log), "--no-out", "--date", "2014-02-30"]) == 2
    assert "--date: Must be" in capsys.readouterr().err
    assert main(["replay", str(log), "--no-out", "--date", "2014-07-18"]) == 0
    text = capsys.readouterr().out
    # 10:00:00 to 10:00:08, sentences every 2 s: an epoch every second (the water speed is
    # fresh for 5 s), each of the 5 fixes in one epoch only
    assert "epochs 9  fixes 5" in text
    assert "final MPP (" in text and "10:00:08Z" in text
    assert "config: sensors: gyro n/a, log on, echo sounder n/a" in text


def test_skipped_count_covers_every_damaged_line(tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    """231 bad-checksum lines: 'skipped records 231' (it said 20, the BAD lines written)."""
    log = tmp_path / "trip.nmea"
    write_log(log, n=30)
    bad_line = nmea("HEHDT,12.0,T")[:-2] + "00"
    with open(log, "a") as fh:
        fh.write((bad_line + "\n") * 231)
    write_config(tmp_path / "trip.toml", "trip.nmea")
    out = tmp_path / "trip.OUT"
    assert main(["replay", str(log), "--out", str(out)]) == 0
    text = capsys.readouterr()
    assert "skipped records 231" in text.out
    assert "nmea: skipped: bad checksum 231" in text.out
    assert len(read_out_log(out).bad_records) == 20  # the first of the kind, one by one
    assert "all counted per kind in the nmea: lines" in text.err


@pytest.mark.parametrize(("data", "what"), [
    (b"", "an empty file"),
    ("$GPGGA,1*00\n".encode("utf-16"), "UTF-16 text"),
    (b"\x1f\x8b\x08\x00\x00\x00\x00\x00\x00\x03\xcbH\xcd\xc9\xc9\xe7\x02\x00 0:6\x06\x00\x00\x00",
     "gzip-compressed text: 0 of its first 1"),
], ids=["empty", "utf16", "gzip-text"])
def test_replay_names_a_file_that_is_no_log(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                            data: bytes, what: str) -> None:
    """Without a configuration, a file that is neither a log nor a .RUN is named for what it
    is, not met with a message about a missing NAME.toml."""
    run = tmp_path / "log.nmea"
    run.write_bytes(data)
    assert main(["replay", str(run), "--no-out"]) == 2
    err = capsys.readouterr().err
    assert f"{run}: Not an NMEA 0183 log ({what}" in err
    assert "log.toml" not in err
    assert main(["denied", str(run)]) == 2
    err = capsys.readouterr().err
    assert f"{run}: Not an NMEA 0183 log ({what}" in err and "log.toml" not in err

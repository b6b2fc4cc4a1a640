"""`uvnav convert LOG --out X.RUN`: the .RUN equivalent of an NMEA log (docs/NMEA.md)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from engine.io.outlog import read_out_log
from engine.io.runfile import RunRecord, iter_run_file
from tests.cli.test_replay_nmea import write_config
from tests.nmea_lines import voyage
from uvnav_tui.cli.main import main


def test_convert_writes_lossless_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "v.nmea"
    log.write_text("\n".join(voyage(30)) + "\n")
    out = tmp_path / "v.RUN"
    assert main(["convert", str(log), "--out", str(out)]) == 0
    text = capsys.readouterr()
    assert f"wrote 30 records to {out}" in text.out
    assert "skipped: " in text.err and "bad checksum" in text.err
    recs = [r for r in iter_run_file(out) if isinstance(r, RunRecord)]
    assert len(recs) == 30
    r = recs[10]
    # 12:00:10; 6 kn on 045: 10 s × 6/3600 NM × cos 45° = 0.011785 arc min north
    assert r.time.hour == 12 and r.time.second == 10
    assert (r.gps_lat_deg - 52.8333333333) * 60 == pytest.approx(
        10 * 6 / 3600 * 0.7071068, abs=2e-5)  # the log carries minutes to 1e-4 (0.2 m)
    assert (r.heading_deg, r.speed_kn, r.cog_deg, r.sog_kn) == (45.0, 6.0, 45.0, 6.0)
    assert (r.gps_hdop, r.gps_quality, r.gps_sats) == (0.8, 1, 9)
    assert r.echo_m == 20.1  # DBT of second 10 (20.0 + 10 × 0.01)
    lines = out.read_text().splitlines()
    assert lines[0].startswith("* UVNAV .RUN converted from the NMEA 0183 log")
    assert any(ln.startswith("* skipped: ") and "bad checksum 2" in ln for ln in lines)


def test_replay_of_log_and_of_converted_run_agree(tmp_path: Path) -> None:
    """The issue's proof: the same cycles whichever file is replayed (only the record line
    numbers differ: NMEA line vs .RUN line)."""
    log = tmp_path / "v.nmea"
    log.write_text("\n".join(voyage(40)) + "\n")
    run = tmp_path / "v.RUN"
    assert main(["convert", str(log), "--out", str(run)]) == 0
    write_config(tmp_path / "cfg.toml", "v.nmea")
    assert main(["replay", str(log), "--config", str(tmp_path / "cfg.toml"),
                 "--out", str(tmp_path / "a.OUT")]) == 0
    assert main(["replay", str(run), "--config", str(tmp_path / "cfg.toml"),
                 "--out", str(tmp_path / "b.OUT")]) == 0
    assert len(read_out_log(tmp_path / "a.OUT").cycles) == 40

    def rows(name: str) -> list[str]:
        """The cycle blocks' text (not the header, not the BAD lines of the damaged
        sentences), the record line numbers blanked."""
        text = (tmp_path / name).read_text().splitlines()
        return [re.sub(r" record=\d+", " record=?", ln) for ln in text
                if not ln.startswith(("#", "BAD "))]

    a, b = rows("a.OUT"), rows("b.OUT")
    assert len(a) > 40 * 5 and a == b
    assert (tmp_path / "a.OUT").read_text().count("\nBAD ") == 4  # damage reported, bounded


def test_convert_follows_the_out_rule(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "v.nmea"
    log.write_text("\n".join(voyage(3, damage=False)) + "\n")
    out = tmp_path / "v.RUN"
    out.write_text("not mine\n")
    assert main(["convert", str(log), "--out", str(out)]) == 0
    assert out.read_text() == "not mine\n" and (tmp_path / "v_1.RUN").is_file()
    assert main(["convert", str(log), "--out", str(out), "--force"]) == 2  # not a UVNAV .RUN
    assert main(["convert", str(log), "--out", str(tmp_path / "v_1.RUN"), "--force"]) == 0
    assert main(["convert", str(log), "--out", str(log), "--force"]) == 2  # the input
    assert log.read_text().startswith("$GPGGA")
    capsys.readouterr()


def test_convert_refuses_a_run_file_and_bad_options(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    run = tmp_path / "x.RUN"
    run.write_text("920917 083538 - - .862 .325 .109 232.4 12.7 -.2\n")
    assert main(["convert", str(run), "--out", str(tmp_path / "y.RUN")]) == 2
    assert "Not an NMEA 0183 log" in capsys.readouterr().err
    log = tmp_path / "v.nmea"
    log.write_text("\n".join(voyage(3, damage=False)) + "\n")
    assert main(["convert", str(log), "--out", str(tmp_path / "y.RUN"), "--interval", "0"]) == 2
    assert "--interval" in capsys.readouterr().err
    assert main(["convert", str(log), "--out", str(tmp_path / "y.RUN"), "--date", "2026-13-01"]) \
        == 2
    assert not (tmp_path / "y.RUN").exists()


def test_convert_reads_cr_only_and_gzip_logs(tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    """A log with CR alone as line end gave a header-only .RUN and exit 3; a rotated
    ``.nmea.gz`` was not a log at all. Both give the records of the plain LF log."""
    import gzip

    lines = voyage(20)
    plain = tmp_path / "lf.nmea"
    plain.write_text("\n".join(lines) + "\n")
    assert main(["convert", str(plain), "--out", str(tmp_path / "lf.RUN")]) == 0
    want = [r.raw for r in iter_run_file(tmp_path / "lf.RUN") if isinstance(r, RunRecord)]
    assert len(want) == 20
    cr = tmp_path / "cr.nmea"
    cr.write_bytes(("\r".join(lines) + "\r").encode())
    gz = tmp_path / "v.nmea.gz"
    gz.write_bytes(gzip.compress(plain.read_bytes()))
    for log in (cr, gz):
        out = tmp_path / f"{log.name}.RUN"
        assert main(["convert", str(log), "--out", str(out)]) == 0
        assert "wrote 20 records" in capsys.readouterr().out
        assert [r.raw for r in iter_run_file(out) if isinstance(r, RunRecord)] == want


def test_convert_names_what_a_non_log_is(tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    empty = tmp_path / "e.nmea"
    empty.write_bytes(b"")
    assert main(["convert", str(empty), "--out", str(tmp_path / "e.RUN")]) == 2
    assert f"{empty}: Not an NMEA 0183 log (an empty file) !" in capsys.readouterr().err
    assert not (tmp_path / "e.RUN").exists()

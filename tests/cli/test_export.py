"""``uvnav export`` end to end: the thesis sample replayed, exported in every format, read back;
the ``.OUT`` output rule (free names, ``--force``, inputs protected) and the exit statuses."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import gpxpy
import pandas as pd
import pytest

from tests.paths import copy_data
from uvnav_tui.cli.export import run_export
from uvnav_tui.cli.main import main
from uvnav_tui.cli.replay import run_replay


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """920917_1 replayed with .OUT, JSON lines and smoothed positions."""
    d = copy_data(tmp_path_factory.mktemp("cli_export") / "data")
    assert run_replay([str(d / "920917_1.RUN"), "--jsonl", str(d / "s.jsonl"), "--smooth"]) == 0
    return d


def test_every_format_at_once(run: Path, tmp_path: Path,
                              capsys: pytest.CaptureFixture[str]) -> None:
    out = {k: tmp_path / f"t.{k}" for k in ("gpx", "geojson", "csv", "kml")}
    rc = main(["export", str(run / "920917_1.OUT"), "--tracks", "mpp,lse,smoothed",
               "--smoothed", str(run / "920917_1.smooth.jsonl"),
               *[a for k, p in out.items() for a in (f"--{k}", str(p))]])
    printed = capsys.readouterr().out
    assert rc == 0
    assert "cycles 10  bad records 0  tracks mpp 10 lse 10 smoothed 10" in printed
    assert "datum ED50 -> WGS84" in printed
    gpx = gpxpy.parse(out["gpx"].read_text(encoding="utf-8"))
    assert [len(t.segments[0].points) for t in gpx.tracks] == [10, 10, 10]
    doc = json.loads(out["geojson"].read_text(encoding="utf-8"))
    kinds = [f["properties"]["kind"] for f in doc["features"]]
    assert kinds.count("track") == 3 and kinds.count("epoch") == 30
    assert len(pd.read_csv(out["csv"])) == 10
    assert ET.parse(out["kml"]).getroot().tag == "{http://www.opengis.net/kml/2.2}kml"


def test_outputs_follow_the_out_rule(run: Path, tmp_path: Path,
                                     capsys: pytest.CaptureFixture[str]) -> None:
    log = str(run / "920917_1.OUT")
    target = tmp_path / "a.gpx"
    assert run_export([log, "--gpx", str(target)]) == 0
    assert run_export([log, "--gpx", str(target)]) == 0  # kept: a free name is used
    assert (tmp_path / "a_1.gpx").is_file()
    before = target.stat().st_mtime_ns
    assert run_export([log, "--gpx", str(target), "--force"]) == 0  # an earlier export
    assert target.stat().st_mtime_ns >= before and not (tmp_path / "a_2.gpx").exists()
    notes = tmp_path / "notes.gpx"
    notes.write_text("my notes\n", encoding="utf-8")
    capsys.readouterr()
    assert run_export([log, "--gpx", str(notes), "--force"]) == 2
    assert "Not an earlier UVNAV output" in capsys.readouterr().err
    assert notes.read_text(encoding="utf-8") == "my notes\n"
    assert run_export([log, "--csv", log, "--force"]) == 2  # the log itself: refused
    assert "Same file as the log" in capsys.readouterr().err
    assert run_export([log, "--kml", str(tmp_path / "k.kml"),
                       "--csv", str(tmp_path / "k.kml")]) == 2  # two outputs, one file
    assert not (tmp_path / "k.kml").exists()


def test_bad_input_exits_2_with_a_located_message(run: Path, tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    gpx = str(tmp_path / "x.gpx")
    assert run_export([str(run / "920917_1.OUT")]) == 2
    assert "Nothing to write" in capsys.readouterr().err
    assert run_export([str(tmp_path / "missing.OUT"), "--gpx", gpx]) == 2
    assert "missing.OUT: log: File not found !" in capsys.readouterr().err
    assert run_export([str(run / "s.jsonl"), "--gpx", gpx]) == 2  # JSON lines: no data_dir
    assert "give the run's datum file" in capsys.readouterr().err
    assert run_export([str(run / "s.jsonl"), "--gpx", gpx, "--datum-file",
                       str(run / "TO_WGS84.DAT"), "--tracks", "mpp,gps"]) == 0
    assert "gps: no point in this log (JSON lines carry no GPS input" in capsys.readouterr().err
    assert run_export([str(run / "920917_1.OUT"), "--gpx", gpx, "--tracks", "kf"]) == 2
    assert "--tracks: Unknown track" in capsys.readouterr().err
    assert run_export([str(run / "920917_1.OUT"), "--gpx", gpx, "--tracks", "smoothed"]) == 2
    assert "needs --smoothed" in capsys.readouterr().err
    cut = tmp_path / "cut.OUT"
    text = (run / "920917_1.OUT").read_bytes()
    cut.write_bytes(text[: len(text) - 40])
    assert run_export([str(cut), "--csv", str(tmp_path / "cut.csv")]) == 0
    err = capsys.readouterr().err
    assert f"warning: {cut}:" in err and "incomplete" in err
    assert len(pd.read_csv(tmp_path / "cut.csv")) == 9


def test_an_nmea_replay_exports_its_fixes(tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    """An NMEA 0183 log (helper A's input path) replayed on WGS84 and exported: the GPX GPS
    track is the GGA positions as the sentences give them (ddmm.mmmm, hand-converted here), to
    1e-9° (the GPX's 9 decimals); no datum file is needed on WGS84, nothing is converted."""
    from tests.cli.test_replay_nmea import LAT0, LON0, write_config, write_log

    log = tmp_path / "trip.log"
    write_log(log, n=30)
    write_config(tmp_path / "trip.toml", "trip.log")
    assert main(["replay", str(log), "--out", str(tmp_path / "trip.OUT")]) == 0
    gpx_path = tmp_path / "trip.gpx"
    assert main(["export", str(tmp_path / "trip.OUT"), "--tracks", "gps,mpp",
                 "--gpx", str(gpx_path)]) == 0
    assert "datum WGS84 -> WGS84" in capsys.readouterr().out
    gps, mpp = gpxpy.parse(gpx_path.read_text(encoding="utf-8")).tracks
    points = gps.segments[0].points
    assert len(points) == 30
    for k, p in enumerate(points):
        lat = LAT0 + k * 5.0 / 3600.0 / 60.0
        minutes = round((lat - int(lat)) * 60, 4)  # what the GGA sentence carries
        assert p.latitude == pytest.approx(int(lat) + minutes / 60, abs=1e-9)
        assert p.longitude == pytest.approx(LON0, abs=1e-9)
        assert p.time.hour == 12 and p.time.second == k % 60
    assert len(mpp.segments[0].points) == 30


def test_the_datum_file_is_an_input(run: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The datum file found through the log's data_dir is protected like the log itself."""
    dat = run / "TO_WGS84.DAT"
    before = dat.read_bytes()
    assert run_export([str(run / "920917_1.OUT"), "--csv", str(dat)]) == 2
    assert "--csv: Same file as the datum file !" in capsys.readouterr().err
    assert run_export([str(run / "920917_1.OUT"), "--csv", str(dat), "--force"]) == 2
    assert "Not an earlier UVNAV output" in capsys.readouterr().err
    assert dat.read_bytes() == before
    assert not list(run.glob("TO_WGS84_*"))


def test_a_write_error_removes_the_cut_file(run: Path, tmp_path: Path,
                                            monkeypatch: pytest.MonkeyPatch,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    """A full disk while a file is written: named, exit 1, and the cut file removed (a GeoJSON
    cut in the middle is no file any reader takes); the files written before it are kept."""
    from engine.io import outputs

    real_write = outputs.OutputFile.write

    def write(self: outputs.OutputFile, text: str) -> None:
        if self.path.suffix == ".geojson":
            real_write(self, text[:100])
            raise OSError(28, "No space left on device", str(self.path))
        real_write(self, text)

    monkeypatch.setattr(outputs.OutputFile, "write", write)
    gpx, geo = tmp_path / "w.gpx", tmp_path / "w.geojson"
    rc = run_export([str(run / "920917_1.OUT"), "--gpx", str(gpx), "--geojson", str(geo)])
    err = capsys.readouterr().err
    assert rc == 1
    assert (f"uvnav export: {geo}: cannot write: No space left on device ! "
            "(the incomplete file removed)") in err
    assert not geo.exists()
    assert gpxpy.parse(gpx.read_text(encoding="utf-8")).tracks

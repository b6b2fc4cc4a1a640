"""Headless replay: `uvnav replay`, the .OUT log read back, JSON lines, crash safety."""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import pytest

from engine.errors import InputError
from engine.io.outlog import read_out_log
from engine.run.commands import SetDecca
from engine.run.config import dump_config, load_config, parse_config_text
from engine.run.session import Session
from tests.paths import DATA, ROOT
from uvnav_tui.cli.main import main


def test_replay_sample_writes_out_and_jsonl(tmp_path: Path, capsys) -> None:
    out, jl = tmp_path / "S.OUT", tmp_path / "S.jsonl"
    rc = main(["replay", str(DATA / "920917_1.RUN"), "--config", str(DATA / "920917_1.toml"),
               "--out", str(out), "--jsonl", str(jl), "--smooth", str(tmp_path / "S.smo")])
    assert rc == 0
    text = capsys.readouterr().out
    assert "epochs 10  fixes 10  rejected LOPs 0  skipped records 0" in text
    assert "smoothed epochs 10" in text
    log = read_out_log(out)
    assert len(log.cycles) == 10 and not log.truncated
    assert 'datum = "ED50"' in log.config_text and any("engine" in h for h in log.header)
    objs = [json.loads(line) for line in jl.read_text().splitlines()]
    assert len(objs) == 10
    for o in objs:
        assert {"time", "record", "filter", "source", "datum", "mpp", "lse", "kf", "lops"} <= set(o)
        assert set(o["mpp"]) >= {"lat", "lon", "x", "y", "a95", "b95", "az_deg"}
        assert all(set(lop) >= {"system", "pattern", "obs", "calc", "v", "w", "used"}
                   for lop in o["lops"])
    assert objs[0]["time"] == "1992-09-17T08:35:38Z" and objs[0]["record"] == 2
    assert [o["filter"] for o in objs] == ["N/A"] + ["ON"] * 9


def test_out_log_round_trips_the_cycle_values(tmp_path: Path) -> None:
    """The reader returns exactly what the cycle computed (full float precision)."""
    cfg = load_config(DATA / "920917_1.toml")
    with Session(cfg, out_path=tmp_path / "R.OUT") as s:
        results = [s.step() for _ in range(10)]
    log = read_out_log(tmp_path / "R.OUT")
    for r, c in zip(results, log.cycles, strict=True):
        assert c.fields["n"] == r.n and c.fields["record"] == r.record
        mpp = c.first("MPP")
        assert (mpp["x"], mpp["y"], mpp["lat"], mpp["lon"]) == (
            r.mpp.x_m, r.mpp.y_m, r.mpp.lat_deg, r.mpp.lon_deg)
        lse = c.first("LSE")
        assert (lse["x"], lse["y"], lse["s2"]) == (r.fix.x_m, r.fix.y_m, r.fix.s2)
        lops = c.all("LOP")
        assert [(x["sys"], x["pat"], x["v"] if x["used"] else None) for x in lops] == [
            (lop.system, lop.pattern, lop.v_m if lop.used else None) for lop in r.fix.lops]
        assert c.first("IN")["raw"] == r.raw


def test_existing_out_is_not_overwritten(tmp_path: Path, capsys) -> None:
    out = tmp_path / "S.OUT"
    out.write_text("precious\n")
    rc = main(["replay", str(DATA / "920917_1.RUN"), "--out", str(out)])
    assert rc == 0 and out.read_text() == "precious\n"
    assert (tmp_path / "S_1.OUT").exists()
    assert "S_1.OUT" in capsys.readouterr().out


def test_bad_input_gives_a_message_not_a_traceback(tmp_path: Path, capsys) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('datum = "ED50"\n[lsq]\nlop_reject = "Q"\n')
    rc = main(["replay", str(DATA / "920917_1.RUN"), "--config", str(bad), "--no-out"])
    err = capsys.readouterr().err
    assert rc == 2 and f"{bad}:3: lsq.lop_reject" in err and "Traceback" not in err


def test_kill_during_long_replay_leaves_a_readable_log(tmp_path: Path) -> None:
    """SIGKILL in the middle of the 2 h demo: every completed cycle is in the .OUT."""
    out = tmp_path / "K.OUT"
    proc = subprocess.Popen(
        [sys.executable, "-m", "uvnav_tui.cli.main", "replay", str(DATA / "DEMO.RUN"),
         "--config", str(DATA / "DEMO.toml"), "--out", str(out)],
        cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )
    # Until the log is well under way, however slow a loaded machine is (not a fixed time).
    deadline = time.monotonic() + 300
    while not (out.exists() and out.stat().st_size > 400_000):
        assert time.monotonic() < deadline and proc.poll() is None
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    log = read_out_log(out)
    assert len(log.cycles) > 50
    ns = [c.fields["n"] for c in log.cycles]
    assert ns == list(range(1, len(ns) + 1))
    assert all(c.first("MPP") is not None for c in log.cycles)


@pytest.mark.parametrize("name", ["920917_1", "DEMO"])
def test_bundled_configs_load_and_point_at_their_run(name: str) -> None:
    cfg = load_config(DATA / f"{name}.toml")
    assert cfg.run_path.exists()


# --------------------------------------------------------------------------- located errors

RUN = DATA / "920917_1.RUN"
TOML_TEXT = (DATA / "920917_1.toml").read_text(encoding="utf-8")


def _line_of(text: str, start: str) -> int:
    """1-based number of the first line of ``text`` starting with ``start``."""
    return next(i for i, ln in enumerate(text.splitlines(), 1) if ln.startswith(start))


def _config(tmp_path: Path, old: str, new: str, name: str = "bad.toml") -> tuple[Path, int]:
    """The sample configuration with ``old`` replaced, data_dir pointing at data/; returns the
    file and the line of the change."""
    assert old in TOML_TEXT
    text = TOML_TEXT.replace(old, new).replace('data_dir = "."', f'data_dir = "{DATA}"')
    text = text.replace('run_file = "920917_1.RUN"', f'run_file = "{RUN}"')
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path, _line_of(text, new.splitlines()[0])


@pytest.mark.parametrize(("old", "new", "field", "message"), [
    ('datum = "ED50"', 'datum = "ED51"', "datum", "Unknown datum !"),
    ('run_gps_datum = "ED50"', 'run_gps_datum = "ED5O"', "run_gps_datum", "Unknown datum !"),
    ('chain = "9B"', 'chain = "9C"', "decca.chain", "Unknown chain !"),
])
def test_unknown_names_are_located_in_the_config(tmp_path: Path, capsys, old: str, new: str,
                                                 field: str, message: str) -> None:
    cfg, line = _config(tmp_path, old, new)
    rc = main(["replay", str(RUN), "--config", str(cfg), "--out", str(tmp_path / "X.OUT")])
    err = capsys.readouterr().err
    got = new.split(" = ")[1]
    assert rc == 2 and f"uvnav replay: {cfg}:{line}: {field}: {message} (got {got!r})" in err
    assert "Traceback" not in err and not (tmp_path / "X.OUT").exists()


def test_session_refuses_an_unknown_chain() -> None:
    # Not only the CLI: a Session never starts with a chain DECCA.CHN does not have (before,
    # the run went GPS-only with a per-cycle message).
    cfg = load_config(DATA / "920917_1.toml")
    bad = cfg.replace(decca=replace(cfg.decca, chain="9C"))
    with pytest.raises(InputError) as info:
        Session(bad)
    assert (info.value.field, info.value.message, info.value.text) == (
        "decca.chain", "Unknown chain !", "9C")
    # An operator command cannot switch to one either (the console shows the message).
    s = Session(cfg)
    with pytest.raises(InputError):
        s.apply(SetDecca(on=True, chain="9C", red="B20", green="F34", purple="A51"))
    assert s.config.decca.chain == "9B"


def _data_dir_with(tmp_path: Path, chain_old: str, chain_new: str) -> Path:
    d = tmp_path / "data"
    d.mkdir()
    shutil.copy(DATA / "TO_WGS84.DAT", d)
    chn = (DATA / "DECCA.CHN").read_text(encoding="utf-8")
    assert chain_old in chn
    (d / "DECCA.CHN").write_text(chn.replace(chain_old, chain_new, 1), encoding="utf-8")
    return d


def test_unknown_chain_datum_is_reported_at_the_chain_file_line(tmp_path: Path, capsys) -> None:
    d = _data_dir_with(tmp_path, "ED50\n* Geodetic Datum", "XX50\n* Geodetic Datum")
    cfg, _ = _config(tmp_path, 'data_dir = "."', f'data_dir = "{d}"')
    rc = main(["replay", str(RUN), "--config", str(cfg), "--out", str(tmp_path / "X.OUT")])
    err = capsys.readouterr().err
    # Line 14 of DECCA.CHN is 9B's datum line (A8.4); before: 10 × "skipped: time: datum: …".
    assert rc == 2
    assert f"{d / 'DECCA.CHN'}:14: datum: Unknown datum ! (got 'XX50')" in err
    assert "skipped" not in err and not (tmp_path / "X.OUT").exists()


# --------------------------------------------------------------------------- bad records

def _run_file(tmp_path: Path, lines: list[str], name: str = "P.RUN") -> Path:
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


SAMPLE_LINES = RUN.read_text(encoding="utf-8").splitlines()  # caption + 10 records


def test_repeated_time_names_run_file_and_line(tmp_path: Path, capsys) -> None:
    run = _run_file(tmp_path, SAMPLE_LINES[:4] + [SAMPLE_LINES[3]] + SAMPLE_LINES[4:])
    out = tmp_path / "P.OUT"
    rc = main(["replay", str(run), "--config", str(DATA / "920917_1.toml"), "--out", str(out)])
    cap = capsys.readouterr()
    assert rc == 0 and "epochs 10" in cap.out and "skipped records 1" in cap.out
    # Line 5 repeats 08:35:40 of line 4.
    assert f"skipped: {run.resolve()}:5: time: Time does not advance ! (got '083540')" in cap.err
    log = read_out_log(out)
    assert [(b["record"], b["field"]) for b in log.bad_records] == [(5, "time")]


def test_an_engine_error_is_not_reported_as_a_bad_record(monkeypatch, tmp_path: Path) -> None:
    """A record that passed the parser and the time check is valid input for the cycle: an
    exception there is a bug and must surface, naming the record, not become a BAD line."""
    import engine.run.session as session_mod

    def broken(*_a: object, **_k: object) -> None:
        raise ValueError("math domain error")

    monkeypatch.setattr(session_mod, "step", broken)
    s = Session(load_config(DATA / "920917_1.toml"), out_path=tmp_path / "E.OUT")
    with pytest.raises(ValueError, match="math domain error") as info:
        s.step()
    s.close()
    assert f"{RUN}:2: " in "\n".join(getattr(info.value, "__notes__", []))
    assert s.bad_records == [] and read_out_log(tmp_path / "E.OUT").bad_records == ()


def test_cli_reports_an_engine_error_as_internal(monkeypatch, tmp_path: Path, capsys) -> None:
    import engine.run.session as session_mod

    def broken(*_a: object, **_k: object) -> None:
        raise ValueError("math domain error")

    monkeypatch.setattr(session_mod, "step", broken)
    rc = _replay(tmp_path)
    err = capsys.readouterr().err
    assert rc == 4 and "internal error (ValueError: math domain error)" in err
    assert f"while processing {RUN.resolve()}:2:" in err and "skipped" not in err


def test_all_bad_run_exits_3_some_bad_exits_0(tmp_path: Path, capsys) -> None:
    cfg = str(DATA / "920917_1.toml")
    bad = [ln.replace(" N\t", " X\t") for ln in SAMPLE_LINES]  # no latitude hemisphere is valid
    assert sum(" X\t" in ln for ln in bad) == 10
    run = _run_file(tmp_path, bad, "ALLBAD.RUN")
    rc = main(["replay", str(run), "--config", cfg, "--out", str(tmp_path / "A.OUT")])
    cap = capsys.readouterr()
    assert rc == 3 and "epochs 0" in cap.out
    assert f"uvnav replay: {run}: no record could be processed (10 skipped) !" in cap.err
    assert len(read_out_log(tmp_path / "A.OUT").bad_records) == 10  # the log says why
    some = _run_file(tmp_path, SAMPLE_LINES[:2] + bad[2:], "SOMEBAD.RUN")
    rc = main(["replay", str(some), "--config", cfg, "--out", str(tmp_path / "S.OUT")])
    cap = capsys.readouterr()
    assert rc == 0 and "epochs 1" in cap.out and "skipped records 9" in cap.out
    empty = _run_file(tmp_path, ["* nothing but a comment"], "EMPTY.RUN")
    assert main(["replay", str(empty), "--config", cfg, "--no-out"]) == 3


# --------------------------------------------------------------------------- output files

def _replay(tmp_path: Path, *extra: str) -> int:
    return main(["replay", str(RUN), "--config", str(DATA / "920917_1.toml"),
                 "--out", str(tmp_path / "S.OUT"), *extra])


def test_existing_smooth_and_jsonl_files_are_kept(tmp_path: Path, capsys) -> None:
    smo, jl = tmp_path / "S.smo", tmp_path / "S.jsonl"
    smo.write_text("precious smooth\n")
    jl.write_text("precious jsonl\n")
    rc = _replay(tmp_path, "--jsonl", str(jl), "--smooth", str(smo))
    cap = capsys.readouterr()
    # Same rule as the .OUT: never overwritten, the next free NAME_N is used (before: the
    # smooth file gave a traceback after the whole replay, the jsonl exit 2 + an orphan .OUT).
    assert rc == 0 and "Traceback" not in cap.err
    assert smo.read_text() == "precious smooth\n" and jl.read_text() == "precious jsonl\n"
    assert len((tmp_path / "S_1.smo").read_text().splitlines()) == 10
    assert len((tmp_path / "S_1.jsonl").read_text().splitlines()) == 10
    assert f"smoothed positions {tmp_path / 'S_1.smo'}" in cap.out
    assert f"json lines {tmp_path / 'S_1.jsonl'}" in cap.out
    # --force replaces earlier outputs, never a file UVNAV did not write (engine/io/outputs.py).
    assert _replay(tmp_path, "--jsonl", str(jl), "--smooth", str(smo), "--force") == 2
    assert "Not an earlier UVNAV output" in capsys.readouterr().err
    assert smo.read_text() == "precious smooth\n" and jl.read_text() == "precious jsonl\n"
    smo1, jl1 = tmp_path / "S_1.smo", tmp_path / "S_1.jsonl"
    smo1.write_text(smo1.read_text().splitlines()[0] + "\n")  # an earlier, shorter output
    jl1.write_text(jl1.read_text().splitlines()[0] + "\n")
    assert _replay(tmp_path, "--jsonl", str(jl1), "--smooth", str(smo1), "--force") == 0
    assert len(smo1.read_text().splitlines()) == 10 and len(jl1.read_text().splitlines()) == 10


def test_an_output_that_cannot_be_created_leaves_no_orphans(tmp_path: Path, capsys) -> None:
    rc = _replay(tmp_path, "--jsonl", str(tmp_path / "nodir" / "S.jsonl"), "--smooth",
                 str(tmp_path / "S.smo"))
    err = capsys.readouterr().err
    assert rc == 2 and "--jsonl: Directory not found !" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == []
    # The engine alone: the .OUT is created after the JSON lines and removed if they fail.
    (tmp_path / "J.jsonl").mkdir()  # a directory: opening it for writing fails
    with pytest.raises(InputError, match="Is a directory"):
        Session(load_config(DATA / "920917_1.toml"), out_path=tmp_path / "J.OUT",
                jsonl_path=tmp_path / "J.jsonl", force=True)
    assert not (tmp_path / "J.OUT").exists()


def test_outputs_must_not_be_an_input_or_each_other(tmp_path: Path, capsys) -> None:
    run = _run_file(tmp_path, SAMPLE_LINES, "IN.RUN")
    before = run.read_bytes()
    cfg = str(DATA / "920917_1.toml")
    rc = main(["replay", str(run), "--config", cfg, "--jsonl", str(run), "--force"])
    assert rc == 2 and "--jsonl: Same file as the run file !" in capsys.readouterr().err
    assert run.read_bytes() == before
    rc = main(["replay", str(run), "--config", cfg, "--jsonl", str(tmp_path / "X"),
               "--smooth", str(tmp_path / "X")])
    assert rc == 2 and "--smooth: Same file as --jsonl !" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["IN.RUN"]


# --------------------------------------------------------------------------- the logged config

def test_logged_config_reproduces_the_run(tmp_path: Path) -> None:
    """The header TOML, loaded from anywhere, gives the same run and data paths (before, it said
    data_dir = "." next to an absolute run_file, so it pointed at the log's directory)."""
    work = tmp_path / "work"
    work.mkdir()
    for name in ("920917_1.RUN", "920917_1.toml", "TO_WGS84.DAT", "DECCA.CHN"):
        shutil.copy(DATA / name, work)
    out = tmp_path / "logs" / "W.OUT"
    out.parent.mkdir()
    assert main(["replay", str(work / "920917_1.RUN"), "--out", str(out)]) == 0
    logged = parse_config_text(read_out_log(out).config_text, "header",
                               base_dir=tmp_path / "elsewhere")
    original = load_config(work / "920917_1.toml")
    assert logged.run_path == original.run_path == work / "920917_1.RUN"
    assert logged.data_dir == original.data_dir == work
    # Everything else is the same configuration too, but for the LOP rule the headless run
    # followed: "A" (ask) has nobody to ask and runs as "N"; the log records what was done.
    assert original.lsq.lop_reject == "A" and logged.lsq.lop_reject == "N"
    assert dump_config(logged) == dump_config(
        original.replace(run_file=str(original.run_path), data_dir_text=str(work),
                         lsq=replace(original.lsq, lop_reject="N")))


# --------------------------------------------------------------------------- progress bar

def test_count_lines_matches_the_text_reader(tmp_path: Path) -> None:
    from uvnav_tui.cli.replay import count_lines

    for body in ("", "a", "a\n", "a\nb", "a\nb\n", "\n\n", "x" * 3_000_000 + "\ny"):
        p = tmp_path / "L.RUN"
        p.write_text(body, newline="")
        assert count_lines(p) == len(body.splitlines())
    assert count_lines(DATA / "DEMO.RUN") == 7200


def test_count_lines_counts_cr_line_ends_and_gzip_content(tmp_path: Path) -> None:
    """The progress bar's total for an NMEA log with CR line ends or in gzip (the log reader
    reads both): the lines the reader counts, not 0 or the compressed bytes' newlines."""
    import gzip

    from uvnav_tui.cli.replay import count_lines

    for body in ("a\rb\rc", "a\r\nb\r\n", "a\rb\nc\r\n\r", "\r" * 5):
        p = tmp_path / "L.nmea"
        p.write_text(body, newline="")
        assert count_lines(p) == len(body.splitlines()), repr(body)
        z = tmp_path / "L.nmea.gz"
        z.write_bytes(gzip.compress(body.encode()))
        assert count_lines(z) == len(body.splitlines()), repr(body)
    big = tmp_path / "big.nmea"  # a CR LF split between two 1 MiB chunks counts once
    big.write_bytes(b"x" * ((1 << 20) - 1) + b"\r\ny\r\n")
    assert count_lines(big) == 2


@pytest.mark.skipif(not hasattr(os, "openpty"), reason="needs a pseudo-terminal")
def test_progress_bar_on_a_terminal_shows_the_total(tmp_path: Path) -> None:
    import pty

    master, slave = pty.openpty()
    proc = subprocess.Popen(
        [sys.executable, "-m", "uvnav_tui.cli.main", "replay", str(RUN), "--config",
         str(DATA / "920917_1.toml"), "--out", str(tmp_path / "T.OUT")],
        cwd=ROOT, stdin=slave, stdout=subprocess.DEVNULL, stderr=slave,
        env={**os.environ, "COLUMNS": "100", "TERM": "xterm"},
    )
    os.close(slave)
    chunks = []
    while True:
        try:
            data = os.read(master, 4096)
        except OSError:  # the child closed the terminal
            break
        if not data:
            break
        chunks.append(data)
    os.close(master)
    assert proc.wait(timeout=60) == 0
    text = re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", b"".join(chunks).decode("utf-8", "replace"))
    # 11 lines: the caption and 10 records; before, the bar had no total ("10/?").
    assert " 0/11 lines" in text and "11/11 lines" in text and "/?" not in text


def test_out_and_no_out_together_are_refused(tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    """``--out FILE --no-out`` asked for a log and for none: a usage error (exit 2), nothing
    run; the second used to win silently."""
    with pytest.raises(SystemExit) as stop:
        main(["replay", str(DATA / "920917_1.RUN"), "--out", str(tmp_path / "y.OUT"),
              "--no-out"])
    assert stop.value.code == 2
    assert "argument --no-out: not allowed with argument --out" in capsys.readouterr().err
    assert not (tmp_path / "y.OUT").exists()

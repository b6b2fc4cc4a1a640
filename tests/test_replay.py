"""Headless replay: `uvnav replay`, the .OUT log read back, JSON lines, crash safety."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from engine.outlog import read_out_log
from engine.runconfig import load_config
from engine.session import Session
from uvnav_tui.cli import main

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "data"


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
        [sys.executable, "-m", "uvnav_tui.cli", "replay", str(DATA / "DEMO.RUN"),
         "--config", str(DATA / "DEMO.toml"), "--out", str(out)],
        cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if out.exists() and out.stat().st_size > 400_000:
            break
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

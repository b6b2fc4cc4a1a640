"""``uvnav campaign`` on a real dask.distributed LocalCluster (docs/CAMPAIGN.md).

Small on purpose (the machine is shared): the 10-minute SHORT_DIVE scenario, a few seeds. The
reference for every table is a plain loop of :func:`engine.campaign.run.run_one` in this
process, without Dask: a campaign's table must equal it, timing columns aside, whatever the
number of workers, the order in which runs finish, a killed worker or a killed client.
"""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pyarrow.parquet as pq
import pytest

from engine.campaign.run import COLUMNS, TIMING_COLUMNS, run_one
from engine.campaign.spec import load_campaign
from tests.paths import DATA, ROOT
from uvnav_tui.cli import campaign as cli

SHORT = DATA / "campaigns" / "scenarios" / "SHORT_DIVE.scenario.toml"


def _spec(tmp_path: Path, seeds: str, extra: str = "", name: str = "c.toml",
          top: str = "") -> Path:
    p = tmp_path / name
    p.write_text(f'name = "test"\n{top}scenarios = ["{SHORT}"{extra}]\nseeds = "{seeds}"\n'
                 '[[variants]]\nname = "default"\n[[variants]]\nname = "thesis"\n'
                 'filter = { preset = "thesis", model = "thesis", p0 = "thesis" }\n',
                 encoding="utf-8")
    return p


def _comparable(rows: list[dict[str, Any]]) -> list[tuple[Any, ...]]:
    """Rows without the timing columns, NaN made comparable."""
    names = [n for n, _k in COLUMNS if n not in TIMING_COLUMNS]
    return [tuple("nan" if isinstance(r[n], float) and math.isnan(r[n]) else r[n]
                  for n in names) for r in rows]


def _table(out: Path) -> list[dict[str, Any]]:
    return pq.read_table(out / "runs.parquet").to_pylist()


def _reference(spec_path: Path) -> list[tuple[Any, ...]]:
    spec = load_campaign(spec_path)
    bundle = spec.bundle()
    return _comparable([run_one(bundle, t) for t in spec.tasks])


def test_one_and_two_workers_give_the_plain_loops_table(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = _spec(tmp_path, "1-3")
    want = _reference(spec)
    assert len(want) == 6 and all(r[4] == "ok" for r in want)
    for workers in ("1", "2"):
        out = tmp_path / f"w{workers}"
        assert cli.run_campaign([str(spec), "--out", str(out), "--workers", workers]) == 0
        assert _comparable(_table(out)) == want, workers
        summary = (out / "summary.md").read_text()
        assert "| SHORT\\_DIVE | default | 3 |" in summary
        assert "| SHORT\\_DIVE | thesis | 3 |" in summary
        assert (out / "coverage.svg").read_text().startswith("<svg")
    # a second call skips every recorded run and starts no cluster
    capsys.readouterr()
    assert cli.run_campaign([str(spec), "--out", str(tmp_path / "w2")]) == 0
    out, err = capsys.readouterr()
    assert "runs to do" not in err and "(0 run now, 0 failed; 6 recorded before)" in out
    assert _comparable(_table(tmp_path / "w2")) == want


def test_an_external_scheduler_gives_the_same_table(tmp_path: Path) -> None:
    """``--scheduler ADDRESS``: a cluster the campaign did not start (here a LocalCluster of this
    test, as ``dask scheduler`` + ``dask worker`` would be) runs the same table; with
    ``tracks = true`` each run's ``.OUT`` is kept as ``tracks/KEY.OUT``."""
    from distributed import LocalCluster

    spec = _spec(tmp_path, "4", top="tracks = true\n")
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster:
        out = tmp_path / "ext"
        assert cli.run_campaign([str(spec), "--out", str(out), "--scheduler",
                                 cluster.scheduler_address]) == 0
    assert _comparable(_table(out)) == _reference(spec)
    keys = sorted(t.key for t in load_campaign(spec).tasks)
    assert sorted(p.stem for p in (out / "tracks").glob("*.OUT")) == keys
    assert all((out / "tracks" / f"{k}.OUT").read_text().count("CYCLE") >= 300 for k in keys)


@pytest.fixture(scope="module")
def troubled(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, int]:
    """A 2-worker campaign in which one worker process dies mid-run (the test hook) and one
    scenario's runs raise (its configuration's datum is not the scenario's)."""
    tmp = tmp_path_factory.mktemp("troubled")
    for name in ("SHORT_DIVE.scenario.toml", "SHORT_DIVE.toml"):
        text = (SHORT.parent / name).read_text().replace('data_dir = "../.."',
                                                         f'data_dir = "{DATA}"')
        if name == "SHORT_DIVE.toml":
            text = text.replace('datum = "ED50"', 'datum = "WGS84"')
        (tmp / name.replace("SHORT_DIVE", "WRONG_DATUM")).write_text(text, encoding="utf-8")
    spec = _spec(tmp, "1-2", f', "{tmp / "WRONG_DATUM.scenario.toml"}"')
    marker = tmp / "crashed"
    env = {**os.environ, cli.CRASH_ONCE_ENV: str(marker)}
    out = tmp / "out"
    proc = subprocess.run([sys.executable, "-m", "uvnav_tui.cli.main", "campaign", str(spec),
                           "--out", str(out), "--workers", "2"], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=300)
    assert marker.exists(), "no worker died: the hook did not run"
    return spec, out, proc.returncode


def test_a_worker_killed_mid_run_has_its_run_done_elsewhere(
        troubled: tuple[Path, Path, int]) -> None:
    spec, out, rc = troubled
    assert rc == 0
    rows = _table(out)
    assert len(rows) == 8
    good = [r for r in rows if r["scenario"] == "SHORT_DIVE"]
    assert [r["status"] for r in good] == ["ok"] * 4


def test_a_run_that_raises_is_a_failed_row(troubled: tuple[Path, Path, int]) -> None:
    _spec_path, out, _rc = troubled
    bad = [r for r in _table(out) if r["scenario"] == "WRONG_DATUM"]
    assert len(bad) == 4 and {r["status"] for r in bad} == {"failed"}
    assert all("is not the truth's working datum" in r["error"] for r in bad), bad[0]["error"]
    assert all("uvnav-campaign-" not in r["error"] for r in bad)  # no scratch path in a row
    assert all(math.isnan(r["all_mpp_rms_m"]) for r in bad)
    assert "## Failed runs (4)" in (out / "summary.md").read_text()


def _wait_rows(out: Path, n: int, proc: subprocess.Popen[str], limit_s: float = 180) -> None:
    t0 = time.monotonic()
    while time.monotonic() - t0 < limit_s:
        parts = list((out / "parts").glob("*.jsonl")) if (out / "parts").is_dir() else []
        if sum(p.read_bytes().count(b"\n") for p in parts) >= n:
            return
        if proc.poll() is not None:
            raise AssertionError(f"campaign ended early: {proc.returncode}")
        time.sleep(0.2)
    raise AssertionError("no rows in time")


def test_interrupted_and_killed_clients_resume_to_the_same_table(tmp_path: Path) -> None:
    """Ctrl-C leaves a valid partial table (exit 130); a client killed with SIGKILL leaves its
    recorded rows; the next call does only the rest, and the table is the plain loop's."""
    spec = _spec(tmp_path, "1-8")
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "uvnav_tui.cli.main", "campaign", str(spec), "--out", str(out),
           "--workers", "1"]
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    _wait_rows(out, 2, proc)
    proc.send_signal(signal.SIGINT)
    _stdout, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    partial = _table(out)
    assert 2 <= len(partial) < 16 and "holds the" in err
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    _wait_rows(out, len(partial) + 2, proc)
    proc.kill()
    proc.communicate(timeout=60)
    before = sum(p.read_bytes().count(b"\n") for p in (out / "parts").glob("*.jsonl"))
    assert before < 16
    assert len(_table(out)) >= len(partial)  # the last table written is whole
    proc2 = subprocess.run([*cmd, "--resume"], cwd=ROOT, capture_output=True, text=True,
                           timeout=300)
    assert proc2.returncode == 0, proc2.stderr
    assert f"({before} already recorded)" in proc2.stderr or before == 16
    assert _comparable(_table(out)) == _reference(spec)


def test_a_changed_spec_is_refused_unless_restart(tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    out.mkdir()
    spec = _spec(tmp_path, "1")
    from engine.campaign.store import CampaignStore

    CampaignStore(out).open(load_campaign(spec))  # as a first call does before its runs
    changed = _spec(tmp_path, "1-2", name="c2.toml")
    assert cli.run_campaign([str(changed), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "another spec" in err and "--restart" in err and str(out) in err
    assert cli.run_campaign([str(spec), "--out", str(tmp_path / "new"), "--resume"]) == 2
    assert "No campaign to resume" in capsys.readouterr().err


def test_bad_input_exits_2_before_any_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    spec = _spec(tmp_path, "1")
    bad = tmp_path / "bad.toml"
    bad.write_text(spec.read_text().replace('seeds = "1"', 'seeds = "9-2"'))
    assert cli.run_campaign([str(bad), "--out", str(tmp_path / "o1")]) == 2
    assert f"{bad}:3: seeds: Bad seed range" in capsys.readouterr().err
    assert cli.run_campaign([str(spec), "--out", str(tmp_path / "o2"), "--workers", "0"]) == 2
    assert "--workers" in capsys.readouterr().err
    assert cli.run_campaign([str(spec), "--out", str(tmp_path / "o2"), "--workers", "2",
                             "--scheduler", "tcp://127.0.0.1:9"]) == 2
    assert "--workers: Only for the local cluster" in capsys.readouterr().err
    monkeypatch.setattr(cli, "CONNECT_TIMEOUT_S", 2)
    rc = cli.run_campaign([str(spec), "--out", str(tmp_path / "o3"), "--scheduler",
                           "tcp://127.0.0.1:9"])
    err = capsys.readouterr().err
    assert rc == 2 and "--scheduler: Cannot reach the scheduler" in err, err
    assert not list((tmp_path / "o3" / "parts").glob("*.jsonl"))


def test_a_held_dask_port_is_not_the_campaigns_business(tmp_path: Path) -> None:
    """Another Dask user (or the other Python's suite) holding 8787, the default port of the
    scheduler's HTTP server, must not put a warning in a campaign's output: the local cluster
    has no dashboard and its HTTP server takes a free loopback port."""
    import socket

    held = socket.socket()
    try:
        held.bind(("127.0.0.1", 8787))
        held.listen()
    except OSError:  # already held by someone else: the condition under test all the same
        pass
    try:
        proc = subprocess.run([sys.executable, "-m", "uvnav_tui.cli.main", "campaign",
                               str(_spec(tmp_path, "1")), "--out", str(tmp_path / "out"),
                               "--workers", "1"], cwd=ROOT, capture_output=True, text=True,
                              timeout=300)
    finally:
        held.close()
    assert proc.returncode == 0, proc.stderr
    assert "8787" not in proc.stderr and "Warning" not in proc.stderr, proc.stderr

"""Issue 15 items 1–4, 7, 8: nothing lost, nothing silently wrong.

Output files are compared with the inputs by identity (device, inode), ``--force`` replaces
only an earlier UVNAV output, devices and dangling links are refused, bad input of every kind
is a located message with exit 2, and bad records / huge lines cannot fill the memory.
Each test names the behaviour the issue reported before the fix.
"""

from __future__ import annotations

import errno
import os
import re
import shutil
import signal
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

import pytest

from engine.errors import InputError, read_error
from engine.io.outlog import read_out_log
from engine.io.outputs import OutputFile, OutputGuard
from engine.io.runfile import LINE_TOO_LONG_MESSAGE, MAX_LINE_CHARS, iter_run_file
from engine.run.config import load_config
from engine.run.session import BAD_RECORDS_KEPT, Session
from tests.paths import DATA, ROOT
from uvnav_tui.cli.main import main

SCENARIO = ('data_dir = "."\nstart_time = "1992-09-17T08:00:00Z"\n'
            'start_position = "52 50 00 N 004 30 00 E"\n'
            "[[leg]]\nduration_s = 60\ncourse_deg = 232\nspeed_kn = 10\n")


@pytest.fixture
def run_dir(tmp_path: Path) -> Path:
    """The 10-record sample run, its configuration and the data files, all in ``tmp_path``
    (``data_dir = "."``), so a test can point outputs at every input."""
    for name in ("920917_1.RUN", "TO_WGS84.DAT", "DECCA.CHN"):
        shutil.copy(DATA / name, tmp_path / name)
    text = (DATA / "920917_1.toml").read_text(encoding="utf-8")
    lines = ['data_dir = "."' if ln.startswith("data_dir") else ln for ln in text.splitlines()]
    (tmp_path / "R.toml").write_text("\n".join(lines) + "\n", encoding="utf-8")
    return tmp_path


def _replay(d: Path, *extra: str) -> int:
    return main(["replay", str(d / "920917_1.RUN"), "--config", str(d / "R.toml"), *extra])


def _snapshot(d: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(d.iterdir()) if p.is_file()}


# --------------------------------------------------------------------------- item 1: identity

@pytest.mark.parametrize("force", [[], ["--force"]])
def test_a_hard_link_to_the_run_file_is_refused(run_dir: Path, capsys, force: list[str]) -> None:
    """Before: ``--out h.OUT --force`` with h.OUT a hard link of the .RUN truncated the input
    and replayed its own output (4.9 GB, OOM)."""
    os.link(run_dir / "920917_1.RUN", run_dir / "h.OUT")
    before = _snapshot(run_dir)
    assert _replay(run_dir, "--out", str(run_dir / "h.OUT"), *force) == 2
    assert "--out: Same file as the run file !" in capsys.readouterr().err
    assert _snapshot(run_dir) == before


@pytest.mark.parametrize(("target", "label"), [
    ("R.toml", "the configuration"),
    ("TO_WGS84.DAT", "the data file TO_WGS84.DAT"),
    ("DECCA.CHN", "the data file DECCA.CHN"),
])
def test_links_to_the_config_and_data_files_are_refused(run_dir: Path, capsys, target: str,
                                                        label: str) -> None:
    os.link(run_dir / target, run_dir / "hard.jsonl")
    (run_dir / "soft.smo").symlink_to(target)
    before = _snapshot(run_dir)
    assert _replay(run_dir, "--no-out", "--jsonl", str(run_dir / "hard.jsonl"), "--force") == 2
    assert f"--jsonl: Same file as {label} !" in capsys.readouterr().err
    assert _replay(run_dir, "--no-out", "--smooth", str(run_dir / "soft.smo"), "--force") == 2
    assert f"--smooth: Same file as {label} !" in capsys.readouterr().err
    assert _snapshot(run_dir) == before


def test_two_outputs_that_are_one_file_are_refused(run_dir: Path, capsys) -> None:
    assert _replay(run_dir, "--out", str(run_dir / "E.OUT")) == 0
    os.link(run_dir / "E.OUT", run_dir / "E.jsonl")
    capsys.readouterr()
    before = _snapshot(run_dir)
    rc = _replay(run_dir, "--out", str(run_dir / "E.OUT"), "--jsonl", str(run_dir / "E.jsonl"),
                 "--force")
    assert rc == 2 and "--jsonl: Same file as --out !" in capsys.readouterr().err
    assert _snapshot(run_dir) == before


# --------------------------------------------------------------------------- item 2: dangling link

def test_a_dangling_symlink_output_gets_a_free_name_and_does_not_hang(run_dir: Path) -> None:
    """Before: the free-name loop spun at 100 % CPU forever. A subprocess with a timeout, so a
    regression fails instead of hanging the suite."""
    (run_dir / "d.OUT").symlink_to("nowhere")
    cmd = [sys.executable, "-m", "uvnav_tui.cli.main", "replay", str(run_dir / "920917_1.RUN"),
           "--config", str(run_dir / "R.toml"), "--out", str(run_dir / "d.OUT")]
    done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert f"log {run_dir / 'd_1.OUT'}" in done.stdout
    assert len(read_out_log(run_dir / "d_1.OUT").cycles) == 10
    assert (run_dir / "d.OUT").is_symlink() and not (run_dir / "nowhere").exists()
    # --force would write wherever the link points: refused.
    done = subprocess.run([*cmd, "--force"], cwd=ROOT, capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 2 and "Dangling symbolic link" in done.stderr
    assert not (run_dir / "nowhere").exists()


# --------------------------------------------------------------------------- item 3: --force

def test_force_replaces_an_earlier_output_only(run_dir: Path, capsys) -> None:
    """Before: ``--out TO_WGS84.DAT --force`` overwrote the datum file."""
    notes = run_dir / "notes.OUT"
    notes.write_text("the operator's notes\n")
    before = _snapshot(run_dir)
    assert _replay(run_dir, "--out", str(run_dir / "TO_WGS84.DAT"), "--force") == 2
    assert "Same file as the data file TO_WGS84.DAT !" in capsys.readouterr().err
    assert _replay(run_dir, "--out", str(notes), "--force") == 2
    assert "--out: Not an earlier UVNAV output" in capsys.readouterr().err
    assert _snapshot(run_dir) == before
    # An earlier .OUT (here cut short) and an empty file are replaced.
    assert _replay(run_dir, "--out", str(run_dir / "E.OUT")) == 0
    (run_dir / "E.OUT").write_text("# UVNAV output log, format 1\n# cut\n")
    (run_dir / "empty.jsonl").write_text("")
    assert _replay(run_dir, "--out", str(run_dir / "E.OUT"), "--jsonl",
                   str(run_dir / "empty.jsonl"), "--force") == 0
    assert len(read_out_log(run_dir / "E.OUT").cycles) == 10
    assert len((run_dir / "empty.jsonl").read_text().splitlines()) == 10
    assert not (run_dir / "E_1.OUT").exists()


def _simulate(d: Path, *args: str) -> int:
    return main(["simulate", str(d / "S.toml"), *args])


def test_simulate_force_never_overwrites_its_scenario_or_data(run_dir: Path, capsys) -> None:
    """Before: ``simulate S.toml --out S.toml --force`` overwrote its own scenario."""
    (run_dir / "S.toml").write_text(SCENARIO, encoding="utf-8")
    os.link(run_dir / "S.toml", run_dir / "L.RUN")
    before = _snapshot(run_dir)
    cases = [
        (["--out", str(run_dir / "S.toml")], "--out: Same file as the scenario !"),
        (["--out", str(run_dir / "L.RUN")], "--out: Same file as the scenario !"),
        (["--out", str(run_dir / "N.RUN"), "--truth", str(run_dir / "DECCA.CHN")],
         "--truth: Same file as the data file DECCA.CHN !"),
        (["--out", str(run_dir / "R.toml")], "--out: Not an earlier UVNAV output"),
        (["--out", str(run_dir / "N.RUN"), "--truth", str(run_dir / "N.RUN")],
         "--truth: Same file as --out !"),
    ]
    for args, message in cases:
        assert _simulate(run_dir, *args, "--force") == 2, args
        assert message in capsys.readouterr().err
    assert _snapshot(run_dir) == before
    # An earlier simulation is replaced; no temporary file is left behind.
    assert _simulate(run_dir, "--out", str(run_dir / "N.RUN")) == 0
    first = (run_dir / "N.RUN").read_bytes()
    assert _simulate(run_dir, "--out", str(run_dir / "N.RUN"), "--seed", "2", "--force") == 0
    assert (run_dir / "N.RUN").read_bytes() != first
    assert not [p for p in run_dir.iterdir() if p.name.endswith(".tmp")]


# --------------------------------------------------------------------------- item 4: devices

@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
@pytest.mark.parametrize("option", ["--out", "--jsonl", "--smooth"])
def test_devices_are_refused_and_no_sibling_is_invented(run_dir: Path, capsys,
                                                        option: str) -> None:
    """Before: ``--out /dev/full`` created a regular file /dev/full_1 and exited 0."""
    existed = os.path.exists("/dev/full_1")
    for force in ([], ["--force"]):
        assert _replay(run_dir, option, "/dev/full", *force) == 2
        err = capsys.readouterr().err
        assert f"/dev/full: {option}: Not a regular file" in err and "Traceback" not in err
    assert os.path.exists("/dev/full_1") == existed
    assert not (run_dir / "920917_1.OUT").exists()  # nothing was created, nothing ran


def test_a_directory_as_output_is_refused(run_dir: Path, capsys) -> None:
    """Before: ``--out .`` raised ValueError from Path.with_name (a traceback)."""
    for name in (".", str(run_dir), str(run_dir) + "/"):
        assert _replay(run_dir, "--out", name) == 2
        err = capsys.readouterr().err
        assert "--out: Is a directory, not a file name !" in err and "Traceback" not in err


# --------------------------------------------------------------------------- item 7: clean errors

def _config_with(d: Path, top: str = "", tail: str = "") -> Path:
    """R.toml with ``top`` lines first (top-level keys) and ``tail`` appended (tables)."""
    keys = {ln.split("=")[0].strip() for ln in top.splitlines() if "=" in ln}
    base = [ln for ln in (d / "R.toml").read_text(encoding="utf-8").splitlines()
            if ln.split("=")[0].strip() not in keys]
    bad = d / "bad.toml"
    bad.write_text(top + "\n".join(base) + "\n" + tail, encoding="utf-8")
    return bad


@pytest.mark.parametrize(("top", "tail", "where", "message"), [
    ("depth_m = " + "[" * 2000 + "]" * 2000 + "\n", "", ":1: depth_m:",
     "nested too deep"),
    ("depth_m = " + "{a=" * 2000 + "}" * 2000 + "\n", "", ":1: depth_m:", "nested too deep"),
    ("depth_m = " + "9" * 5000 + "\n", "", ":1: depth_m:", "Number too long"),
    ("depth_m = " + "9" * 4000 + "\n", "", ":1: depth_m:", "Not a finite number"),
    ('data_dir = "a\\u0000b"\n', "", ":1: data_dir:", "NUL character"),
    ('run_file = "a\\u0000b"\n', "", ":1: run_file:", "NUL character"),
    ("", "[demo]\ndelta_t_s = 1000000000\n", "demo.delta_t_s:",
     "Out of range: must be 1 <= value <= 3600 !"),
])
def test_hostile_configs_are_located_errors(run_dir: Path, capsys, top: str, tail: str,
                                            where: str, message: str) -> None:
    """Before: RecursionError, ValueError (int digits), ValueError (embedded null byte)
    tracebacks, and delta_t_s = 10⁹ passed then failed in the engine (exit 4)."""
    bad = _config_with(run_dir, top, tail)
    rc = main(["replay", str(run_dir / "920917_1.RUN"), "--config", str(bad), "--no-out"])
    err = capsys.readouterr().err
    assert rc == 2 and "Traceback" not in err
    assert message in err
    if where.startswith(":"):
        assert f"{bad}{where}" in err
    else:  # the [demo] line number depends on the file: any line, then the field
        assert re.search(rf"{re.escape(str(bad))}:\d+: {where}", err)
    assert len(err) < 600  # a 4000-digit value is not echoed whole


def test_hostile_scenarios_are_located_errors(run_dir: Path, capsys) -> None:
    """Before: RecursionError for deep nesting, MemoryError for duration_s = 1e11."""
    s = run_dir / "S.toml"
    s.write_text('name = ' + "[" * 2000 + "]" * 2000 + "\n" + SCENARIO, encoding="utf-8")
    assert _simulate(run_dir, "--out", str(run_dir / "X.RUN")) == 2
    assert f"{s}:1: name: Arrays or inline tables nested too deep !" in capsys.readouterr().err
    s.write_text(SCENARIO.replace("duration_s = 60", "duration_s = 100000000000"),
                 encoding="utf-8")
    started = time.monotonic()
    assert _simulate(run_dir, "--out", str(run_dir / "X.RUN")) == 2
    assert time.monotonic() - started < 30
    err = capsys.readouterr().err
    assert f"{s}:5: leg[1].duration_s: Mission too long" in err
    assert not (run_dir / "X.RUN").exists()


def test_directories_as_input_files_say_so(run_dir: Path, capsys) -> None:
    """Before: a directory as run file or config said "File not found !"."""
    (run_dir / "D.RUN").mkdir()
    (run_dir / "D.toml").mkdir()
    assert main(["replay", str(run_dir / "D.RUN"), "--no-out"]) == 2
    assert f"{run_dir / 'D.RUN'}: Is a directory, not a file !" in capsys.readouterr().err
    assert main(["replay", str(run_dir / "920917_1.RUN"), "--config", str(run_dir / "D.toml"),
                 "--no-out"]) == 2
    assert f"{run_dir / 'D.toml'}: Is a directory, not a file !" in capsys.readouterr().err
    assert not list(run_dir.glob("*.OUT"))


def test_read_errors_say_why() -> None:
    """Unreadable files: the reason, not "File not found !" (root reads everything, so the
    CLI test below cannot run as root; this checks the mapping itself)."""
    cases = [(FileNotFoundError(errno.ENOENT, "x"), "File not found !"),
             (PermissionError(errno.EACCES, "x"), "Cannot read: permission denied !"),
             (IsADirectoryError(errno.EISDIR, "x"), "Is a directory, not a file !"),
             (OSError(errno.EIO, "Input/output error"), "Cannot read: Input/output error !")]
    for exc, message in cases:
        assert read_error(exc, "F").message == message


@pytest.mark.skipif(os.geteuid() == 0, reason="root can read a mode-000 file")
def test_an_unreadable_run_file_is_bad_input_and_writes_nothing(run_dir: Path, capsys) -> None:
    """Before: "cannot write: Permission denied" (exit 1) and a header-only .OUT."""
    run = run_dir / "920917_1.RUN"
    run.chmod(0)
    assert _replay(run_dir) == 2
    assert f"{run}: Cannot read: permission denied !" in capsys.readouterr().err
    assert not list(run_dir.glob("*.OUT"))


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
def test_write_and_close_errors_name_the_file() -> None:
    """Before: ``None: cannot write: No space left on device !``. /dev/full fails every write
    with ENOSPC; the buffered text fails at close."""
    out = OutputFile(open("/dev/full", "w", encoding="utf-8"), Path("/dev/full"))  # noqa: SIM115
    out.write("x" * 10)
    with pytest.raises(OSError) as info:
        out.close()
    assert (info.value.errno, info.value.filename) == (errno.ENOSPC, "/dev/full")
    assert out.closed


def test_replay_write_error_names_the_log(run_dir: Path, capsys, monkeypatch) -> None:
    """A disk that fills up during the run: exit 1, the message names the .OUT."""
    import engine.io.outputs

    def full(_fd: int) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(engine.io.outputs.os, "fsync", full)
    assert _replay(run_dir, "--out", str(run_dir / "F.OUT")) == 1
    err = capsys.readouterr().err
    assert f"{run_dir / 'F.OUT'}: cannot write: No space left on device !" in err
    assert "None" not in err


def test_ctrl_c_exits_130_with_one_line(run_dir: Path, capsys, monkeypatch) -> None:
    def interrupted(*_a: object, **_k: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(Session, "run", interrupted)
    assert _replay(run_dir, "--out", str(run_dir / "C.OUT")) == 130
    err = capsys.readouterr().err
    assert err == ("uvnav replay: interrupted (Ctrl-C); the logs keep every cycle completed "
                   "before it\n")
    assert len(read_out_log(run_dir / "C.OUT").cycles) == 0  # the log exists, closed cleanly


def test_sigint_during_a_long_replay(tmp_path: Path) -> None:
    """A real Ctrl-C (SIGINT) in the middle of the 2 h demo: exit 130, one line, no traceback,
    and the .OUT keeps every completed cycle."""
    out = tmp_path / "I.OUT"
    proc = subprocess.Popen(
        [sys.executable, "-m", "uvnav_tui.cli.main", "replay", str(DATA / "DEMO.RUN"),
         "--config", str(DATA / "DEMO.toml"), "--out", str(out)],
        cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
    )
    # Until the log is well under way, however slow a loaded machine is (not a fixed time).
    deadline = time.monotonic() + 300
    while not (out.exists() and out.stat().st_size > 200_000):
        assert time.monotonic() < deadline and proc.poll() is None
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert err.strip().splitlines() == [
        "uvnav replay: interrupted (Ctrl-C); the logs keep every cycle completed before it"]
    log = read_out_log(out)
    assert len(log.cycles) > 20 and not log.truncated


# --------------------------------------------------------------------------- item 8: memory

def test_bad_records_are_counted_not_all_kept(run_dir: Path, capsys) -> None:
    """Before: every bad record was kept to the end and printed (1 M lines: 2.57 GB)."""
    good = (run_dir / "920917_1.RUN").read_text().splitlines()
    n_bad = 3 * BAD_RECORDS_KEPT
    run = run_dir / "MANY.RUN"
    run.write_text("\n".join(good + ["garbage"] * n_bad) + "\n")
    cfg = load_config(run_dir / "R.toml").replace(run_file=str(run))
    with Session(cfg, out_path=run_dir / "M.OUT") as s:
        summary = s.run()
    assert summary.skipped_records == n_bad and len(s.bad_records) == BAD_RECORDS_KEPT
    assert len(read_out_log(run_dir / "M.OUT").bad_records) == n_bad  # all in the log
    assert main(["replay", str(run), "--config", str(run_dir / "R.toml"),
                 "--out", str(run_dir / "N.OUT")]) == 0
    err = capsys.readouterr().err.splitlines()
    assert len(err) == BAD_RECORDS_KEPT + 1
    assert err[-1] == (f"skipped: … and {n_bad - BAD_RECORDS_KEPT} more (every one is a BAD "
                       f"line of {run_dir / 'N.OUT'})")


def test_a_huge_line_is_a_bad_record_in_bounded_memory(tmp_path: Path) -> None:
    """Before: a 100 MB line used 1 GB and was echoed in full. A 30 MB line now costs the
    reader under 1 MB (tracemalloc peak) and keeps 80 characters of it."""
    good = (DATA / "920917_1.RUN").read_text().splitlines()
    run = tmp_path / "HUGE.RUN"
    with open(run, "w", encoding="utf-8") as fh:
        fh.write(good[1] + "\n")
        fh.write("9" * 30_000_000 + "\n")
        fh.write(good[2] + "\n")
    tracemalloc.start()
    items = list(iter_run_file(run))
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 1_000_000
    assert [type(i).__name__ for i in items] == ["RunRecord", "BadRecord", "RunRecord"]
    bad = items[1]
    assert bad.line_no == 2 and bad.error.message == LINE_TOO_LONG_MESSAGE
    assert str(MAX_LINE_CHARS) in LINE_TOO_LONG_MESSAGE and len(bad.raw) == 81
    assert items[2].line_no == 3
    assert len(str(bad.error)) < 200


def test_guard_check_is_read_only(tmp_path: Path) -> None:
    """``check`` with ``force`` reads an existing file but never changes it."""
    f = tmp_path / "x.jsonl"
    f.write_text("not json\n")
    guard = OutputGuard()
    with pytest.raises(InputError, match="Not an earlier UVNAV output"):
        guard.check(f, "--jsonl", kind="jsonl", force=True)
    assert f.read_text() == "not json\n"


def test_assess_svg_is_never_an_input_and_never_overwritten(tmp_path: Path, capsys) -> None:
    """``assess --svg`` wrote over any existing file (even a hard link of its truth)."""
    truth = tmp_path / "T.csv"
    shutil.copy(DATA / "DEMO.truth.csv", truth)
    os.link(truth, tmp_path / "T.svg")
    before = _snapshot(tmp_path)
    rc = main(["assess", str(tmp_path / "none.OUT"), str(truth), "--svg",
               str(tmp_path / "T.svg"), "--force"])
    assert rc == 2  # the log is missing too: the input is named first
    assert "none.OUT: log: File not found !" in capsys.readouterr().err
    log = tmp_path / "L.OUT"  # the name is refused before the log is read: any file will do
    log.write_text("")
    rc = main(["assess", str(log), str(truth), "--svg", str(tmp_path / "T.svg"), "--force"])
    assert rc == 2 and "--svg: Same file as the truth !" in capsys.readouterr().err
    assert _snapshot(tmp_path) == {**before, "L.OUT": log.read_bytes()}
    (tmp_path / "D").mkdir()
    assert main(["assess", str(tmp_path / "D"), str(truth)]) == 2
    assert f"{tmp_path / 'D'}: log: Is a directory, not a file !" in capsys.readouterr().err


def test_svg_plots_follow_the_out_rule(tmp_path: Path) -> None:
    """An earlier plot is kept (free name) or, with force, replaced; a foreign SVG is not."""
    plot = tmp_path / "p.svg"
    plot.write_text('<svg xmlns="http://www.w3.org/2000/svg">\n<!-- UVNAV assess plot -->\n')
    with OutputGuard().open(plot, label="--svg", kind="svg") as fh:
        fh.write("new")
    assert fh.path == tmp_path / "p_1.svg" and "UVNAV" in plot.read_text()
    with OutputGuard().open(plot, label="--svg", kind="svg", force=True) as fh:
        fh.write("new")
    assert fh.path == plot and plot.read_text() == "new"
    plot.write_text('<svg xmlns="http://www.w3.org/2000/svg"><!-- a drawing --></svg>\n')
    with pytest.raises(InputError, match="Not an earlier UVNAV output"):
        OutputGuard().open(plot, label="--svg", kind="svg", force=True)
    assert "a drawing" in plot.read_text()


def test_hardcopy_names_skip_dangling_symlinks(tmp_path: Path) -> None:
    """A dangling link at a hardcopy name was taken as free and written through."""
    from uvnav_tui.hardcopy import free_stem

    (tmp_path / "UVNAV_X_083538_Pg100.txt").symlink_to(tmp_path / "elsewhere.txt")
    assert free_stem(tmp_path, "UVNAV_X_083538_Pg100") == "UVNAV_X_083538_Pg100_2"

"""A command whose standard output cannot be written: one line naming standard output and exit
1 (a full disk: ``> /dev/full``), or exit 141 when its reader went away (``| head -1``); never a
traceback, and the files the command writes are written all the same (uvnav_tui/cli/stdout.py).
Each command runs in a child process, its standard output the failing file."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.paths import DATA, ROOT, copy_data
from uvnav_tui.cli.main import EXIT_BROKEN_PIPE, EXIT_CANNOT_WRITE

DEV_FULL = Path("/dev/full")
needs_dev_full = pytest.mark.skipif(not DEV_FULL.exists(), reason="no /dev/full here")


def uvnav(args: list[str], cwd: Path, stdout: int | object) -> subprocess.CompletedProcess[str]:
    """``uvnav ARGS`` in a child process (the CLI's own module), standard error captured."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-m", "uvnav_tui.cli.main", *args], cwd=cwd,
                          env=env, stdout=stdout, stderr=subprocess.PIPE, text=True,
                          timeout=300, check=False)


@pytest.fixture(scope="module")
def data(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The bundled data with the thesis sample replayed (its .OUT, for assess and export)."""
    d = copy_data(tmp_path_factory.mktemp("stdout_errors") / "data")
    with open(os.devnull, "w") as null:
        assert uvnav(["replay", "920917_1.RUN"], d, null).returncode == 0
    return d


@needs_dev_full
@pytest.mark.parametrize("command", [
    ["--help"],
    ["--version"],
    ["replay", "920917_1.RUN", "--no-out"],
    ["export", "920917_1.OUT", "--csv", "x.csv"],
    ["convert", str(DATA / "nmea" / "avnav-baltic-20130731.nmea"), "--out", "c.RUN"],
    ["simulate", str(DATA / "DEMO.scenario.toml"), "--out", "s.RUN"],
], ids=lambda c: c[0])
def test_a_full_standard_output_is_one_line_and_exit_1(data: Path, command: list[str]) -> None:
    with DEV_FULL.open("w") as full:
        done = uvnav(command, data, full)
    name = "uvnav" if command[0].startswith("--") else f"uvnav {command[0]}"
    assert done.returncode == EXIT_CANNOT_WRITE, done.stderr
    assert f"{name}: standard output: cannot write: No space left on device !" in done.stderr
    assert "Traceback" not in done.stderr and "Exception ignored" not in done.stderr
    if "x.csv" in command:  # the file before the report: written whole
        assert (data / "x.csv").read_text(encoding="utf-8").count("\n") == 11


def test_assess_into_a_closed_pipe_keeps_its_plot(data: Path, tmp_path: Path) -> None:
    """``uvnav assess LOG TRUTH --svg P | head -1``: exit 141 and the plot written (it was lost:
    the report came first, and the closed pipe ended the command with exit 1)."""
    with open(os.devnull, "w") as null:
        assert uvnav(["replay", "DEMO.RUN", "--out", str(tmp_path / "S.OUT")], data,
                     null).returncode == 0
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "uvnav_tui.cli.main", "assess",
                             str(tmp_path / "S.OUT"), str(DATA / "DEMO.truth.csv"), "--svg",
                             str(tmp_path / "p.svg")], cwd=data, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert proc.stdout is not None and proc.stderr is not None
    proc.stdout.close()  # the reader gone before the first line
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=300) == EXIT_BROKEN_PIPE, err
    assert "Traceback" not in err, err
    assert "UVNAV assess plot" in (tmp_path / "p.svg").read_text(encoding="utf-8")


def test_control_characters_in_a_message_are_shown_literally(tmp_path: Path) -> None:
    """A file name with an escape sequence (or a carriage return that would overwrite the
    line) is quoted in the message as escapes, never sent to the terminal as they are."""
    name = "x\x1b[31mred\rfake.RUN"
    done = uvnav(["replay", name], tmp_path, subprocess.PIPE)
    assert done.returncode == 2
    assert "uvnav replay: x\\x1b[31mred\\x0dfake.RUN: File not found !" in done.stderr
    assert "\x1b" not in done.stderr and "\r" not in done.stderr

"""Which configuration plain ``uvnav`` uses and where the console writes: ``./data/DEMO.toml``
of the current directory before the bundled one, the configuration named on the message line,
each run's ``.OUT`` where ``--out-dir`` says, else beside the run file when that folder is
writable, else in the current directory (the bundled demo's: the current directory, never the
install tree), and the log's path said when the run starts.

Every wait is for a condition (:func:`test_console_support.wait_for`), never a fixed time."""

from __future__ import annotations

from pathlib import Path

import pytest
from test_console_support import drive, make_app, start, wait_for
from textual.pilot import Pilot

from tests.paths import DATA, copy_data
from uvnav_tui import run_control
from uvnav_tui.cli import console


def test_plain_uvnav_uses_the_data_folder_of_the_current_directory(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """In a directory with its own ``data/DEMO.toml``, that one; elsewhere the bundled one.
    Before, the bundled one won even when the current directory had its own."""
    own = copy_data(tmp_path / "mine" / "data")
    monkeypatch.chdir(tmp_path / "mine")
    assert console.default_config_path() == (own / "DEMO.toml").resolve()
    monkeypatch.chdir(tmp_path)
    assert console.default_config_path() == (DATA / "DEMO.toml").resolve()


def test_out_dir_rules(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``--out-dir`` wins; the bundled demo used from another directory writes in that
    directory; otherwise beside the run file if its folder is writable, else the current
    directory."""
    monkeypatch.chdir(tmp_path)
    bundled = console.BUNDLED_DATA / "DEMO.toml"
    assert console.console_out_dir(bundled, "logs") == Path("logs")
    assert console.console_out_dir(bundled, None) == Path.cwd()
    assert console.console_out_dir(tmp_path / "data" / "DEMO.toml", None) is None
    folder = tmp_path / "runs"
    folder.mkdir()
    assert run_control.out_folder(folder, None) == folder
    assert run_control.out_folder(folder, tmp_path / "o") == tmp_path / "o"
    monkeypatch.setattr(run_control.os, "access", lambda path, mode: False)  # read-only
    assert run_control.out_folder(folder, None) == Path.cwd()


def test_console_names_its_configuration_and_writes_the_log_where_told(
        data_dir: Path, tmp_path: Path) -> None:
    """The message line names the configuration at start and the run's log when it starts;
    the ``.OUT`` is in ``out_dir``.  Before, neither was said and the log always went beside
    the run file (into the install tree for the bundled demo)."""
    out = tmp_path / "out"
    out.mkdir()
    config = data_dir / "920917_1.toml"
    app = make_app(data_dir, config_path=config, out_dir=out, show_init=True)

    async def script(pilot: Pilot[None]) -> None:
        await wait_for(pilot, lambda: any(e.text == f"Configuration {config}"
                                          for e in app.message_log.since(0)[1]),
                       "the configuration named")
        await start(pilot, 1)
        assert app.control is not None
        log = app.control.session.out_path
        assert log == out / "920917_1.OUT"
        assert any(e.text == f"Run log {log}" for e in app.message_log.since(0)[1])
        assert not (data_dir / "920917_1.OUT").exists()

    drive(app, script)

"""The run-file field of Parameter Initialization takes any path: a ``.RUN`` file or an NMEA
0183 log anywhere (absolute, ``~/…``, relative to the run directory or the current directory),
or a live URL; Tab completes a path and Ctrl+O opens a folder tree (Textual's
``DirectoryTree``) to pick the file.

Every wait is for a condition (:func:`test_console_support.wait_for`), never a fixed time."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from test_console_support import drive, make_app, start, wait_for
from textual.pilot import Pilot

from tests.nmea_lines import voyage
from tests.paths import DATA
from uvnav_tui.dialogs.init_dialog import InitDialog
from uvnav_tui.widgets.path_completion import complete_path
from uvnav_tui.widgets.validated_field import ValidatedField

MARKERMEER = "nmea/avnav-markermeer-20160815.nmea"
"""A real yacht's log bundled under ``data/`` (docs/NMEA.md)."""


def nmea_log(path: Path) -> Path:
    """A short NMEA 0183 log at ``path`` (a simulated voyage, every sentence)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(voyage(10, damage=False)) + "\n", encoding="ascii")
    return path


async def init_dialog(pilot: Pilot[None]) -> InitDialog:
    """The start-up dialog, mounted."""
    app = pilot.app
    await wait_for(pilot, lambda: isinstance(app.screen, InitDialog) and app.screen.is_mounted,
                   "Parameter Initialization")
    return app.screen  # type: ignore[return-value]


async def type_run_file(pilot: Pilot[None], text: str) -> ValidatedField:
    """Empty the run-file field and type ``text`` into it, key by key."""
    field = (await init_dialog(pilot)).query_one("#init-run", ValidatedField)
    field.focus_input()
    await pilot.pause()
    await pilot.press("end", "ctrl+u", *[("space" if c == " " else c) for c in text])
    return field


@pytest.mark.parametrize("where", ["relative", "absolute", "home"])
def test_run_file_field_takes_an_nmea_log_anywhere(data_dir: Path, tmp_path: Path,
                                                   where: str,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """``nmea/avnav-markermeer-20160815.nmea`` (under the run directory), an absolute path and
    ``~/…`` start the run on that log.  Before: ``Wrong file name !`` for all three (only a
    log beside the .RUN file, named without a folder, was taken)."""
    shutil.copytree(DATA / "nmea", data_dir / "nmea")
    home = tmp_path / "home"
    monkeypatch.setenv("HOME", str(home))
    log = nmea_log(tmp_path / "logs" / "trip.nmea") if where == "absolute" \
        else nmea_log(home / "trip.nmea") if where == "home" else data_dir / MARKERMEER
    typed = {"relative": MARKERMEER, "absolute": str(log), "home": "~/trip.nmea"}[where]
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        field = await type_run_file(pilot, typed)
        await wait_for(pilot, lambda: field.text == typed, "the path typed")
        assert field.error is None, field.error
        await start(pilot, 2)
        assert app.control is not None
        assert app.control.session.config.run_path == log.resolve()
        assert app.control.session.nmea_stats is not None

    drive(app, script)


@pytest.mark.parametrize(("typed", "message"), [
    ("notes.txt", "Neither a .RUN file nor an NMEA 0183 log !"),
    ("nmea", "A folder, not a file (Ctrl+O: pick a file) !"),
    ("nmea/none.nmea", "File not found !"),
    ("bad name!", "Wrong file name !"),
])
def test_run_file_field_says_what_is_wrong(data_dir: Path, typed: str, message: str) -> None:
    """A file that is neither kind, a folder, a missing path, an impossible run name: each
    says so under the field, and the text stays."""
    (data_dir / "notes.txt").write_text("not a log\n", encoding="ascii")
    (data_dir / "nmea").mkdir()
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        field = await type_run_file(pilot, typed)
        await wait_for(pilot, lambda: field.text == typed, "the text typed")
        assert field.error == message and field.text == typed

    drive(app, script)


def test_tab_completes_a_path(data_dir: Path) -> None:
    """``nmea/avnav-m`` Tab → ``nmea/avnav-markermeer-20160815.`` (the .nmea and .toml share
    it), ``n`` Tab → the log; a bare name (``DEM``) is the thesis' field: Tab moves on."""
    shutil.copytree(DATA / "nmea", data_dir / "nmea")
    assert complete_path("nmea/avnav-m", [data_dir]) == "nmea/avnav-markermeer-20160815."
    assert complete_path("nme", [data_dir]) is None  # not a path: no completion
    assert complete_path(str(data_dir / "nm"), [Path("/nonexistent")]) == f"{data_dir}/nmea/"
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        field = await type_run_file(pilot, "nmea/avnav-m")
        await pilot.press("tab")
        await wait_for(pilot, lambda: field.text == "nmea/avnav-markermeer-20160815.",
                       "the common part completed")
        await pilot.press("n", "tab")
        await wait_for(pilot, lambda: field.text == MARKERMEER, "the log completed")
        assert field.input.has_focus
        await pilot.press("tab")  # nothing more to complete: on to the Start button
        await wait_for(pilot, lambda: not field.input.has_focus, "Tab moving on")

    drive(app, script)


def test_ctrl_o_picks_the_run_file_in_a_folder_tree(data_dir: Path, tmp_path: Path) -> None:
    """Ctrl+O opens the folder tree at the run directory; Backspace goes up; Enter on a file
    puts its path in the field, and the run starts on it."""
    from textual.widgets import DirectoryTree

    from uvnav_tui.screens.file_picker import FilePicker

    log = nmea_log(data_dir.parent / "trip.nmea")
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await init_dialog(pilot)
        await pilot.press("ctrl+o")
        await wait_for(pilot, lambda: isinstance(app.screen, FilePicker)
                       and app.screen.is_mounted, "the file picker")
        picker = app.screen
        assert picker.folder == data_dir.resolve()
        await pilot.press("backspace")
        tree = picker.query_one(DirectoryTree)

        def line_of(name: str) -> int | None:
            for line in range(tree.last_line + 1):
                node = tree.get_node_at_line(line)
                if node is not None and node.data is not None and node.data.path.name == name:
                    return line
            return None

        await wait_for(pilot, lambda: line_of("trip.nmea") is not None, "the parent listed")
        tree.cursor_line = line_of("trip.nmea")  # type: ignore[assignment]
        await pilot.press("enter")
        await wait_for(pilot, lambda: isinstance(app.screen, InitDialog), "back in the dialog")
        field = app.screen.query_one("#init-run", ValidatedField)
        await wait_for(pilot, lambda: field.text == str(log.resolve()), "the path in the field")
        assert field.error is None
        await start(pilot, 1)
        assert app.control is not None and app.control.session.config.run_path == log.resolve()

    drive(app, script)


def test_key_lines_of_the_run_file_keep_quit_at_80_columns() -> None:
    """Parameter Initialization names Ctrl+O after Ctrl+Q; the picker its own keys; both keep
    ``Ctrl+Q Quit`` at 80 columns."""
    from uvnav_tui.keys_help import key_line
    from uvnav_tui.screens.file_picker import PICKER_KEYS

    assert "Ctrl+Q Quit" in key_line(InitDialog.KEY_HINTS, 80)
    assert "Ctrl+O Open file" in key_line(InitDialog.KEY_HINTS, 100)
    assert "Ctrl+Q Quit" in key_line(PICKER_KEYS, 80)

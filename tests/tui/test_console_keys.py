"""Pilot tests of the console's keyboard habits (issue 16): keys typed at speed during a fast
run, help (F1, ?), go to page by number, the command palette's pages, the context key line,
menus over the Predict/Smoothing tables and their hardcopies, run-state feedback, Ctrl+C.

Every wait is for a condition (:func:`test_console_support.wait_for`), never a fixed time."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest
from test_console_support import (
    drive,
    make_app,
    start,
    text_of,
    wait_for,
)
from textual import events
from textual.pilot import Pilot

from uvnav_tui import keys_help as kh
from uvnav_tui.app import UVNAVApp
from uvnav_tui.cli.main import main as cli_main
from uvnav_tui.dialogs.confirm_dialog import ConfirmDialog
from uvnav_tui.pages.registry import DEV_PAGES_FROM, page_titles
from uvnav_tui.screens.console_screen import ConsoleScreen
from uvnav_tui.screens.help_screen import HelpScreen
from uvnav_tui.screens.table_screen import TableScreen
from uvnav_tui.widgets.pulldown import PulldownScreen

SIZE = (100, 30)




def type_at_once(app: UVNAVApp, *keys: str) -> None:
    """Queue ``keys`` in the app's input queue in one go, as a fast typist or a loaded terminal
    delivers them: no key waits for the previous one to be handled."""
    for key in keys:
        char = key if len(key) == 1 else None
        app.post_message(events.Key(key, char))


# ------------------------------------------------------------------------------------------
# Defect 10: keys typed at speed during a fast run


def repeat_demo(data_dir: Path, times: int) -> None:
    """``DEMO.RUN`` of ``data_dir`` replaced by the 2 h demo ``times`` times over, each copy
    2 h later than the one before (10:00–11:59:59, 12:00–13:59:59, …): a longer fast run. The
    ship jumps back ~6.5 km at each seam; the run goes on (the fixes there are gated)."""
    path = data_dir / "DEMO.RUN"
    lines = path.read_text(encoding="ascii").splitlines()
    out = []
    for k in range(times):
        for line in lines:
            date, hms, rest = line.split(" ", 2)
            out.append(f"{date} {int(hms[:2]) + 2 * k:02d}{hms[2:]} {rest}")
    path.write_text("\n".join(out) + "\n", encoding="ascii")


def test_keys_typed_at_speed_during_a_fast_run_are_not_lost(data_dir: Path) -> None:
    """Alt+T then L queued together while the demo runs at pace fast: Statistics ▸ LSE (Pg 631)
    is shown and no menu stays open.  Before the fix the L went to the console screen (the menu
    was opened later, from the screen's own queue) and was lost; then Alt+K F Esc (Filtering
    dialog opened and cancelled at once) and 6 4 2 (go to the plot) likewise.

    LOP rejection is "N" here: with the demo's "A", the first flagged w-test (cycle ~1000) asks
    "Discard LOP …?", and a run fast enough to get there during the test (a quiet machine, or
    the engine after issue 14) left that question open instead of the pages this test types.
    The demo is played three times over (:func:`repeat_demo`): once the console's session was
    made faster (2026-12-04: ~4500 cycles/s headless) the 2 h demo ended within the test, and
    "the run to go on" waited for a run that was over."""
    repeat_demo(data_dir, 3)
    app = make_app(data_dir, "DEMO", hold=False)
    app.base_config = replace(app.base_config, lsq=replace(app.base_config.lsq, lop_reject="N"))

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot)
        run = app.control
        assert run is not None
        await wait_for(pilot, lambda: run.cycles >= 20, "20 cycles")
        for _ in range(3):
            type_at_once(app, "alt+t", "l")
            await wait_for(pilot, lambda: app.page == 631 and isinstance(app.screen,
                                                                          ConsoleScreen),
                           "Pg 631 with no menu open")
            before = run.cycles
            await wait_for(pilot, lambda b=before: run.cycles > b, "the run to go on")
            type_at_once(app, "alt+k", "f", "escape", "6", "4", "2")
            await wait_for(pilot, lambda: app.page == 642 and isinstance(app.screen,
                                                                          ConsoleScreen),
                           "the Filtering dialog opened and closed by Esc, then Pg 642")
            type_at_once(app, "alt+t", "m")
            await wait_for(pilot, lambda: app.page == 100 and isinstance(app.screen,
                                                                          ConsoleScreen),
                           "Pg 100")
        await wait_for(pilot, lambda: run.state_word == "Working...", "the run to resume")
        assert not run.eof  # every key above was typed while the run was going
        app.actions.run_suspend()

    drive(app, script)


# ------------------------------------------------------------------------------------------
# Help and habits


def test_f1_and_question_mark_open_help_and_esc_closes_it(data_dir: Path) -> None:
    """F1 and ? show the help with the menus, hot-keys, page map (611 … 853) and dialog keys;
    Esc (and F1 again) close it."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        for opener, closer in (("f1", "escape"), ("question_mark", "f1")):
            await pilot.press(opener)
            await wait_for(pilot, lambda: isinstance(app.screen, HelpScreen), "help")
            text = str(app.screen.query_one("#help-text").render())
            for number, title in page_titles().items():
                assert f"Pg {number}  {title}" in text
            for needle in ("Alt+T  Statistics", "[L] LSE", "Tab / Shift+Tab", "Ctrl+Q",
                           "PgUp / PgDn", "nnn (three digits)"):
                assert needle in text, needle
            await pilot.press(closer)
            await wait_for(pilot, lambda: isinstance(app.screen, ConsoleScreen), "help closed")

    drive(app, script)


def test_help_from_the_palette_is_closable(data_dir: Path) -> None:
    """The palette has Help instead of Textual's Keys panel (which could not be closed), and
    every page by title (developer pages only in developer mode)."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        titles = [c.title for c in app.get_system_commands(app.screen)]
        assert "Keys" not in titles and "Help" in titles
        for number, title in page_titles().items():
            assert (f"Pg {number} {title}" in titles) == (number < DEV_PAGES_FROM)
        app.actions.set_dev_mode(True)
        titles = [c.title for c in app.get_system_commands(app.screen)]
        assert all(f"Pg {n} {t}" in titles for n, t in page_titles().items())
        help_cmd = next(c for c in app.get_system_commands(app.screen) if c.title == "Help")
        help_cmd.callback()
        await wait_for(pilot, lambda: isinstance(app.screen, HelpScreen), "help")
        await pilot.press("escape")
        await wait_for(pilot, lambda: isinstance(app.screen, ConsoleScreen), "help closed")

    drive(app, script)


def test_go_to_page_by_typing_its_number(data_dir: Path) -> None:
    """6 3 1 shows Pg 631; the digits typed so far show on the key line; Esc forgets them;
    Backspace erases one; an unknown number says so."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 2)
        await pilot.press("6", "3")
        assert "Go to page 63_" in text_of(app)
        await pilot.press("1")
        assert app.page == 631 and "Pg 631" in text_of(app)
        await pilot.press("6", "escape", "6", "4", "backspace", "5")
        assert app.page == 631
        await pilot.press("0")
        assert app.page == 650
        await pilot.press("9", "9", "9")
        assert app.page == 650 and "No page 999" in app.message
        await pilot.press("8", "1", "0")
        assert app.page == 650 and "developer page" in app.message

    drive(app, script)


def test_key_line_shows_the_keys_of_the_context(data_dir: Path) -> None:
    """The bottom line: page keys (sub-pages where there are some) with Ctrl+Q, menu keys in a
    menu, dialog keys in a dialog, Y/N in a question."""
    app = make_app(data_dir)

    def bottom() -> str:
        return text_of(app).rstrip("\n").splitlines()[-1]

    async def script(pilot: Pilot[None]) -> None:
        await pilot.pause()
        assert "Enter OK" in bottom() and "Esc Cancel" in bottom()
        await start(pilot, 2)
        assert "Ctrl+Q Quit" in bottom() and "F1 Help" in bottom()
        assert "PgUp/PgDn" not in bottom()
        await pilot.press("6", "4", "1")
        await wait_for(pilot, lambda: "PgUp/PgDn Sub-page" in bottom(), "sub-page keys")
        await pilot.press("alt+t")
        await wait_for(pilot, lambda: "←→ Menus" in bottom(), "menu keys")
        assert "Ctrl+Q Quit" in bottom()
        await pilot.press("escape", "ctrl+q")
        await wait_for(pilot, lambda: "Y Yes" in bottom(), "question keys")
        await pilot.press("n")

    drive(app, script)


def test_left_right_move_between_menus_and_open_sub_menus(data_dir: Path) -> None:
    """→ on an item without sub-menu goes to the next bar menu, ← to the previous; Enter or
    → on an item with ▸ opens its sub-menu, ← closes it."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        await pilot.press("alt+q", "right")
        menu = app.screen
        assert isinstance(menu, PulldownScreen) and menu.menu_index == 1  # Edit
        await pilot.press("right")
        assert menu.menu_index == 2 and menu.path == [0]  # Setup, on Params ▸
        await pilot.press("right")
        assert menu.path == [0, 0]  # Params opened
        await pilot.press("left")
        assert menu.path == [0]
        await pilot.press("enter")
        assert menu.path == [0, 0]
        await pilot.press("escape", "left")
        assert menu.menu_index == 1
        await pilot.press("escape")
        await wait_for(pilot, lambda: isinstance(app.screen, ConsoleScreen), "menu closed")

    drive(app, script)


# ------------------------------------------------------------------------------------------
# Defect 12: feedback, the run-state word, Ctrl+C, --help


def test_continue_while_working_and_suspend_while_suspended_say_so(data_dir: Path) -> None:
    """Run ▸ Continue on a working run and Run ▸ Suspend on a suspended run are not silent."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 2)
        await pilot.press("alt+r", "c")
        assert "already working" in app.message
        await pilot.press("alt+r", "s")
        assert app.state_word == "Suspended..."
        await pilot.press("alt+r", "s")
        assert "already suspended" in app.message
        assert "already suspended" in text_of(app)

    drive(app, script)


@pytest.mark.parametrize("hotkey", ["alt+q", "alt+e", "alt+s", "alt+r"])
def test_pulldowns_leave_the_run_state_word_visible(data_dir: Path, hotkey: str) -> None:
    """With a menu open, line 2 still starts with the run-state word (the boxes hang below it);
    before, the Quit and Edit boxes covered ``Interrupted...``."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        await pilot.press(hotkey)
        assert isinstance(app.screen, PulldownScreen)
        await pilot.pause()
        assert text_of(app).splitlines()[1].startswith("Interrupted...  Time ")

    drive(app, script)


def test_ctrl_c_asks_to_quit(data_dir: Path) -> None:
    """Ctrl+C asks "Leave UVNAV?" like Ctrl+Q and Quit ▸ Quit (No carries on)."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        await pilot.press("ctrl+c")
        assert isinstance(app.screen, ConfirmDialog) and app.screen.title_text == "Quit"
        await pilot.press("n")
        assert isinstance(app.screen, ConsoleScreen)
        await pilot.press("ctrl+c", "y")
        await wait_for(pilot, lambda: app.control is None, "the run to stop")

    drive(app, script)


def test_uvnav_help_lists_every_console_option(capsys: pytest.CaptureFixture[str]) -> None:
    """``uvnav --help`` names --config, --dev and --hardcopy-dir."""
    assert cli_main(["--help"]) == 0
    out = capsys.readouterr().out
    for option in ("--config", "--dev", "--hardcopy-dir"):
        assert option in out, option


# ------------------------------------------------------------------------------------------
# Defect 9: menus and hardcopy over the Predict and Smoothing tables


@pytest.mark.parametrize(("keys", "name"), [
    (("alt+k", "p", "enter"), "Predict"),
    (("alt+k", "s"), "Smoothing"),
])
def test_menus_and_hardcopy_over_the_tables(data_dir: Path, keys: tuple[str, ...],
                                            name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Over Kalman ▸ Predict./Smoothing: F10 opens the menu (Esc closes it, the table stays),
    Alt+E H saves the table as ``UVNAV_<run>_<time>_<name>.svg/.txt`` with the table's
    rows in the text, and the message line under the table says so; a page chosen from the
    menu replaces the table."""
    monkeypatch.chdir(data_dir)
    app = make_app(data_dir, hardcopy_dir=Path("hc"))  # a short path: a one-line message

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 6)
        await pilot.press(*keys)
        await wait_for(pilot, lambda: isinstance(app.screen, TableScreen), f"the {name} table")
        table = app.screen
        await pilot.press("f10")
        assert isinstance(app.screen, PulldownScreen)
        await pilot.press("escape")
        assert app.screen is table
        await pilot.press("alt+e", "h")
        await wait_for(pilot, lambda: len(app.hardcopies) == 1, "the hardcopy")
        svg, txt = app.hardcopies[0]
        assert svg.name.endswith(f"_{name}.svg") and svg.exists()
        assert txt.name.endswith(f"_{name}.txt")
        text = txt.read_text(encoding="utf-8")
        assert f"Kalman ▸ {name}" in text and "Lat" in text
        assert app.screen is table
        await pilot.pause()
        assert f"Hardcopy {svg.name}" in text_of(app)  # the message line shows under the table
        await pilot.press("alt+t", "l")
        await wait_for(pilot, lambda: isinstance(app.screen, ConsoleScreen)
                       and app.page == 631, "Pg 631 instead of the table")

    drive(app, script)


@pytest.mark.parametrize("hints", [
    kh.console_hints(641, True), kh.MENU_KEYS, kh.DIALOG_KEYS, kh.CONFIRM_KEYS, kh.TABLE_KEYS,
    kh.HELP_KEYS, kh.PALETTE_KEYS,
], ids=["page", "menu", "dialog", "confirm", "table", "help", "palette"])
def test_key_line_keeps_quit_at_80_columns(hints: list[kh.KeyHint]) -> None:
    """Every context's key line names Ctrl+Q even at 80 columns, and never cuts a hint."""
    line = kh.key_line(hints, 80)
    assert "Ctrl+Q Quit" in line and len(line) <= 80
    assert all(f" {key} {what}" in line for key, what in hints[: line.count("  ") + 1])

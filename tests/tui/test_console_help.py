"""F1 everywhere, in context: over a page, in Parameter Initialization and every dialog (what
its fields mean and accept, and which one the cursor is in), in a menu (the highlighted item),
over the Predict table; ``?`` where it types nothing.  The help explains MPP, LSE, ``999.99``,
how to open an NMEA log or a live source and where the files go, and is wrapped to the screen
(whole at 80×24).

Every wait is for a condition (:func:`test_console_support.wait_for`), never a fixed time."""

from __future__ import annotations

from pathlib import Path

import pytest
from rich.cells import cell_len
from test_console_support import drive, make_app, start, wait_for
from textual.pilot import Pilot
from textual.widgets import Static

from uvnav_tui import keys_help as kh
from uvnav_tui.dialogs.dialog import Dialog
from uvnav_tui.dialogs.init_dialog import InitDialog
from uvnav_tui.screens.console_screen import ConsoleScreen
from uvnav_tui.screens.help_screen import HelpScreen
from uvnav_tui.screens.table_screen import TableScreen
from uvnav_tui.widgets.pulldown import PulldownScreen

HELP_S = 20.0
"""Seconds the help may take to open on the loaded machine (it takes milliseconds)."""


def shown_help(app: object) -> str:
    """The text of the help screen on top."""
    return str(app.screen.query_one("#help-text", Static).render())  # type: ignore[attr-defined]


async def open_help(pilot: Pilot[None], key: str = "f1") -> str:
    """Press ``key`` and return the help's text once it is shown."""
    app = pilot.app
    await pilot.press(key)
    await wait_for(pilot, lambda: isinstance(app.screen, HelpScreen) and app.screen.is_mounted,
                   f"the help after {key}", HELP_S)
    await pilot.pause()
    return " ".join(shown_help(app).split())


async def close_help(pilot: Pilot[None]) -> None:
    """Esc closes the help, back to where it was opened."""
    await pilot.press("escape")
    await wait_for(pilot, lambda: not isinstance(pilot.app.screen, HelpScreen), "help closed")


def test_f1_in_parameter_initialization_explains_its_fields(data_dir: Path) -> None:
    """F1 in the start-up dialog: its title, the field the cursor is in and what each field
    accepts, including the run file's paths and URLs.  Before, F1 did nothing there."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await wait_for(pilot, lambda: isinstance(app.screen, InitDialog)
                       and app.screen.is_mounted, "Parameter Initialization")
        await pilot.press("tab")
        text = await open_help(pilot)
        assert text.startswith("Here: Parameter Initialization")
        assert "The cursor is in: DR position" in text
        for needle in ("Depth (m): 0 to 1000", "NMEA 0183 log", "udp://0.0.0.0:10110",
                       "Ctrl+O opens a file picker", "52 50 00 N 004 30 00 E",
                       "no exponent such as 1e3"):
            assert needle in text, needle
        await close_help(pilot)
        assert isinstance(app.screen, InitDialog)
        assert app.screen.query_one("#init-dr-input").has_focus  # the cursor where it was

    drive(app, script)


@pytest.mark.parametrize(("keys", "needles"), [
    (("alt+o", "d"), ("Obs ▸ Distance", "The cursor is in: Station name",
                      "Distance (nm): nautical miles (1 nm = 1852 m)")),
    (("alt+k", "p"), ("Kalman ▸ Predict.", "Time interval (min): more than 0, at most 1440",
                      "Step size (s): at least 1")),
    (("alt+s", "p", "c"), ("Setup ▸ Params ▸ Current", "the set, towards which")),
    (("alt+s", "y", "d"), ("Setup ▸ Systems ▸ Decca", "B20")),
    (("alt+d", "p"), ("Demo ▸ Parameters", "[demo] pace")),
])
def test_f1_in_a_dialog_explains_its_fields(data_dir: Path, keys: tuple[str, ...],
                                            needles: tuple[str, ...]) -> None:
    """F1 in a dialog opened from the menus: its own help first (then the general help), and
    Esc returns to the dialog with what was typed.  Before, F1 did nothing in dialogs."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 2)
        await pilot.press(*keys)
        await wait_for(pilot, lambda: isinstance(app.screen, Dialog) and app.screen.is_mounted,
                       "the dialog", HELP_S)
        dialog = app.screen
        text = await open_help(pilot)
        for needle in needles:
            assert needle in text, needle
        assert "Keys over a page" in text  # the general help follows
        await close_help(pilot)
        assert app.screen is dialog

    drive(app, script)


def test_f1_and_question_mark_in_a_menu_explain_the_item(data_dir: Path) -> None:
    """In a menu, F1 and ? explain the highlighted item (its path, what it does, whether it
    needs a run).  Before, both did nothing in menus."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        for key in ("f1", "question_mark"):
            await pilot.press("alt+k", "down")
            await wait_for(pilot, lambda: isinstance(app.screen, PulldownScreen), "the menu")
            text = await open_help(pilot, key)
            assert "Here: Menu: Kalman ▸ Predict." in text
            assert "Predict position and ellipse over a time interval" in text
            await close_help(pilot)
            assert isinstance(app.screen, PulldownScreen)
            await pilot.press("escape")
            await wait_for(pilot, lambda: isinstance(app.screen, ConsoleScreen), "menu closed")

    drive(app, script)


def test_f1_over_the_predict_table_explains_its_columns(data_dir: Path) -> None:
    """Over the Predict table F1 and ? explain the columns and 999.99.  Before: nothing."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 6)
        await pilot.press("alt+k", "p", "enter")
        await wait_for(pilot, lambda: isinstance(app.screen, TableScreen), "the table", HELP_S)
        for key in ("f1", "question_mark"):
            text = await open_help(pilot, key)
            assert "Here: Kalman ▸ Predict." in text
            assert "a, b the error ellipse's semi-axes (m)" in text and "999.99" in text
            await close_help(pilot)
            assert isinstance(app.screen, TableScreen)

    drive(app, script)


def test_help_topics() -> None:
    """The help explains MPP, LSE, 999.99, opening an NMEA log or a live source and where the
    .OUT and hardcopies go."""
    text = " ".join(kh.help_text().split())
    titles = [title for title, _text in kh.TOPICS]
    assert titles == ["MPP", "LSE", "999.99", "Opening an NMEA log or a live source",
                      "Where files go"]
    for needle in ("Most Probable Position", "Least-Squares Estimate", "no redundancy",
                   "udp://0.0.0.0:10110", "Ctrl+O opens a file picker", "--out-dir DIR",
                   "UVNAV_<run>_<time>_Pg<nnn>.svg", "--hardcopy-dir DIR"):
        assert needle in text, needle


def test_help_is_wrapped_to_80_columns(data_dir: Path) -> None:
    """At 80×24 every line of the help fits its frame (before, the menu list and page map ran
    off the right edge with no way to scroll to them); wrapped lines keep every word."""
    assert all(cell_len(line) <= 74 for line in kh.wrap_help(kh.help_text(), 74).splitlines())
    assert kh.wrap_help(kh.help_text(), 74).split() == kh.help_text().split()
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        await open_help(pilot)
        body = app.screen.query_one("#help-text", Static)
        lines = str(body.render()).splitlines()
        assert max(cell_len(line) for line in lines) <= body.content_size.width
        assert app.screen.query_one("#help-body").max_scroll_x == 0

    drive(app, script, size=(80, 24))

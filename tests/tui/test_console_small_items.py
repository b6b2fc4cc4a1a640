"""What a navigator notices: the text hardcopy of a page is the whole page, Pg 710 wraps its
meanings instead of cutting them, an Obs message has its unit and the menus' ``▸``, Predict and
Distance take the same numbers, and a dialog on a terminal too small for it says so instead of
cutting off its buttons.

Every wait is for a condition (:func:`test_console_support.wait_for`), never a fixed time."""

from __future__ import annotations

from pathlib import Path

import pytest
from test_console_support import drive, make_app, start, text_of, wait_for
from textual.pilot import Pilot
from textual.widgets import Static

from uvnav_tui.dialogs.dialog import Dialog
from uvnav_tui.dialogs.obs_dialog import ObsDialog
from uvnav_tui.pages.page_frame import PageFrame
from uvnav_tui.pages.page_text import TextPage
from uvnav_tui.screens.console_screen import ConsoleScreen
from uvnav_tui.widgets.validated_field import ValidatedField

SCROLLBAR_GLYPHS = set("▁▂▃▄▅▆▇█▉▊▋▌▍▎▏")


async def goto(pilot: Pilot[None], number: int) -> None:
    """Type the page number and wait for the page."""
    await pilot.press(*str(number))
    await wait_for(pilot, lambda: pilot.app.page == number  # type: ignore[attr-defined]
                   and isinstance(pilot.app.screen, ConsoleScreen), f"Pg {number}")
    await pilot.pause()


async def hardcopy(pilot: Pilot[None]) -> str:
    """Edit ▸ Hardcopy; the text file's content."""
    app = pilot.app
    before = len(app.hardcopies)  # type: ignore[attr-defined]
    await pilot.press("alt+e", "h")
    await wait_for(pilot, lambda: len(app.hardcopies) > before, "the hardcopy")  # type: ignore
    return app.hardcopies[-1][1].read_text(encoding="utf-8")  # type: ignore[attr-defined]


@pytest.mark.parametrize("number", [631, 650])
def test_hardcopy_of_a_text_page_is_the_whole_page(data_dir: Path, number: int) -> None:
    """At 80×24 Pg 631 and Pg 650 are wider and taller than the screen: the text hardcopy holds
    every line of the page in full, a heading with the page and the run's own state, and the
    status column; no scroll bar, no state line of the moment (``Interrupted...``: the menu
    was open).  Before: a screen dump cut at 80 columns."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 4)
        await goto(pilot, number)
        body = app.screen.query_one(PageFrame).body
        assert isinstance(body, TextPage)
        lines = [ln.rstrip() for ln in body.text.splitlines() if ln.strip()]
        assert max(len(ln) for ln in lines) > 62 or len(lines) > 18  # larger than the screen
        text = await hardcopy(pilot)
        kept = text.splitlines()
        assert kept[0].startswith(f"UVNAV  Pg {number} ") and "Time 08:35:4" in kept[0]
        assert "Working..." in kept[0] and "Interrupted..." not in text
        for line in lines:
            assert line in kept, line
        assert "Systems:" in text  # the status column
        assert not SCROLLBAR_GLYPHS & set(text)

    drive(app, script, size=(80, 24))


def test_pg_710_never_cuts_a_meaning(data_dir: Path) -> None:
    """Pg 710 at 80×24 shows each meaning whole or not at all (then says where to read them:
    F1 lists them, the hardcopy has them); at 120×40 they are wrapped under their column.
    Before, ``half-width of the position plo`` was cut at the edge."""
    app = make_app(data_dir, "DEMO")
    meaning = "half-width of the position plot (Pg 642), centred on the MPP"

    def page() -> str:
        return " ".join(str(app.screen.query_one(PageFrame).body.render()).split())

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 2)
        await goto(pilot, 710)
        await wait_for(pilot, lambda: "Plot scale" in page(), "Pg 710 drawn")
        shown = page()
        assert "half-width" not in shown and "(what each means: F1" in shown
        assert meaning in " ".join((await hardcopy(pilot)).split())
        await pilot.press("f1")
        await wait_for(pilot, lambda: not isinstance(app.screen, ConsoleScreen), "help")
        assert meaning in " ".join(str(app.screen.query_one("#help-text").render()).split())
        await pilot.press("escape")
        await wait_for(pilot, lambda: isinstance(app.screen, ConsoleScreen), "help closed")
        await pilot.resize_terminal(120, 40)
        await wait_for(pilot, lambda: meaning in page(), "the meanings wrapped at 120×40")

    drive(app, script, size=(80, 24))


def test_obs_message_has_its_unit_and_the_menus_arrow(data_dir: Path) -> None:
    """``Obs ▸ distance Heiloo 16.70 nm (radar)``: the distance in the nautical miles it was
    typed in, and ``▸`` as in the menus; a bearing in degrees; a Setup command likewise.
    Before: ``Obs > distance Heiloo 30928.40 (radar)`` (metres, no unit).  The .OUT keeps its
    ASCII ``>``."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 2)
        for keys, value in ((("alt+o", "d"), "16.7"), (("alt+o", "b"), "123.4")):
            await pilot.press(*keys)
            await wait_for(pilot, lambda: isinstance(app.screen, ObsDialog)
                           and app.screen.is_mounted, "the Obs dialog")
            kind = "obs-distance" if keys[1] == "d" else "obs-bearing"
            position = ["space" if c == " " else c for c in "52 35 N 4 40 E"]
            await pilot.press(*"Heiloo", "tab", *position, "tab")
            await pilot.press(*value)
            await wait_for(pilot, lambda k=kind, v=value: app.screen.query_one(
                f"#{k}", ValidatedField).text == v, "typed")
            await pilot.press("enter")
            await wait_for(pilot, lambda: isinstance(app.screen, ConsoleScreen), "applied")
        assert app.message.startswith("Obs ▸ bearing Heiloo 123.40° (compass repeater)")
        texts = [e.text for e in app.message_log.since(0)[1]]
        assert any(t.startswith("Obs ▸ distance Heiloo 16.70 nm (radar)") for t in texts)
        assert not any(" > " in t for t in texts)
        await pilot.press("alt+s", "p", "c", "tab", "ctrl+u", "4", "5", "enter")
        await wait_for(pilot, lambda: app.message.startswith("Setup ▸ Params ▸ Current"),
                       "Setup ▸ Params ▸ Current applied")

    drive(app, script)


@pytest.mark.parametrize(("keys", "field_id", "message"), [
    (("alt+k", "p"), "predict-interval", "Wrong time interval input !"),
    (("alt+o", "d"), "obs-distance", "Wrong distance input !"),
])
def test_predict_and_distance_take_the_same_numbers(data_dir: Path, keys: tuple[str, ...],
                                                    field_id: str, message: str) -> None:
    """``1e3`` is refused by Predict's interval as by Distance (plain decimals in every
    navigation dialog, as the help says); ``1000`` is taken by both.  Before, Predict took
    ``1e3`` (Python's float()) and Distance refused it."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 2)
        await pilot.press(*keys)
        await wait_for(pilot, lambda: isinstance(app.screen, Dialog) and app.screen.is_mounted,
                       "the dialog")
        field = app.screen.query_one(f"#{field_id}", ValidatedField)
        field.focus_input()
        for text, error in (("1e3", message), ("1000", None)):
            await pilot.press("end", "ctrl+u", *text)
            await wait_for(pilot, lambda t=text: field.text == t, f"{text} typed")
            assert field.error == error, (text, field.error)

    drive(app, script)


def test_a_dialog_too_large_for_the_terminal_says_so(data_dir: Path) -> None:
    """At 40×12 Obs ▸ Radar says the terminal is too small and what it needs instead of
    showing a box whose buttons are off the edge; what is typed meanwhile is kept, and at
    80×24 the whole box is back with its buttons on the screen."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 2)
        await pilot.press("alt+o", "r")
        await wait_for(pilot, lambda: isinstance(app.screen, ObsDialog)
                       and app.screen.is_mounted, "Obs ▸ Radar")
        dialog = app.screen
        note = dialog.query_one("#dialog-too-small", Static)
        await wait_for(pilot, lambda: note.display, "the too-small note")

        def shown() -> str:  # the screen as drawn: the note is on it a frame after display
            return " ".join(text_of(app).replace("│", " ").split())

        await wait_for(pilot, lambda: "The terminal is too small" in shown(), "the note drawn")
        assert "The terminal is too small for Obs ▸ Radar: 40×12, it needs 76×" in shown()
        await pilot.press(*"ABC")
        await pilot.resize_terminal(80, 24)
        await wait_for(pilot, lambda: not note.display, "the box back")
        await pilot.pause()
        assert dialog.query_one("#obs-station", ValidatedField).text == "ABC"
        for button in ("#ok", "#cancel"):
            region = dialog.query_one(button).region
            assert region.right <= 80 and region.bottom <= 24 and region.x >= 0

    drive(app, script, size=(40, 12))

"""The console at 80×24 (issue 16, defect 6): every page fully readable by keyboard (the text
pages take the focus and scroll with ← ↑ ↓ → Home End), the message line wraps instead of
being cut, and a snapshot of every page and of the help screen at 80×24 (the 100×34 page
snapshots are in test_pages_snapshots.py).

Waits are for conditions, never for a fixed time."""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from pathlib import Path

import pytest
from rich.cells import cell_len
from test_console_support import drive as support_drive
from test_console_support import (
    freeze,
    make_app,
    start,
    text_of,
    wait_for,
)
from textual.pilot import Pilot

from uvnav_tui.app import UVNAVApp
from uvnav_tui.dialogs.dialog import Dialog
from uvnav_tui.pages.page_frame import PageFrame
from uvnav_tui.pages.page_text import TextPage
from uvnav_tui.pages.registry import page_titles
from uvnav_tui.pages.throttled_page import ThrottledTextPage
from uvnav_tui.screens.console_screen import ConsoleScreen
from uvnav_tui.screens.help_screen import HelpScreen

SMALL = (80, 24)
PAGES = sorted(page_titles())



def drive(app: UVNAVApp, script: Callable[[Pilot[None]], Awaitable[None]]) -> None:
    """Run ``script`` against ``app`` at 80×24."""
    support_drive(app, script, SMALL)


async def goto_page(pilot: Pilot[None], number: int) -> None:
    """Type the page number, as a navigator does."""
    await pilot.press(*str(number))
    await wait_for(pilot, lambda: pilot.app.page == number, f"Pg {number}")  # type: ignore
    await pilot.pause()


async def press_until(pilot: Pilot[None], key: str, done: Callable[[], bool],
                      limit: int = 60) -> None:
    """Press ``key`` until ``done()`` (at most ``limit`` times)."""
    for _ in range(limit):
        if done():
            return
        await pilot.press(key)
    assert done(), f"{key} pressed {limit} times"


@pytest.mark.parametrize("number", [n for n in PAGES if n != 100])
def test_every_page_is_readable_at_80x24_by_keyboard(data_dir: Path, number: int) -> None:
    """A text page larger than its area has the focus, and the cursor keys bring its last
    column (the right end of the widest line) and its last line into view; the scroll bars sit
    beside the text.  Before, the bodies took no focus and the columns beyond 62 (Pg 620 KF
    syst. error and √P, 631 Sel, 641, 650, 810, 840, 851) could not be reached."""
    app = make_app(data_dir, dev_mode=True)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 5)
        await goto_page(pilot, number)
        body = app.screen.query_one(PageFrame).body
        if isinstance(body, ThrottledTextPage):  # 642, 643, 710: drawn to the area's size
            await wait_for(pilot, lambda: bool(body._text), "the page drawn")  # noqa: SLF001
            drawn = body._text.splitlines()  # noqa: SLF001
            width, height = body.content_size
            assert max(cell_len(line) for line in drawn) <= width and len(drawn) <= height
            return
        assert isinstance(body, TextPage)
        lines = body.text.splitlines()
        assert body.virtual_size.width >= max(cell_len(line) for line in lines)
        if body.max_scroll_x == 0 and body.max_scroll_y == 0:
            return  # it fits
        assert app.focused is body
        await wait_for(pilot, lambda: "Scroll" in text_of(app).splitlines()[-1],
                       "the scroll keys on the key line")
        # right end of the widest of the lines in view at the top
        top = lines[: body.scrollable_content_region.height]
        widest = max(top, key=cell_len).rstrip()
        await press_until(pilot, "right", lambda: body.scroll_x >= body.max_scroll_x)
        await pilot.pause()
        assert widest[-8:] in text_of(app), widest
        # the last line, from its start
        await press_until(pilot, "left", lambda: body.scroll_x == 0)
        await press_until(pilot, "down", lambda: body.scroll_y >= body.max_scroll_y)
        await pilot.pause()
        last = next(line for line in reversed(lines) if line.strip())
        assert last[:20].rstrip() in text_of(app)
        # PgDn is still the sub-page key while the body has the focus
        await pilot.press("pagedown")
        await pilot.pause()

    drive(app, script)


def test_long_message_wraps_at_80_columns(data_dir: Path) -> None:
    """A message wider than the screen is shown whole on up to three lines, not cut."""
    app = make_app(data_dir)
    words = [f"word{i:02d}" for i in range(20)]  # 139 characters

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        app.say(" ".join(words))
        await pilot.pause()
        screen = text_of(app)
        assert all(w in screen for w in words), screen
        assert "Ctrl+Q Quit" in screen.splitlines()[-1]

    drive(app, script)


def _settle(number: int | None) -> Callable[[Pilot[None]], Awaitable[None]]:
    """``run_before`` of the snapshots: 5 sample cycles, then the page (or the help)."""

    async def run_before(pilot: Pilot[None]) -> None:
        app = pilot.app
        assert isinstance(app, UVNAVApp)
        await start(pilot, 5)
        if number is None:
            await pilot.press("f1")
            await wait_for(pilot, lambda: isinstance(app.screen, HelpScreen), "help")
        else:
            await goto_page(pilot, number)
        await app.workers.wait_for_complete()
        await pilot.pause()
        freeze(app)
        await pilot.pause()

    return run_before


@pytest.mark.parametrize("number", PAGES)
def test_snapshot_every_page_80x24(snap_compare: Callable[..., bool], data_dir: Path,
                                   number: int) -> None:
    """Every page of the console (developer mode) at 80×24 after 5 sample cycles."""
    app = make_app(data_dir, dev_mode=True)
    assert snap_compare(app, terminal_size=SMALL, run_before=_settle(number))


def test_snapshot_help_80x24(snap_compare: Callable[..., bool], data_dir: Path) -> None:
    """The help screen (F1) at 80×24."""
    app = make_app(data_dir)
    assert snap_compare(app, terminal_size=SMALL, run_before=_settle(None))


DIALOGS = [
    ("alt+s", "p", "d"), ("alt+s", "p", "p"), ("alt+s", "p", "c"), ("alt+s", "y", "g"),
    ("alt+s", "y", "d"), ("alt+s", "e"), ("alt+o", "b"), ("alt+o", "d"), ("alt+o", "r"),
    ("alt+k", "f"), ("alt+k", "p"), ("alt+d", "p"), ("alt+d", "c"), ("alt+d", "l"),
    ("alt+d", "f"),
]


@pytest.mark.parametrize("keys", DIALOGS, ids=["-".join(k) for k in DIALOGS])
def test_every_dialog_is_usable_at_80x24_by_keyboard(data_dir: Path,
                                                     keys: tuple[str, ...]) -> None:
    """Tab reaches every field and button of every dialog at 80×24, and each one is fully on
    the screen when it has the focus (the dialog scrolls it into view)."""
    app = make_app(data_dir, dev_mode=True)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 2)
        await pilot.press(*keys)
        await wait_for(pilot, lambda: isinstance(app.screen, Dialog), "the dialog")
        dialog = app.screen
        focusable = list(dialog.focus_chain)
        assert focusable
        seen = set()
        for _ in range(len(focusable) + 1):
            await pilot.press("tab")
            await pilot.pause()
            focused = app.focused
            assert focused is not None
            seen.add(focused)
            geometry = dialog.find_widget(focused)
            visible = geometry.region.intersection(geometry.clip)
            assert visible == geometry.region, f"{focused!r} is not fully visible"
            assert visible.bottom <= SMALL[1] and visible.right <= SMALL[0]
        assert seen == set(focusable)
        await pilot.press("escape")
        await wait_for(pilot, lambda: isinstance(app.screen, ConsoleScreen), "closed")

    drive(app, script)

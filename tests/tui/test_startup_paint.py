"""What the console does before its first paint (issue 14, start-up time): no style sheet parsed
twice, the engine's preload only once the menu bar is on screen, and only the dialogs that
first frame shows imported; keys typed at once still reach the Parameter Initialization dialog."""

from __future__ import annotations

import asyncio
import subprocess
import sys
from pathlib import Path

import pytest
from test_console_support import make_app, wait_for
from textual.css.stylesheet import Stylesheet
from textual.widgets import Input

from tests.paths import ROOT
from uvnav_tui.app import MONOCHROME, UVNAVApp
from uvnav_tui.dialogs.init_dialog import InitDialog
from uvnav_tui.widgets.menu_bar import MenuBar


def log_bar_renders(monkeypatch: pytest.MonkeyPatch, events: list[str]) -> None:
    """Every drawing of a menu bar appends ``render <its id>`` to ``events``."""
    render = MenuBar.render

    def render_logged(self: MenuBar) -> object:
        events.append(f"render {self.id}")
        return render(self)

    monkeypatch.setattr(MenuBar, "render", render_logged)


def test_no_style_sheet_parsed_again_before_the_first_paint(
        data_dir: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The theme and the dialog's style sheet are in place before the first parse: setting the
    theme on the running app, or reading dialog.tcss when the dialog is pushed, parsed every
    style sheet again and restyled every widget (two such parses before this test)."""
    reparses: list[str] = []
    reparse = Stylesheet.reparse

    def counted(self: Stylesheet) -> None:
        reparses.append("reparse")
        reparse(self)

    monkeypatch.setattr(Stylesheet, "reparse", counted)
    events: list[str] = []
    log_bar_renders(monkeypatch, events)
    app = make_app(data_dir)
    monkeypatch.setattr(app, "_preload_engine", lambda: None)

    async def run() -> None:
        async with app.run_test(size=(160, 50)) as pilot:
            await wait_for(pilot, lambda: "render menu-bar" in events, "the first paint")
            assert reparses == []
            assert app.theme == MONOCHROME.name
            assert app.has_class(f"-theme-{MONOCHROME.name}", "-dark-mode")
            assert isinstance(app.screen, InitDialog)

    asyncio.run(run())


def test_engine_preloaded_once_the_menu_bar_is_painted(
        data_dir: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The preload thread takes the interpreter from the UI thread: it starts after the frame
    that shows the console (before this test it started when the app had only been refreshed,
    before the console's first frame)."""
    events: list[str] = []
    log_bar_renders(monkeypatch, events)
    app = make_app(data_dir)
    monkeypatch.setattr(app, "_preload_engine", lambda: events.append("preload"))

    async def run() -> None:
        async with app.run_test(size=(160, 50)) as pilot:
            await wait_for(pilot, lambda: "preload" in events, "the preload")
            await pilot.pause()

    asyncio.run(run())
    assert events[0] == "render menu-bar"
    assert events.count("preload") == 1


def test_only_the_dialogs_of_the_first_frame_are_imported_with_the_console() -> None:
    """``import uvnav_tui.app`` brings Parameter Initialization and Quit's confirmation; the
    other dialogs and the message screen come with the action that opens them (before this
    test every dialog module was imported at start-up), and NumPy with the engine's preload."""
    code = ("import sys, uvnav_tui.app; print(' '.join(sorted(m for m in sys.modules if "
            "m.startswith(('uvnav_tui.dialogs', 'uvnav_tui.screens', 'numpy')))))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, check=True,
                         capture_output=True, text=True).stdout.split()
    assert out == ["uvnav_tui.dialogs", "uvnav_tui.dialogs.confirm_dialog",
                   "uvnav_tui.dialogs.dialog", "uvnav_tui.dialogs.init_dialog",
                   "uvnav_tui.screens", "uvnav_tui.screens.console_screen",
                   "uvnav_tui.screens.help_screen", "uvnav_tui.screens.table_screen"]


def test_keys_typed_at_once_reach_the_init_dialog(
        data_dir: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Keys typed before the first frame go to the Parameter Initialization dialog's first
    field (it is pushed when the app is mounted, before any key is handled)."""
    events: list[str] = []
    log_bar_renders(monkeypatch, events)
    app: UVNAVApp = make_app(data_dir)

    async def run() -> None:
        async with app.run_test(size=(160, 50)) as pilot:
            await pilot.press("end", "x", "y")
            await wait_for(pilot, lambda: "render menu-bar" in events, "the first paint")
            assert isinstance(app.screen, InitDialog)
            field = app.screen.query_one("#init-datum Input", Input)
            assert field.value.endswith("xy")

    asyncio.run(run())

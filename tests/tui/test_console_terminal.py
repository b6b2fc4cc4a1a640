"""The console and its terminal: Ctrl+Z suspends to the shell and ``fg`` repaints every cell,
Ctrl+L repaints, and leaving the console (quit or Ctrl+Z) clears the alternate screen first, so
no frame is left on the shell's screen after a resize.

Every wait is for a condition (:func:`test_console_support.wait_for`), never a fixed time."""

from __future__ import annotations

import io
import signal
from pathlib import Path

import pytest
from rich.console import Console
from test_console_support import drive, make_app, start, wait_for
from textual.driver import Driver
from textual.drivers.headless_driver import HeadlessDriver
from textual.drivers.linux_driver import LinuxDriver
from textual.pilot import Pilot

from uvnav_tui.app import UVNAVApp
from uvnav_tui.dialogs.position_dialog import PositionDialog
from uvnav_tui.terminal import CLEAR_SCREEN, ConsoleDriver, console_driver


def drawn_text(renderable: object, size: tuple[int, int]) -> str:
    """What a renderable sent to the terminal draws, as plain text."""
    console = Console(width=size[0], height=size[1], file=io.StringIO(), force_terminal=True,
                      color_system=None, record=True, legacy_windows=False)
    console.print(renderable)
    return console.export_text(styles=False)


def capture_display(app: UVNAVApp) -> list[object]:
    """Every update the app sends to the terminal from now on (kept, then sent as before)."""
    sent: list[object] = []
    display = app._display  # noqa: SLF001

    def recording(screen: object, renderable: object) -> None:
        sent.append(renderable)
        display(screen, renderable)  # type: ignore[arg-type]

    app._display = recording  # type: ignore[method-assign] # noqa: SLF001
    return sent


@pytest.mark.parametrize("how", ["ctrl+l", "resume"])
def test_repaint_draws_every_cell(data_dir: Path, how: str) -> None:
    """Ctrl+L and the return from Ctrl+Z (Textual's resume signal, published when ``fg``
    restarts the terminal) send one update that draws the whole screen: the menu bar, the
    boxes and the key line.  Before, neither sent anything (the screen stayed blank after
    ``fg``: Textual sends only what changed, and nothing had)."""
    app = make_app(data_dir)
    size = (100, 30)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 2)
        await pilot.pause()
        sent = capture_display(app)
        if how == "ctrl+l":
            await pilot.press("ctrl+l")
        else:
            app.post_message(Driver.SignalResume())
        await wait_for(pilot, lambda: any(
            "Quit  Edit  Setup" in (t := drawn_text(u, size)) and "F1 Help" in t
            and "MPP" in t for u in sent), "a whole-screen update")

    drive(app, script, size)


def test_ctrl_z_suspends_to_the_shell_from_a_dialog(data_dir: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """Ctrl+Z sends the console to the shell (SIGTSTP to itself, as a terminal's Ctrl+Z
    does), on a page and in a dialog's field.  Before, Ctrl+Z did nothing (the terminal is in
    raw mode: it arrives as a key, and nothing was bound to it)."""
    signals: list[int] = []
    monkeypatch.setattr(HeadlessDriver, "can_suspend", property(lambda self: True))
    monkeypatch.setattr("textual.app.os.kill", lambda pid, sig: signals.append(sig))
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 2)
        await pilot.press("ctrl+z")
        await wait_for(pilot, lambda: signals == [signal.SIGTSTP], "SIGTSTP from a page")
        await pilot.press("alt+s", "p", "p")
        await wait_for(pilot, lambda: isinstance(app.screen, PositionDialog)
                       and app.screen.is_mounted, "Setup ▸ Params ▸ DR Pos")
        await pilot.press("ctrl+z")
        await wait_for(pilot, lambda: len(signals) == 2, "SIGTSTP from a dialog")

    drive(app, script)


def test_leaving_the_terminal_clears_the_alternate_screen(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The console's driver erases the alternate screen before Textual leaves it (quit and
    Ctrl+Z): in tmux, rows written after a resize stayed on the shell's screen otherwise."""
    assert console_driver(LinuxDriver) is ConsoleDriver
    assert console_driver(HeadlessDriver) is HeadlessDriver
    written: list[str] = []
    monkeypatch.setattr(LinuxDriver, "stop_application_mode",
                        lambda self: written.append("<leave alternate screen>"))
    driver = ConsoleDriver.__new__(ConsoleDriver)
    driver.write = written.append  # type: ignore[method-assign]
    driver.stop_application_mode()
    assert written == [CLEAR_SCREEN, "<leave alternate screen>"]

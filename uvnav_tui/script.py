"""Console scripts: plain-text lists of console actions, replayed through the real UI.

One action per line (docs/CONSOLE.md)::

    # comment                   ignored, as are blank lines
    menu Setup > Systems > GPS  open the menu path with the keyboard and choose the item
    type 52 50 N 004 30 E       type text into the focused field
    clear                       empty the focused field (End, Ctrl+U)
    key enter                   press keys (Textual key names, several allowed)
    wait 30                     let 30 cycles run and wait for them
    sleep 2                     pause 2 s of wall time (skipped when headless)
    page 641                    show a page (as Statistics ▸ …)
    suspend / continue          Run ▸ Suspend / Run ▸ Continue
    hardcopy                    Edit ▸ Hardcopy
    pace x20                    set the playback pace (real, fast, xN)
    lop yes                     answer LOP-rejection questions: yes, no or ask
    quit                        leave the console

While a script runs the run is *held*: cycles advance only during ``wait``, so hardcopies are
reproducible. Keys go through Textual's pilot, exactly as typed keys would.
"""

from __future__ import annotations

import asyncio
import contextlib
from dataclasses import dataclass
from pathlib import Path

from textual.pilot import Pilot

from engine.api import SetParameters, read_text
from uvnav_tui.app import UVNAVApp
from uvnav_tui.menus import find_path
from uvnav_tui.pages.registry import page_titles
from uvnav_tui.screens.console_screen import ConsoleScreen

COMMANDS = ("menu", "type", "clear", "key", "wait", "sleep", "page", "suspend", "continue",
            "hardcopy", "pace", "lop", "quit")
MENU_PAUSE_S = 0.4
"""How long an opened menu stays visible before the item is chosen (visible console only)."""


class ScriptError(Exception):
    """A script line that cannot be parsed or executed, with its line number."""

    def __init__(self, line_no: int, message: str) -> None:
        super().__init__(f"line {line_no}: {message}")
        self.line_no = line_no
        self.message = message


@dataclass(frozen=True)
class Step:
    """One script line: command word and its argument text."""

    line_no: int
    command: str
    arg: str


def _int_arg(step_no: int, arg: str, what: str) -> int:
    try:
        value = int(arg)
    except ValueError:
        raise ScriptError(step_no, f"{what} must be a whole number, got {arg!r}") from None
    if value < 0:
        raise ScriptError(step_no, f"{what} must not be negative")
    return value


def parse_script(text: str) -> list[Step]:
    """Parse a script; raises :class:`ScriptError` for the first bad line."""
    steps = []
    for n, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        word, _, arg = line.partition(" ")
        command = word.lower()
        arg = line[len(word) + 1:] if command == "type" else arg.strip()
        if command not in COMMANDS:
            raise ScriptError(n, f"unknown command {word!r} (one of: {', '.join(COMMANDS)})")
        needs_arg = command in ("menu", "type", "key", "wait", "sleep", "page", "pace", "lop")
        if needs_arg and not arg:
            raise ScriptError(n, f"{command} needs an argument")
        if command in ("wait", "page"):
            _int_arg(n, arg, command)
        if command == "page" and int(arg) not in page_titles():
            raise ScriptError(n, f"no page {arg} (pages: {', '.join(map(str, page_titles()))})")
        if command == "sleep":
            try:
                float(arg)
            except ValueError:
                raise ScriptError(n, f"sleep needs seconds, got {arg!r}") from None
        if command == "lop" and arg.lower() not in ("yes", "no", "ask"):
            raise ScriptError(n, "lop must be yes, no or ask")
        steps.append(Step(n, command, arg))
    return steps


class ScriptRunner:
    """Executes parsed steps on a running console through a pilot."""

    def __init__(self, pilot: Pilot[None], *, headless: bool) -> None:
        self.pilot = pilot
        self.headless = headless
        app = pilot.app
        assert isinstance(app, UVNAVApp)
        self.app: UVNAVApp = app
        self.log: list[str] = []

    def release_hold(self) -> None:
        """End scripted stepping: the run advances freely again (LOP questions are asked)."""
        app = self.app
        app.hold = False
        app.lop_policy = "ask"
        if app.control is not None:
            app.control.budget = None
            app.kick()

    async def run_or_quit(self, steps: list[Step]) -> bool:
        """:meth:`run`, given up when the console exits meanwhile (the operator's Ctrl+Q, or a
        ``quit`` step): True when every step ran. Textual waits for the script before it
        exits, and a ``wait`` step would otherwise hold a quit console on a blank screen for
        up to its timeout (10 min). Raises :class:`ScriptError` as :meth:`run` does."""
        work = asyncio.ensure_future(self.run(steps))
        quitting = asyncio.ensure_future(self.app.exiting.wait())
        try:
            await asyncio.wait({work, quitting}, return_when=asyncio.FIRST_COMPLETED)
        finally:
            quitting.cancel()
        if not work.done():
            work.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await work
            return False
        work.result()  # its ScriptError, if any
        return True

    async def run(self, steps: list[Step]) -> None:
        """Run every step; raises :class:`ScriptError` on the first failure."""
        await self.pilot.pause()
        for step in steps:
            try:
                await self.execute(step)
            except ScriptError:
                raise
            except (KeyError, ValueError, RuntimeError, TimeoutError) as exc:
                message = exc.args[0] if exc.args else str(exc)
                raise ScriptError(step.line_no, str(message)) from None
            await self.pilot.pause()

    def _base_only(self, step: Step) -> None:
        if not isinstance(self.app.screen, ConsoleScreen):
            raise ScriptError(step.line_no,
                              f"{step.command}: a menu or dialog is still open "
                              f"({type(self.app.screen).__name__})")

    async def execute(self, step: Step) -> None:
        """Run one step."""
        app, pilot, cmd, arg = self.app, self.pilot, step.command, step.arg
        self.log.append(f"{step.line_no}: {cmd} {arg}".rstrip())
        if cmd == "menu":
            self._base_only(step)
            labels = [part.strip() for part in arg.split(">")]
            indices = find_path(labels, app.dev_mode)
            app.open_menu(indices[0], indices[1:] or [0])
            await pilot.pause()
            if not self.headless:
                await asyncio.sleep(MENU_PAUSE_S)
            await pilot.press("enter")
        elif cmd == "type":
            await pilot.press(*arg)
        elif cmd == "clear":
            await pilot.press("end", "ctrl+u")
        elif cmd == "key":
            await pilot.press(*arg.split())
        elif cmd == "wait":
            if app.control is None:
                raise ScriptError(step.line_no, "wait: no run (start one first)")
            if app.control.suspended:
                raise ScriptError(step.line_no, "wait: the run is suspended (use continue)")
            await app.wait_cycles(int(arg))
        elif cmd == "sleep":
            if not self.headless:
                await asyncio.sleep(float(arg))
        elif cmd == "page":
            self._base_only(step)
            app.show_page(int(arg))
        elif cmd == "suspend":
            app.actions.run_suspend()
        elif cmd == "continue":
            app.actions.run_continue()
        elif cmd == "hardcopy":
            await pilot.pause()
            if app.actions.write_hardcopy() is None:
                raise ScriptError(step.line_no, f"hardcopy failed: {app.message}")
        elif cmd == "pace":
            if not app.actions.apply(SetParameters("demo", (("pace", arg.lower()),))):
                raise ScriptError(step.line_no, f"pace: {app.message}")
        elif cmd == "lop":
            app.lop_policy = arg.lower()
        elif cmd == "quit":
            app.stop_run()
            app.exit()


def load_script(path: Path) -> list[Step]:
    """Read and parse a script file (InputError if it cannot be read, saying why: not found,
    a directory, permission, not UTF-8; engine.io.tomlsource.read_text)."""
    return parse_script(read_text(path))

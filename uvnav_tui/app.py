"""UVNAVApp: the navigation console (THEORY §12.1–12.10).

The app only renders engine state and sends operator commands to the engine. Cycles are computed
in a worker thread (:meth:`UVNAVApp._cycle_loop`) through a :class:`RunController`; the display
is refreshed at most ten times a second, so input is never blocked, even at "as fast as
possible". Every menu item is also a command-palette entry (Ctrl+P).

Around the app: the menu tree in :mod:`uvnav_tui.menus` is the action registry, the handlers
are :class:`uvnav_tui.actions.MenuActions`, the pages are found by
:mod:`uvnav_tui.pages.registry`, the console screen paints itself
(:meth:`ConsoleScreen.repaint`), and the engine is reached only through :mod:`engine.api`.
"""

from __future__ import annotations

import asyncio
import gc
import time
from collections.abc import Iterable
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

from textual import events, on
from textual.app import App, SystemCommand
from textual.binding import Binding
from textual.driver import Driver
from textual.message import Message
from textual.screen import Screen
from textual.theme import Theme
from textual.worker import get_current_worker

from engine import api
from engine.api import DatumFile, DeccaChain, RunConfig, load_data
from uvnav_tui.actions import MenuActions
from uvnav_tui.menus import palette_entries
from uvnav_tui.pages.registry import next_sub_page, page_refusal
from uvnav_tui.run_control import RunController, open_session
from uvnav_tui.screens.console_screen import ConsoleScreen
from uvnav_tui.screens.help_screen import HelpScreen
from uvnav_tui.screens.table_screen import TableScreen
from uvnav_tui.typeahead import KeyHandled, TypeAhead
from uvnav_tui.widgets.menu_bar import MenuBar
from uvnav_tui.widgets.message_log import MessageLog
from uvnav_tui.widgets.pulldown import PulldownScreen

if TYPE_CHECKING:
    from rich.console import RenderableType

    from engine.api import CycleResult, NmeaSender

REFRESH_S = 0.1
"""Shortest time between two display refreshes while cycles run (≤ 10 Hz)."""
HEADLESS_REFRESH_S = 0.5
"""The same without a terminal (scripted hardcopies, tests): nobody watches in between."""
DISPLAY_SHARE = 0.1
"""At pace fast, the display (the UI thread: repaint, compositing, terminal output) may use at
most this share of the process's CPU time: when a refresh costs more than the cycles computed
meanwhile allow, the next one waits, so the cycles keep the rest (issue 14: the console at
≥ 2,000 cycles/s). CPU time, not wall time: on a loaded machine the process gets less of it, and
so does its display. A refresh of Pg 100 or Pg 642 at 160×50 costs 30–50 ms of the UI thread on
the 2-core bench machine, so the display at pace fast is refreshed 2–3 times a second there.
(4 % was tried on 2026-12-03: about one refresh a second, and no gain in cycles/s that paired
runs on the shared machine could resolve, so the smoother display was kept.)"""
MAX_REFRESH_S = 1.0
"""Longest time between two refreshes while cycles run, whatever a refresh costs."""
PANEL_REFRESH_S = 0.5
"""At pace fast, the message panel under Pg 100 takes the new messages at most this often (the
message line shows the newest at every refresh; the end of the data, a page switch and any
refresh when the run is not at pace fast bring the panel up to date): new lines in the panel
repaint all its rows, about as much as the rest of a refresh at 160×50."""

MONOCHROME = Theme(
    name="uvnav-mono",
    primary="#C0C0C0",
    secondary="#A0A0A0",
    accent="#FFFFFF",
    foreground="#C0C0C0",
    background="#000000",
    surface="#000000",
    panel="#262626",
    boost="#1A1A1A",
    warning="#FFFFFF",
    error="#FFFFFF",
    success="#FFFFFF",
    dark=True,
)
"""The thesis console used no colours (L7591–7600): grey on black, reverse for highlights."""


CSS_FILES = [
    "app.tcss",
    "widgets/menu_bar.tcss",
    "widgets/state_line.tcss",
    "pages/main_page.tcss",
    "widgets/status_column.tcss",
    "pages/page_frame.tcss",
    "widgets/validated_field.tcss",
    "screens/console_screen.tcss",
    "widgets/message_line.tcss",
    "widgets/message_panel.tcss",
]
"""The console screen's style sheets (the other screens name their own)."""
INIT_DIALOG_CSS = (Path(__file__).parent / "dialogs" / "dialog.tcss").resolve()
"""The style sheet of the Parameter Initialization dialog (:attr:`Dialog.CSS_PATH`), read with
the console's when the dialog is shown at start: read when the dialog is pushed, it made the
app parse every style sheet again and restyle every widget before the first paint (issue 14,
start-up time). Same rules in the same order: the dialog is the first screen pushed."""

def load_engine() -> None:
    """Import the engine's run-time modules (the session, the cycle, the commands): what
    :mod:`engine.api` would otherwise import when the run starts. The cyclic garbage collector
    is paused meanwhile, as for the imports at start-up (``uvnav_tui.cli.main``)."""
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        for name in PRELOADED:
            getattr(api, name)
    finally:
        if was_enabled:  # never switch on a collector somebody else paused
            gc.enable()


PRELOADED = ("Session", "CycleResult", "SetDatum", "lse_estimate", "quality_name", "lop_name")
"""Names of :mod:`engine.api` whose modules :func:`load_engine` imports (together they load
all a run needs: the session imports the cycle, the filter, the fix and the NMEA reader).
pyproj is not among them: the datum shifts are the engine's own formulas
(engine/geodesy/ellipsoidal.py); the geodesic azimuths import it on first use."""


class Advanced(Message):
    """The worker computed one or more cycles since the last refresh."""


class EndOfData(Message):
    """The worker reached the end of the ``.RUN`` file (or stopped on an engine error)."""


class LopQuestion(Message):
    """A cycle flagged an LOP for rejection (``LOPReject = 'A'``)."""

    def __init__(self, result: CycleResult) -> None:
        super().__init__()
        self.result = result


class UVNAVApp(App[None]):
    """The console: one run at a time, driven from the menus, dialogs and command palette."""

    TITLE = "UVNAV"
    CSS_PATH = CSS_FILES
    BINDINGS = [
        Binding("ctrl+q", "quit", "Quit", show=False, priority=True),
        Binding("ctrl+c", "quit", "Quit", show=False),
        Binding("f1", "help", "Help", show=False, priority=True),
        Binding("ctrl+z", "suspend_process", "Suspend to the shell", show=False, priority=True),
        Binding("ctrl+l", "repaint", "Repaint", show=False, priority=True),
        Binding("f3", "acknowledge", "Acknowledge alarm", show=False, priority=True),
    ]

    def __init__(
        self,
        config: RunConfig,
        *,
        dev_mode: bool = False,
        hardcopy_dir: Path | None = None,
        pace_override: str | None = None,
        show_init: bool = True,
        write_logs: bool = True,
        hold: bool = False,
        lop_policy: str = "ask",
        data: tuple[DatumFile, dict[str, DeccaChain]] | None = None,
        nmea_sender: NmeaSender | None = None,
        config_path: Path | None = None,
        out_dir: Path | None = None,
    ) -> None:
        super().__init__()
        self._use_theme(MONOCHROME)
        if show_init:  # the first screen pushed: its style sheet is parsed with the others
            self.css_path.append(INIT_DIALOG_CSS)
        self._collector_held = False
        self._preloading = False
        """True once the first paint has started the engine's preload."""
        self.nmea_sender = nmea_sender
        """Where every cycle's MPP goes as NMEA 0183 (``uvnav --nmea-out``), or None."""
        self.base_config = config
        self.launch_dev_mode = dev_mode
        self.dev_mode = dev_mode
        self.hardcopy_dir = hardcopy_dir if hardcopy_dir is not None else Path("hardcopy")
        self.config_path = config_path
        """The configuration file ``uvnav`` started the console with, or None (scripts, tests):
        when given, the message line names it at start and each run's log when it starts."""
        self.out_dir = out_dir
        """Where the runs' ``.OUT`` logs go (None: beside the run file when that folder is
        writable, else the current directory; :func:`uvnav_tui.run_control.out_folder`)."""
        self.pace_override = pace_override
        self.show_init = show_init
        self.write_logs = write_logs
        self.hold = hold
        self.lop_policy = lop_policy
        self.data = data if data is not None else load_data(config)
        self.control: RunController | None = None
        self.page = 100
        self.message = ""
        self.message_log = MessageLog()
        self.hardcopies: list[tuple[Path, Path]] = []
        self.exiting = asyncio.Event()
        """Set when the console starts to exit (:meth:`exit`): a script driving it stops."""
        self._refresh_pending = False
        self._last_refresh = -1.0
        self._last_refresh_cpu = (0.0, 0.0)
        """CPU times of the UI thread and of the process at the last refresh [s]."""
        self._last_panel_sync = -1.0
        self.actions = MenuActions(self)
        """The handlers of the menu actions."""
        self.typeahead = TypeAhead(self)
        """Keys typed ahead, handed on one at a time (:mod:`uvnav_tui.typeahead`)."""

    # ------------------------------------------------------------------ keys
    async def on_event(self, event: events.Event) -> None:
        """Keys and pasted text read from the terminal go through the type-ahead queue
        (:class:`uvnav_tui.typeahead.TypeAhead`); everything else as Textual does."""
        if isinstance(event, (events.Key, events.Paste)) and not event.is_forwarded:
            await self.typeahead.key(event)
            return
        await super().on_event(event)

    @on(KeyHandled)
    def _key_handled(self, message: KeyHandled) -> None:
        self.typeahead.handled(message)

    # ------------------------------------------------------------------ set-up
    def get_default_screen(self) -> Screen[Any]:
        """The console screen (menu bar, state line, pages)."""
        return ConsoleScreen()

    def get_driver_class(self) -> type[Driver]:
        """Textual's terminal driver with the console's key parser and clean exit
        (:mod:`uvnav_tui.terminal`)."""
        from uvnav_tui.terminal import console_driver

        return console_driver(super().get_driver_class())

    def _use_theme(self, theme: Theme) -> None:
        """Start with ``theme``: what setting :attr:`theme` does (Textual 8.2's ``_watch_theme``:
        the app's classes, the ANSI colour filter, the style sheet's variables), done before the
        style sheet is first parsed, so without the new parse of every style sheet and the new
        styling of every widget that setting it in :meth:`on_mount` cost before the first paint
        (issue 14, start-up time; with the dialog's style sheet read at its push, the two took
        30–60 ms of CPU on the loaded 2-core machine)."""
        self.register_theme(theme)
        self.set_reactive(UVNAVApp.theme, theme.name)
        self.set_class(theme.dark, "-dark-mode", update=False)
        self.set_class(not theme.dark, "-light-mode", update=False)
        self.set_class(True, f"-theme-{theme.name}", update=False)
        self._refresh_truecolor_filter(self.ansi_theme)
        self.stylesheet.set_variables(self.get_css_variables())

    def on_mount(self) -> None:
        """The Parameter Initialization dialog over the main page; the whole screen drawn
        again when the console comes back from Ctrl+Z (``fg``)."""
        self.app_resume_signal.subscribe(self, lambda _app: self.action_repaint())
        self.refresh_display()
        if self.config_path is not None:
            self.say(f"Configuration {self.config_path}")
        if self.show_init:
            self.actions.parameter_initialization()

    @on(MenuBar.Painted)
    def _painted(self, event: MenuBar.Painted) -> None:
        """The console's menu bar has been drawn, in the frame just written (the first that
        shows the console: the Parameter Initialization dialog is drawn over a blank screen a
        frame earlier): collector on, engine preloaded (:meth:`_preload_engine`). Started after
        the app's first refresh instead, the preload began 40–70 ms of the UI thread's CPU
        before that frame, and its thread took the interpreter from the UI thread while it
        drew it (issue 14, start-up time)."""
        event.stop()
        if not self._preloading:
            self._preloading = True
            self.release_collector()
            self._preload_engine()

    def _preload_engine(self) -> None:
        """Once the first frame is on screen, load the numeric engine (NumPy, the filter, the
        session) in a worker thread while the operator reads the Parameter Initialization
        dialog, so that Return starts the run as soon as before. :mod:`engine.api` imports it
        on first use: the first paint needs only the configuration and the data files
        (issue 14, start-up time)."""
        self.run_worker(load_engine, thread=True, group="preload", exit_on_error=False)

    def hold_collector_until_painted(self) -> None:
        """Pause the cyclic garbage collector until the first frame is on screen
        (:meth:`release_collector`): building the console makes tens of thousands of objects,
        and the collector scanned them several times over before the first paint (a full
        collection alone took 20–30 ms; issue 14, start-up time). ``uvnav`` calls it; objects
        are collected as before once the frame is painted. Call it only if the collector is on
        (or was, until the caller paused it for the import of this module)."""
        gc.disable()
        self._collector_held = True

    def release_collector(self) -> None:
        """Switch the collector back on if :meth:`hold_collector_until_painted` paused it."""
        if self._collector_held:
            self._collector_held = False
            gc.enable()

    @property
    def datum_names(self) -> list[str]:
        """Datums of ``TO_WGS84.DAT`` section 2, in file order."""
        return list(self.data[0].datums)

    @property
    def config(self) -> RunConfig:
        """The configuration in force (the run's, else the start-up one)."""
        return self.control.session.config if self.control is not None else self.base_config

    @property
    def state_word(self) -> str:
        """``Working...``, ``Interrupted...`` or ``Suspended...``."""
        if self.control is None:
            return "Interrupted..." if len(self.screen_stack) > 1 else "Suspended..."
        return self.control.state_word

    # ------------------------------------------------------------------ runs
    def start_run(self, cfg: RunConfig) -> str | None:
        """Open a session for ``cfg`` (the .OUT under a free name in
        :func:`uvnav_tui.run_control.out_folder`: :attr:`out_dir`, else beside the run file when
        writable, else the current directory; a live-source URL as run file: docs/LIVE.md);
        returns an error message instead if it cannot be opened."""
        session = open_session(cfg, self.data, write_out=self.write_logs, out_dir=self.out_dir)
        if isinstance(session, str):
            return session
        self.stop_run()
        on_cycle = None
        if self.nmea_sender is not None:
            from engine.api import NmeaPositionOut  # only when asked for (start-up time)

            run_session = session if isinstance(session, api.Session) else session.session
            nmea, sender = NmeaPositionOut(run_session.datums), self.nmea_sender

            def on_cycle(r: CycleResult) -> None:
                sender.send(nmea.sentences(r))
        self.control = RunController(session, pace_override=self.pace_override,
                                     log=self.message_log, on_cycle=on_cycle)
        if self.hold:
            self.control.budget = 0
        self.control.interrupted = len(self.screen_stack) > 1
        self.message = ""
        self.show_page(100)
        self.refresh_display()
        for warning in self.control.session.data_warnings:  # a modified data file (DATAFILES.md)
            self.say(f"Warning: {warning}")
        out_path = self.control.session.out_path
        if out_path is not None and self.config_path is not None:  # started by ``uvnav``
            self.say(f"Run log {out_path}")
        scan = self.control.session.nmea_scan
        if scan is not None:  # an NMEA log without heading, log … (docs/NMEA.md)
            for missing in scan.missing_sensors():
                self.say(f"NMEA log: {missing}")
            for line in scan.variation_lines():  # compass headings made true: with what
                self.say(f"NMEA log: {line}")
        self.kick()
        return None

    def stop_run(self) -> None:
        """End the current run (its worker stops before the session is closed)."""
        run = self.control
        if run is None:
            return
        run.stopped = True
        run.close()
        self.control = None

    def set_interrupted(self, covered: bool) -> None:
        """Called by the console screen when it is covered/uncovered by another screen."""
        if covered:
            if self.control is not None:
                self.control.interrupted = True
            self.refresh_display()
        else:
            self.call_after_refresh(self._sync_interrupted)

    def _sync_interrupted(self) -> None:
        covered = len(self.screen_stack) > 1
        if self.control is not None:
            self.control.interrupted = covered
        self.refresh_display()
        self.kick()

    def kick(self) -> None:
        """Start the cycle worker if the run may advance and no worker is running."""
        run = self.control
        if run is None or not run.begin_worker():
            return
        self.run_worker(partial(self._cycle_loop, run), thread=True, group="cycles",
                        name="cycles", exit_on_error=False)

    def _cycle_loop(self, run: RunController) -> None:
        """Worker thread: compute cycles while the run is working, at the chosen pace."""
        worker = get_current_worker()
        run.run_cycles(lambda: worker.is_cancelled, advanced=self._notify_advanced,
                       ended=lambda: self.post_message(EndOfData()),
                       question=lambda result: self.post_message(LopQuestion(result)))

    def _notify_advanced(self) -> None:
        """(worker thread) Ask for a refresh unless one is already pending."""
        if not self._refresh_pending:
            self._refresh_pending = True
            self.post_message(Advanced())

    def _refresh_delay(self) -> float:
        """Seconds until the display may be refreshed again for new cycles: at most every
        :data:`REFRESH_S`; at pace fast also not before the UI thread's CPU time since the last
        refresh (that refresh's compositing and output included) is within
        :data:`DISPLAY_SHARE` of the process's; at least every :data:`MAX_REFRESH_S`."""
        interval = HEADLESS_REFRESH_S if self.is_headless else REFRESH_S
        since = time.monotonic() - self._last_refresh
        wait = interval - since
        run = self.control
        if run is not None and run.live is None and run.interval_s() == 0.0:
            ui0, all0 = self._last_refresh_cpu
            ui = time.thread_time() - ui0
            owed = ui / DISPLAY_SHARE - (time.process_time() - all0)
            wait = max(wait, min(owed, MAX_REFRESH_S - since))
        return wait

    @on(Advanced)
    def _advanced(self, _event: Advanced) -> None:
        delay = self._refresh_delay()
        if delay > 0:
            self.set_timer(delay, self._refresh_from_worker)
        else:
            self._refresh_from_worker()

    def _refresh_from_worker(self) -> None:
        delay = self._refresh_delay()  # the compositing of the last refresh may have come since
        if delay > 0.005:
            self.set_timer(delay, self._refresh_from_worker)
            return
        self._refresh_pending = False
        run = self.control
        fast = run is not None and run.live is None and run.interval_s() == 0.0
        self.refresh_display(
            panel=not fast or time.monotonic() - self._last_panel_sync >= PANEL_REFRESH_S)

    @on(EndOfData)
    def _end_of_data(self, _event: EndOfData) -> None:
        self.refresh_display()

    @on(LopQuestion)
    def _lop_question(self, event: LopQuestion) -> None:
        self.refresh_display()
        self.actions.ask_lop(event.result)

    # ------------------------------------------------------------------ waiting (scripts/tests)
    async def wait_cycles(self, n: int, timeout_s: float = 600.0) -> int:
        """Let ``n`` more cycles run and wait for them (see :meth:`RunController.wait_cycles`);
        returns the number done."""
        if self.control is None:
            raise RuntimeError("no run")
        done = await self.control.wait_cycles(n, self.kick, timeout_s)
        self.refresh_display()
        return done

    # ------------------------------------------------------------------ display
    def say(self, text: str) -> None:
        """Show a console message on the message line (and keep it in the message log)."""
        self.message = text
        run = self.control
        self.message_log.add(text, run.latest.time if run is not None and run.latest else None)
        self.refresh_display()

    def _base(self) -> ConsoleScreen | None:
        screen = self.screen_stack[0] if self.screen_stack else None
        return screen if isinstance(screen, ConsoleScreen) and screen.is_mounted else None

    def refresh_display(self, *, panel: bool = True) -> None:
        """Repaint the state line, the visible page and the message line from engine state
        (``panel``: and bring the message panel under Pg 100 up to date)."""
        self._last_refresh = time.monotonic()
        self._last_refresh_cpu = (time.thread_time(), time.process_time())
        if panel:
            self._last_panel_sync = self._last_refresh
        base = self._base()
        if base is not None:
            base.repaint(self.control, self.state_word, self.config, panel=panel)

    def show_page(self, number: int) -> None:
        """Show page ``number`` (100 = main page); Data pages (8xx) only in developer mode."""
        refusal = page_refusal(number, self.dev_mode)
        if refusal:
            self.say(refusal)
            return
        self.page = number
        base = self._base()
        if base is not None:
            base.select_page(number)
        self.refresh_display()

    def sub_page(self, step: int) -> None:
        """PgDn (+1) / PgUp (−1): the next or previous sub-page of the page shown (641 → 642 →
        643 → 641, THEORY D37); pages without sub-pages stay."""
        target = next_sub_page(self.page, step)
        if target != self.page:
            self.show_page(target)

    # ------------------------------------------------------------------ menus
    def open_menu(self, index: int, path: list[int] | None = None) -> None:
        """Open pulldown ``index`` of the bar (optionally with a sub-menu path open)."""
        self.message = ""
        self.push_screen(PulldownScreen(self.dev_mode, index, path, on_choose=self._chosen))

    def _chosen(self, action: str | None) -> None:
        if not action:
            return
        if isinstance(self.screen, TableScreen) and action not in ("hardcopy", "quit"):
            self.screen.dismiss(None)  # a page or dialog chosen over a table replaces it
        self.do_menu_action(action)

    def get_system_commands(self, screen: Screen[Any]) -> Iterable[SystemCommand]:
        """Every menu item and every page (by number and title) of the current mode, and Help."""
        if isinstance(screen, ConsoleScreen):
            for title, help_text, action in palette_entries(self.dev_mode):
                yield SystemCommand(title, help_text, partial(self.do_menu_action, action))
        yield SystemCommand("Help", "Keys, menus and the page map (F1)", self.action_help)

    def action_help(self) -> None:
        """F1 anywhere, ``?`` where it types nothing: the help screen, starting with the help on
        the screen on top (its ``help_topic()``: a dialog's fields, a menu item, a table, the
        page); F1 in the help closes it."""
        screen = self.screen
        if isinstance(screen, HelpScreen):
            screen.dismiss(None)
            return
        topic = getattr(screen, "help_topic", None)
        self.push_screen(HelpScreen(topic() if callable(topic) else None))

    def action_repaint(self) -> None:
        """Ctrl+L, and back from Ctrl+Z: lay out and draw the whole screen again, every cell
        (the terminal may have been cleared or written over meanwhile)."""
        self.refresh(layout=True)
        self.call_after_refresh(self._draw_whole_screen)

    def _draw_whole_screen(self) -> None:
        screen = self.screen
        update = screen._compositor.render_update(  # noqa: SLF001 - no public full redraw
            full=True, screen_stack=self._background_screens)  # noqa: SLF001
        self._display(screen, update)  # noqa: SLF001

    def action_acknowledge(self) -> None:
        """F3, anywhere: acknowledge the source-lost alarm (the bell stops; the alarm stays on
        the state line, steady, until the source receives again)."""
        if self.control is not None and self.control.acknowledge():
            self.refresh_display()

    def exit(self, result: None = None, return_code: int = 0,
             message: RenderableType | None = None) -> None:
        """Leave the console (Textual's exit), telling a driving script first
        (:attr:`exiting`)."""
        self.exiting.set()
        super().exit(result, return_code, message)

    def action_quit(self) -> None:  # type: ignore[override]
        """Quit asks for confirmation (thesis L5458)."""
        self.do_menu_action("quit")

    def do_menu_action(self, action: str) -> None:
        """Run a menu action by id (see :mod:`uvnav_tui.menus`, :mod:`uvnav_tui.actions`)."""
        self.actions.run(action)

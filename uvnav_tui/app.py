"""UVNAVApp: the navigation console (program.md §1–§4).

The app only renders engine state and sends operator commands to the engine. Cycles are computed
in a worker thread (:meth:`UVNAVApp._cycle_loop`) through a :class:`RunController`; the display
is refreshed at most ten times a second, so input is never blocked, even at "as fast as
possible". Every menu item is also a command-palette entry (Ctrl+P).
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable, Iterable
from datetime import timedelta
from functools import partial
from pathlib import Path
from typing import Any

from textual import on
from textual.app import App, SystemCommand
from textual.binding import Binding
from textual.message import Message
from textual.screen import Screen
from textual.theme import Theme
from textual.widgets import ContentSwitcher
from textual.worker import get_current_worker

import uvnav_tui.pages.all_pages  # noqa: F401  (registers every page but Pg 100)
from engine.errors import InputError
from engine.io.datumfile import DatumFile
from engine.io.deccafile import DeccaChain
from engine.io.formatting import (
    format_angle_deg,
    format_dms_input,
    format_lat_dms,
    format_lon_dms,
    format_metres,
    format_time_z,
)
from engine.lsq.fix import MAX_BRR, lop_name
from engine.run.commands import (
    AddObservation,
    Command,
    SetCurrent,
    SetDatum,
    SetDRPosition,
    SetFiltering,
    SetParameters,
    SetSensor,
)
from engine.run.config import RunConfig
from engine.run.cycle import CycleResult
from engine.run.session import Session, load_data
from uvnav_tui.dialogs.confirm_dialog import ConfirmDialog
from uvnav_tui.dialogs.current_dialog import CurrentDialog
from uvnav_tui.dialogs.datum_dialog import DatumDialog
from uvnav_tui.dialogs.decca_dialog import DeccaDialog
from uvnav_tui.dialogs.filtering_dialog import FilteringDialog
from uvnav_tui.dialogs.gps_dialog import GpsDialog
from uvnav_tui.dialogs.init_dialog import InitDialog
from uvnav_tui.dialogs.obs_dialog import ObsDialog
from uvnav_tui.dialogs.parameters_dialog import ParametersDialog
from uvnav_tui.dialogs.position_dialog import PositionDialog
from uvnav_tui.dialogs.predict_dialog import PredictDialog
from uvnav_tui.dialogs.sensors_dialog import SensorsDialog
from uvnav_tui.hardcopy import write_hardcopy
from uvnav_tui.menus import DEV_PAGES_FROM, PAGE_TITLES, iter_leaves, next_sub_page
from uvnav_tui.pages.main_page import MainPage
from uvnav_tui.pages.page_frame import PageFrame
from uvnav_tui.run_control import RunController
from uvnav_tui.screens.console_screen import ConsoleScreen
from uvnav_tui.screens.help_screen import HelpScreen
from uvnav_tui.screens.message_screen import MessageScreen
from uvnav_tui.screens.table_screen import TableScreen
from uvnav_tui.widgets.menu_bar import MenuBar
from uvnav_tui.widgets.message_line import MessageLine
from uvnav_tui.widgets.message_log import MessageLog
from uvnav_tui.widgets.message_panel import MessagePanel
from uvnav_tui.widgets.pulldown import PulldownScreen
from uvnav_tui.widgets.state_line import StateLine
from uvnav_tui.widgets.status_column import StatusColumn

REFRESH_S = 0.1
"""Shortest time between two display refreshes while cycles run (≤ 10 Hz)."""
HEADLESS_REFRESH_S = 0.5
"""The same without a terminal (scripted hardcopies, tests): nobody watches in between."""

NOT_CONNECTED = "System not connected !"

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


class UVNAVApp(App[None]):
    """The console: one run at a time, driven from the menus, dialogs and command palette."""

    TITLE = "UVNAV"
    CSS_PATH = [
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
    BINDINGS = [
        Binding("ctrl+q", "quit", "Quit", show=False, priority=True),
        Binding("ctrl+c", "quit", "Quit", show=False),
        Binding("f1", "help", "Help", show=False),
    ]

    class Advanced(Message):
        """The worker computed one or more cycles since the last refresh."""

    class EndOfData(Message):
        """The worker reached the end of the ``.RUN`` file (or stopped on an engine error)."""

    class LopQuestion(Message):
        """A cycle flagged an LOP for rejection (``LOPReject = 'A'``)."""

        def __init__(self, result: CycleResult) -> None:
            super().__init__()
            self.result = result

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
    ) -> None:
        super().__init__()
        self.base_config = config
        self.launch_dev_mode = dev_mode
        self.dev_mode = dev_mode
        self.hardcopy_dir = hardcopy_dir if hardcopy_dir is not None else Path("hardcopy")
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
        self._refresh_pending = False
        self._last_refresh = -1.0
        self._lop_excluded: tuple[int, ...] = ()

    # ------------------------------------------------------------------ set-up
    def get_default_screen(self) -> Screen[Any]:
        """The console screen (menu bar, state line, pages)."""
        return ConsoleScreen()

    def on_mount(self) -> None:
        """Monochrome theme; the Parameter Initialization dialog over the main page."""
        self.register_theme(MONOCHROME)
        self.theme = MONOCHROME.name
        self.refresh_display()
        if self.show_init:
            self.show_init_dialog()

    @property
    def datum_names(self) -> list[str]:
        """Datums of ``TO_WGS84.DAT`` section 2, in file order."""
        return list(self.data[0].datums)

    @property
    def session(self) -> Session | None:
        """The run's session (None before the first run)."""
        return self.control.session if self.control is not None else None

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
    def show_init_dialog(self) -> None:
        """Parameter Initialization, pre-filled from the start-up configuration."""
        self.push_screen(InitDialog(self.base_config, self.datum_names, self.start_run),
                         callback=self._init_closed)

    def _init_closed(self, cfg: RunConfig | None) -> None:
        if cfg is None and self.control is None:
            self.say("No run: Run ▸ Start opens Parameter Initialization")

    def start_run(self, cfg: RunConfig) -> str | None:
        """Open a session for ``cfg`` (the .OUT goes next to the .RUN file under a free name);
        returns an error message instead if it cannot be opened."""
        out = cfg.run_path.with_suffix(".OUT") if self.write_logs else None
        try:
            session = Session(cfg, out_path=out, collect_smoother=True, data=self.data)
        except InputError as exc:
            return exc.message
        except OSError as exc:
            return f"File error: {exc.strerror or exc}"
        self.stop_run()
        self.control = RunController(session, pace_override=self.pace_override,
                                     log=self.message_log)
        if self.hold:
            self.control.budget = 0
        self.control.interrupted = len(self.screen_stack) > 1
        self.message = ""
        self.show_page(100)
        self.refresh_display()
        for warning in session.data_warnings:  # a modified data file (docs/DATAFILES.md)
            self.say(f"Warning: {warning}")
        self._kick()
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
        self._kick()

    def _kick(self) -> None:
        """Start the cycle worker if the run may advance and no worker is running."""
        run = self.control
        if run is None or not run.begin_worker():
            return
        self.run_worker(partial(self._cycle_loop, run), thread=True, group="cycles",
                        name="cycles", exit_on_error=False)

    def _cycle_loop(self, run: RunController) -> None:
        """Worker thread: compute cycles while the run is working, at the chosen pace."""
        worker = get_current_worker()
        try:
            while run.worker_may_continue() and not worker.is_cancelled:
                if not run.wait_due(lambda: worker.is_cancelled or not run.can_run()):
                    continue
                with run.lock:
                    if not run.can_run():
                        continue
                    result = run.step()
                if result is None:
                    self.post_message(self.EndOfData())
                    continue
                self._notify_advanced()
                if run.awaiting_answer:
                    self.post_message(self.LopQuestion(result))
        except Exception as exc:  # noqa: BLE001 - an engine failure must not kill the console
            run.fail(exc)
            self.post_message(self.EndOfData())
        finally:
            run.end_worker()

    def _notify_advanced(self) -> None:
        """(worker thread) Ask for a refresh unless one is already pending."""
        if not self._refresh_pending:
            self._refresh_pending = True
            self.post_message(self.Advanced())

    @on(Advanced)
    def _advanced(self, _event: Advanced) -> None:
        interval = HEADLESS_REFRESH_S if self.is_headless else REFRESH_S
        delay = self._last_refresh + interval - time.monotonic()
        if delay > 0:
            self.set_timer(delay, self._refresh_from_worker)
        else:
            self._refresh_from_worker()

    def _refresh_from_worker(self) -> None:
        self._refresh_pending = False
        self.refresh_display()

    @on(EndOfData)
    def _end_of_data(self, _event: EndOfData) -> None:
        self.refresh_display()

    @on(LopQuestion)
    def _lop_question(self, event: LopQuestion) -> None:
        self.refresh_display()
        self._lop_excluded = ()
        self._ask_lop(event.result)

    def _ask_lop(self, result: CycleResult) -> None:
        run = self.control
        fix = result.fix
        if run is None or fix is None or fix.candidate_slot is None:
            return
        slot = fix.candidate_slot
        row = next((lop for lop in fix.lops if lop.slot == slot), None)
        what = lop_name(slot, system=row.system if row is not None else "GPS",
                        manual=result.manual)
        w = f" (w = {row.w:.2f})" if row is not None and row.w == row.w else ""
        question = f"The w-test rejects LOP {what}{w}.\nDiscard LOP {what}?"
        if self.lop_policy in ("yes", "no"):
            self._lop_answer(slot, what, self.lop_policy == "yes")
            return
        self.push_screen(ConfirmDialog("LOP rejection", question, default=True),
                         callback=lambda yes: self._lop_answer(slot, what, bool(yes)))

    def _lop_answer(self, slot: int, what: str, discard: bool) -> None:
        run = self.control
        if run is None:
            return
        if discard:
            self._lop_excluded = (*self._lop_excluded, slot)
            result = run.recompute(self._lop_excluded)
            self.say(f"LOP {what} discarded")
            if result is not None and result.fix is not None \
                    and result.fix.candidate_slot is not None:
                self.refresh_display()
                self._ask_lop(result)
                return
        else:
            self.say(f"LOP {what} kept (monitored)")
        run.awaiting_answer = False
        self.refresh_display()
        self._kick()

    # ------------------------------------------------------------------ waiting (scripts/tests)
    async def wait_cycles(self, n: int, timeout_s: float = 600.0) -> int:
        """Let ``n`` more cycles run (granting them when the run is held) and wait for them.

        Returns the number of cycles done; stops early at the end of the data file or when the
        run is suspended. Raises ``TimeoutError`` after ``timeout_s``.
        """
        run = self.control
        if run is None:
            raise RuntimeError("no run")
        start = run.cycles
        if run.budget is not None:
            run.grant(n)
        self._kick()
        deadline = time.monotonic() + timeout_s
        while run.cycles < start + n and not run.eof and not run.suspended:
            if time.monotonic() > deadline:
                raise TimeoutError(f"{run.cycles - start} of {n} cycles after {timeout_s} s")
            await asyncio.sleep(0.005)
        self.refresh_display()
        return run.cycles - start

    def release_hold(self) -> None:
        """End scripted stepping: the run advances freely again (LOP questions are asked)."""
        self.hold = False
        self.lop_policy = "ask"
        if self.control is not None:
            self.control.budget = None
            self._kick()

    # ------------------------------------------------------------------ display
    def say(self, text: str) -> None:
        """Show a console message on the message line (and keep it in the message log)."""
        self.message = text
        run = self.control
        self.message_log.add(text, run.latest.time if run is not None and run.latest else None)
        self.refresh_display()

    def _base(self) -> ConsoleScreen | None:
        screen = self.screen_stack[0] if self.screen_stack else None
        return screen if isinstance(screen, ConsoleScreen) else None

    def refresh_display(self) -> None:
        """Repaint the state line, the visible page and the message line from engine state."""
        self._last_refresh = time.monotonic()
        base = self._base()
        if base is None or not base.is_mounted:
            return
        run = self.control
        r = run.latest if run is not None else None
        line = base.query_one(StateLine)
        line.state_word = self.state_word
        line.time_text = format_time_z(r.time) if r is not None else "--:--:--Z"
        line.pace = run.pace if run is not None else ""
        line.note = run.note if run is not None else ""
        line.dev_mode = self.dev_mode
        line.page = self.page
        base.query_one(MenuBar).dev_mode = self.dev_mode
        if self.page == 100:
            base.query_one(MainPage).show(r, self.config)
            base.query_one(MessagePanel).sync(self.message_log)
        else:
            base.query_one(StatusColumn).bad_records = run.bad_records if run else 0
            base.query_one(PageFrame).show(r, self.session)
        base.query_one(MessageLine).show(self.message_log)

    def show_page(self, number: int) -> None:
        """Show page ``number`` (100 = main page); Data pages (8xx) only in developer mode."""
        if number not in PAGE_TITLES:
            self.say(f"No page {number}")
            return
        if number >= DEV_PAGES_FROM and not self.dev_mode:
            self.say(f"Pg {number} is a developer page (Setup ▸ Params ▸ Develop)")
            return
        self.page = number
        base = self._base()
        if base is not None and base.is_mounted:
            switcher = base.query_one("#pages", ContentSwitcher)
            if number == 100:
                switcher.current = "page-main"
            else:
                base.query_one(PageFrame).select(number)
                switcher.current = "page-frame"
            base.page_shown()
        self.refresh_display()

    def sub_page(self, step: int) -> None:
        """PgDn (+1) / PgUp (−1): the next or previous sub-page of the page shown (641 → 642 →
        643 → 641, program.md A5); pages without sub-pages stay."""
        target = next_sub_page(self.page, step)
        if target != self.page:
            self.show_page(target)

    def set_dev_mode(self, on: bool) -> None:
        """Setup ▸ Params ▸ Develop / Reset: show or hide the developer items (A4)."""
        self.dev_mode = on
        if not on and self.page >= DEV_PAGES_FROM:
            self.show_page(100)
        self.say("Developer menus on" if on else "Navigator menus")

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
            for path, item in iter_leaves(self.dev_mode):
                assert item.action is not None
                yield SystemCommand(" ▸ ".join(path), item.help,
                                    partial(self.do_menu_action, item.action))
            for number, title in PAGE_TITLES.items():
                if number < DEV_PAGES_FROM or self.dev_mode:
                    yield SystemCommand(f"Pg {number} {title}", f"Show page {number}",
                                        partial(self.show_page, number))
        yield SystemCommand("Help", "Keys, menus and the page map (F1)", self.action_help)

    def action_help(self) -> None:
        """F1 or ``?``: the help screen (not twice)."""
        if not isinstance(self.screen, HelpScreen):
            self.push_screen(HelpScreen())

    def action_quit(self) -> None:  # type: ignore[override]
        """Quit asks for confirmation (thesis L5458)."""
        self.do_menu_action("quit")

    def do_menu_action(self, action: str) -> None:
        """Run a menu action by id (see :mod:`uvnav_tui.menus`)."""
        if action.startswith("page:"):
            self.show_page(int(action.split(":", 1)[1]))
            return
        handler = self._handlers().get(action)
        if handler is None:
            self.say(f"Unknown menu action {action}")
            return
        if action in self._NEEDS_RUN and self.control is None:
            self.say("No run: Run ▸ Start opens Parameter Initialization")
            return
        handler()

    _NEEDS_RUN = {
        "datum", "dr_pos", "current", "gps", "decca", "sensors", "obs_bearing", "obs_distance",
        "obs_radar", "filtering", "predict", "smoothing", "demo_params", "demo_corrections",
        "demo_lsq", "demo_filter", "run_continue", "run_suspend",
    }

    def _handlers(self) -> dict[str, Callable[[], None]]:
        return {
            "quit": self._quit,
            "hardcopy": lambda: self.call_after_refresh(self.hardcopy),
            "datum": self._datum,
            "dr_pos": self._dr_pos,
            "current": self._current,
            "develop": lambda: self.set_dev_mode(True),
            "reset": lambda: self.set_dev_mode(False),
            "gps": self._gps,
            "decca": self._decca,
            "sins": lambda: self.say(f"SINS: {NOT_CONNECTED}"),
            "omega": lambda: self.say(f"Omega: {NOT_CONNECTED}"),
            "loran": lambda: self.say(f"Loran-C: {NOT_CONNECTED}"),
            "sensors": self._sensors,
            "obs_bearing": lambda: self._obs("bearing"),
            "obs_distance": lambda: self._obs("distance"),
            "obs_radar": lambda: self._obs("radar"),
            "filtering": self._filtering,
            "predict": self._predict,
            "smoothing": self._smoothing,
            "demo_params": lambda: self._params("demo"),
            "demo_corrections": lambda: self._params("corrections"),
            "demo_lsq": lambda: self._params("lsq"),
            "demo_filter": lambda: self._params("filter"),
            "run_continue": self.run_continue,
            "run_suspend": self.run_suspend,
            "run_start": self._run_start,
            "messages": lambda: self.push_screen(MessageScreen(self.message_log)),
        }

    def apply(self, *commands: Command, suffix: Callable[[], str] | None = None) -> bool:
        """Send operator commands to the engine; shows the log text (or the error), followed by
        ``suffix()`` if given (one message, not two)."""
        run = self.control
        if run is None:
            return False
        texts = []
        try:
            for cmd in commands:
                texts.append(run.apply(cmd))
        except (InputError, ValueError) as exc:
            self.say(exc.message if isinstance(exc, InputError) else str(exc))
            return False
        self.say("; ".join(texts) + (suffix() if suffix is not None else ""))
        return True

    def _quit(self) -> None:
        def answered(yes: bool | None) -> None:
            if yes:
                self.stop_run()
                self.exit()

        self.push_screen(ConfirmDialog("Quit", "Leave UVNAV?"), callback=answered)

    def _datum(self) -> None:
        self.push_screen(DatumDialog(self.datum_names, self.config.datum),
                         callback=lambda name: name is not None and self.apply(SetDatum(name)))

    def _dr_pos(self) -> None:
        assert self.control is not None
        nav = self.control.session.nav
        current = format_dms_input(nav.mpp_lat_deg, nav.mpp_lon_deg)
        self.push_screen(PositionDialog(current), callback=lambda pos: pos is not None
                         and self.apply(SetDRPosition(*pos)))

    def _current(self) -> None:
        cfg = self.config
        self.push_screen(CurrentDialog(cfg.current_set_deg, cfg.current_speed_kn),
                         callback=lambda v: v is not None and self.apply(SetCurrent(*v)))

    def _gps(self) -> None:
        self.push_screen(GpsDialog(self.config.gps),
                         callback=lambda cmd: cmd is not None and self.apply(cmd))

    def _decca(self) -> None:
        chains = list(self.data[1])
        self.push_screen(DeccaDialog(self.config.decca, chains),
                         callback=lambda cmd: cmd is not None and self.apply(cmd))

    def _sensors(self) -> None:
        def done(cmds: tuple[SetSensor, ...] | None) -> None:
            if cmds:
                self.apply(*cmds)

        self.push_screen(SensorsDialog(self.config.sensors), callback=done)

    def _obs(self, kind: str) -> None:
        def pending() -> str:
            n = len(self.control.session.nav.pending_obs) if self.control is not None else 0
            return f" — {n} observation(s) for the next cycle (at most {MAX_BRR})"

        def done(cmd: AddObservation | None) -> None:
            if cmd is not None:
                self.apply(cmd, suffix=pending)

        self.push_screen(ObsDialog(kind, self.config.lsq), callback=done)

    def _filtering(self) -> None:
        self.push_screen(FilteringDialog(self.config.filter.on),
                         callback=lambda on: on is not None and self.apply(SetFiltering(on)))

    def _params(self, table: str) -> None:
        def done(cmd: SetParameters | None) -> None:
            if cmd is not None and cmd.values:
                self.apply(cmd)

        self.push_screen(ParametersDialog(table, getattr(self.config, table)), callback=done)

    def _predict(self) -> None:
        self.push_screen(PredictDialog(), callback=self._predicted)

    def _predicted(self, value: tuple[float, float] | None) -> None:
        run = self.control
        if value is None or run is None:
            return
        horizon, step = value
        with run.lock:
            estimates = run.session.predict(horizon, step)
            last = run.latest
        if not estimates or last is None:
            self.say("No filter state to predict from")
            return
        level = self.config.lsq.conf_region_pct / 100.0
        rows = []
        n_steps = len(estimates)
        for i, p in enumerate(estimates, start=1):
            t = step * i if i < n_steps else horizon
            rows.append(self._estimate_row(
                f"+{int(t // 60):d}:{int(t % 60):02d}",
                format_time_z(last.time + timedelta(seconds=t)), p, level))
        note = (f"From {format_time_z(last.time)}, step {step:g} s, interval {horizon / 60:g} min;"
                f" ellipse axes at {self.config.lsq.conf_region_pct:g} %.")
        self.push_screen(TableScreen("Kalman ▸ Predict.", note, PREDICT_COLUMNS, rows,
                                     hardcopy_name="Predict"))

    @staticmethod
    def _estimate_row(offset: str, when: str, p: Any, level: float) -> list[str]:
        a = b = az = "999.99"
        if p.ellipse is not None:
            sa, sb = p.ellipse.scaled(level)
            a, b = format_metres(sa, space=False), format_metres(sb, space=False)
            az = format_angle_deg(p.ellipse.az_deg)
        return [offset, when, format_lat_dms(p.lat_deg), format_lon_dms(p.lon_deg), a, b, az]

    def _smoothing(self) -> None:
        run = self.control
        assert run is not None
        self.say("Smoothing …")
        self.run_worker(partial(self._smooth_worker, run), thread=True, group="smooth",
                        exit_on_error=False)

    def _smooth_worker(self, run: RunController) -> None:
        with run.lock:
            smoothed = run.session.smooth()
            history = list(run.session.history)
        self.call_from_thread(self._show_smoothed, smoothed, history)

    def _show_smoothed(self, smoothed: list[Any], history: list[CycleResult]) -> None:
        if not smoothed:
            self.say("Smoothing: nothing to smooth yet (no filter states collected)")
            return
        level = self.config.lsq.conf_region_pct / 100.0
        times = [format_time_z(r.time) for r in history[-len(smoothed):]] \
            if len(smoothed) <= len(history) else [""] * len(smoothed)
        rows = [self._estimate_row(str(i), t, p, level)
                for i, (t, p) in enumerate(zip(times, smoothed, strict=True), start=1)]
        note = (f"Rauch-Tung-Striebel smoothing of the last {len(smoothed)} filter states "
                "(post-processing, not in the 1993 program).")
        self.say("")
        self.push_screen(TableScreen("Kalman ▸ Smoothing", note, SMOOTH_COLUMNS, rows,
                                     hardcopy_name="Smoothing"))

    # ------------------------------------------------------------------ run menu, hardcopy
    def run_suspend(self) -> None:
        """Run ▸ Suspend: freeze after the last cycle."""
        if self.control is not None:
            if self.control.suspended:
                self.say("The run is already suspended: Run ▸ Continue resumes it")
                return
            self.control.suspended = True
            self.refresh_display()

    def run_continue(self) -> None:
        """Run ▸ Continue: leave the suspended state (not past the end of the data)."""
        run = self.control
        if run is None:
            return
        if run.eof:
            self.say("End of data file: Run ▸ Start begins a new run")
            return
        if not run.suspended:
            self.say("The run is already working (Run ▸ Suspend freezes it)")
            return
        run.suspended = False
        run.note = ""
        self.refresh_display()
        self._kick()

    def _run_start(self) -> None:
        def answered(yes: bool | None) -> None:
            if yes:
                self.stop_run()
                self.dev_mode = self.launch_dev_mode
                self.show_page(100)
                self.show_init_dialog()

        self.push_screen(ConfirmDialog("Run ▸ Start",
                                       "Start a new run? All parameters return to their "
                                       "defaults."), callback=answered)

    def hardcopy(self) -> tuple[Path, Path] | None:
        """Edit ▸ Hardcopy: SVG and text of the current page into the hardcopy directory."""
        run = self.control
        r = run.latest if run is not None else None
        name = Path(self.config.run_file).stem
        when = r.time.strftime("%H%M%S") if r is not None else "000000"
        try:
            what = (self.screen.hardcopy_name if isinstance(self.screen, TableScreen)
                    else self.page)
            paths = write_hardcopy(self, self.hardcopy_dir, name, when, what)
        except OSError as exc:
            self.say(f"Hardcopy failed: {exc.strerror or exc}")
            return None
        self.hardcopies.append(paths)
        self.say(f"Hardcopy {paths[0].name} (+ .txt) in {self.hardcopy_dir}")
        return paths


PREDICT_COLUMNS = ("t", "Time", "Lat", "Lon", "a", "b", "Az")
SMOOTH_COLUMNS = ("#", "Time", "Lat", "Lon", "a", "b", "Az")

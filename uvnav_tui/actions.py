"""What the console does for each menu action: one method per action id of
:data:`uvnav_tui.menus.MENU_BAR` (the registry), each opening its dialog and sending the
dialog's answer to the engine as an operator command.

Also here: the LOP-rejection question a cycle may raise (``LOPReject = 'A'``) and the hardcopy
of the current page.  No widgets are built here but the dialogs and tables pushed.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

from textual.app import App
from textual.screen import Screen

from engine import api
from engine.api import InputError, RunConfig, format_dms_input
from uvnav_tui.dialogs.confirm_dialog import ConfirmDialog
from uvnav_tui.dialogs.init_dialog import InitDialog
from uvnav_tui.hardcopy import write_hardcopy
from uvnav_tui.host import ConsoleHost
from uvnav_tui.menus import ACTIONS
from uvnav_tui.pages.registry import DEV_PAGES_FROM
from uvnav_tui.run_control import RunController
from uvnav_tui.screens.table_screen import TableScreen, predict_table, smoothing_table

# The other dialogs and the message screen are imported by the action that shows them: the
# console's first paint needs only Parameter Initialization (and Quit's confirmation at once),
# and the other twelve modules cost ~15 ms of start-up (issue 14).

if TYPE_CHECKING:
    from engine.api import (
        AddObservation,
        Command,
        CycleResult,
        PositionEstimate,
        SetParameters,
        SetSensor,
    )

NM_M = 1852.0
"""Metres in a nautical mile (exact; the Obs dialogs' unit)."""
NOT_CONNECTED = "System not connected !"
NO_RUN = "No run: Run ▸ Start opens Parameter Initialization"
LOP_QUESTION_ARM_S = 0.5
"""Seconds after the LOP rejection question opens during which no key answers it: it opens
unasked, between keys typed for something else (a Return typed ahead used to discard the LOP)."""


def shown_text(cmd: Command, logged: str) -> str:
    """The message line's text of an applied command: the engine's log text (the ``.OUT``'s
    ASCII ``ACT`` line, ``Setup > Params > Datum ED50``) with the menus' ``▸``; a manual
    observation with its unit, a distance in the nautical miles it was typed in
    (``Obs ▸ distance Heiloo 16.70 nm (radar)``)."""
    if isinstance(cmd, api.AddObservation):
        parts = []
        for o in cmd.observations:
            value = (f"{o.value / NM_M:.2f} nm" if o.kind == "distance"
                     else f"{o.value:.2f}°")
            parts.append(f"{o.kind} {o.station} {value} ({o.sensor or o.kind})")
        return "Obs ▸ " + "; ".join(parts)
    return logged.replace(" > ", " ▸ ")


class MenuActions:
    """The handlers of the menu actions, for one console (``host``)."""

    def __init__(self, host: ConsoleHost) -> None:
        self.host = host
        self._lop_excluded: tuple[int, ...] = ()

    def run(self, action: str) -> None:
        """Run the action ``action`` (``page:nnn`` shows a page); refused without a run if the
        registry says it needs one."""
        host = self.host
        if action.startswith("page:"):
            host.show_page(int(action.split(":", 1)[1]))
            return
        item = ACTIONS.get(action)
        handler: Callable[[], None] | None = getattr(self, action, None) if item else None
        if handler is None:
            host.say(f"Unknown menu action {action}")
        elif item is not None and item.needs_run and host.control is None:
            host.say(NO_RUN)
        else:
            handler()

    def apply(self, *commands: Command, suffix: Callable[[], str] | None = None) -> bool:
        """Send operator commands to the engine; shows the log text (or the error), followed by
        ``suffix()`` if given (one message, not two)."""
        run = self.host.control
        if run is None:
            return False
        texts = []
        try:
            for cmd in commands:
                texts.append(shown_text(cmd, run.apply(cmd)))
        except (InputError, ValueError) as exc:
            self.host.say(exc.message if isinstance(exc, InputError) else str(exc))
            return False
        self.host.say("; ".join(texts) + (suffix() if suffix is not None else ""))
        return True

    def parameter_initialization(self) -> None:
        """Parameter Initialization, pre-filled from the start-up configuration; a run starts
        when it is accepted."""
        host = self.host

        def closed(cfg: RunConfig | None) -> None:
            if cfg is None and host.control is None:
                host.say(NO_RUN)

        host.push_screen(InitDialog(host.base_config, host.datum_names, host.start_run),
                         callback=closed)

    def set_dev_mode(self, on: bool) -> None:
        """Show or hide the developer items (A4); a developer page shown gives way to Pg 100."""
        host = self.host
        host.dev_mode = on
        if not on and host.page >= DEV_PAGES_FROM:
            host.show_page(100)
        host.say("Developer menus on" if on else "Navigator menus")

    @property
    def _run(self) -> RunController:
        """The run (the registry guarantees one for the actions that need it)."""
        assert self.host.control is not None
        return self.host.control

    def _push(self, dialog: Screen[Any]) -> None:
        """Push a dialog whose answer (if any) is an operator command to apply."""
        self.host.push_screen(dialog,
                              callback=lambda cmd: cmd is not None and self.apply(cmd))

    # ------------------------------------------------------------------ Quit, Edit
    def quit(self) -> None:
        """Quit ▸ Quit, Ctrl+Q: leave after confirmation (thesis L5458)."""
        def answered(yes: bool | None) -> None:
            if yes:
                self.host.stop_run()
                self.host.exit()

        self.host.push_screen(ConfirmDialog("Quit", "Leave UVNAV?"), callback=answered)

    def hardcopy(self) -> None:
        """Edit ▸ Hardcopy, once the screen is painted."""
        self.host.call_after_refresh(self.write_hardcopy)

    def write_hardcopy(self) -> tuple[Path, Path] | None:
        """SVG and text of the current page (or table) into the hardcopy directory."""
        host = self.host
        run = host.control
        r = run.latest if run is not None else None
        name = Path(host.config.run_file).stem
        when = r.time.strftime("%H%M%S") if r is not None else "000000"
        try:
            what = (host.screen.hardcopy_name if isinstance(host.screen, TableScreen)
                    else host.page)
            paths = write_hardcopy(cast(App[object], host), host.hardcopy_dir, name, when, what)
        except OSError as exc:
            host.say(f"Hardcopy failed: {exc.strerror or exc}")
            return None
        host.hardcopies.append(paths)
        host.say(f"Hardcopy {paths[0].name} (+ .txt) in {host.hardcopy_dir}")
        return paths

    # ------------------------------------------------------------------ Setup
    def datum(self) -> None:
        """Setup ▸ Params ▸ Datum."""
        from uvnav_tui.dialogs.datum_dialog import DatumDialog

        host = self.host
        host.push_screen(DatumDialog(host.datum_names, host.config.datum),
                         callback=lambda name: name is not None and self.apply(api.SetDatum(name)))

    def dr_pos(self) -> None:
        """Setup ▸ Params ▸ DR Pos."""
        from uvnav_tui.dialogs.position_dialog import PositionDialog

        nav = self._run.session.nav
        current = format_dms_input(nav.mpp_lat_deg, nav.mpp_lon_deg)
        self.host.push_screen(PositionDialog(current), callback=lambda pos: pos is not None
                              and self.apply(api.SetDRPosition(*pos)))

    def current(self) -> None:
        """Setup ▸ Params ▸ Current."""
        from uvnav_tui.dialogs.current_dialog import CurrentDialog

        cfg = self.host.config
        self.host.push_screen(CurrentDialog(cfg.current_set_deg, cfg.current_speed_kn),
                              callback=lambda v: v is not None and self.apply(api.SetCurrent(*v)))

    def develop(self) -> None:
        """Setup ▸ Params ▸ Develop."""
        self.set_dev_mode(True)

    def reset(self) -> None:
        """Setup ▸ Params ▸ Reset."""
        self.set_dev_mode(False)

    def gps(self) -> None:
        """Setup ▸ Systems ▸ GPS."""
        from uvnav_tui.dialogs.gps_dialog import GpsDialog

        self._push(GpsDialog(self.host.config.gps))

    def decca(self) -> None:
        """Setup ▸ Systems ▸ Decca."""
        from uvnav_tui.dialogs.decca_dialog import DeccaDialog

        self._push(DeccaDialog(self.host.config.decca, list(self.host.data[1])))

    def sins(self) -> None:
        """Setup ▸ Systems ▸ SINS (not connected)."""
        self.host.say(f"SINS: {NOT_CONNECTED}")

    def omega(self) -> None:
        """Setup ▸ Systems ▸ Omega (not connected)."""
        self.host.say(f"Omega: {NOT_CONNECTED}")

    def loran(self) -> None:
        """Setup ▸ Systems ▸ Loran-C (not connected)."""
        self.host.say(f"Loran-C: {NOT_CONNECTED}")

    def sensors(self) -> None:
        """Setup ▸ Sensors: the changed sensors, one command each."""
        from uvnav_tui.dialogs.sensors_dialog import SensorsDialog

        def done(cmds: tuple[SetSensor, ...] | None) -> None:
            if cmds:
                self.apply(*cmds)

        self.host.push_screen(SensorsDialog(self.host.config.sensors), callback=done)

    # ------------------------------------------------------------------ Obs
    def obs_bearing(self) -> None:
        """Obs ▸ Bearing."""
        self._obs("bearing")

    def obs_distance(self) -> None:
        """Obs ▸ Distance."""
        self._obs("distance")

    def obs_radar(self) -> None:
        """Obs ▸ Radar."""
        self._obs("radar")

    def _obs(self, kind: str) -> None:
        """A manual observation for the next cycle; says how many are pending."""
        from uvnav_tui.dialogs.obs_dialog import ObsDialog

        def pending() -> str:
            run = self.host.control
            n = len(run.session.nav.pending_obs) if run is not None else 0
            return f" — {n} observation(s) for the next cycle (at most {api.MAX_BRR})"

        def done(cmd: AddObservation | None) -> None:
            if cmd is not None:
                self.apply(cmd, suffix=pending)

        self.host.push_screen(ObsDialog(kind, self.host.config.lsq), callback=done)

    # ------------------------------------------------------------------ Kalman
    def filtering(self) -> None:
        """Kalman ▸ Filtering."""
        from uvnav_tui.dialogs.filtering_dialog import FilteringDialog

        self.host.push_screen(FilteringDialog(self.host.config.filter.on), callback=lambda on:
                              on is not None and self.apply(api.SetFiltering(on)))

    def predict(self) -> None:
        """Kalman ▸ Predict.: the interval and step, then the table."""
        from uvnav_tui.dialogs.predict_dialog import PredictDialog

        self.host.push_screen(PredictDialog(), callback=self._predicted)

    def _predicted(self, value: tuple[float, float] | None) -> None:
        run = self.host.control
        if value is None or run is None:
            return
        horizon, step = value
        with run.lock:
            estimates = run.session.predict(horizon, step)
            last = run.latest
        if not estimates or last is None:
            self.host.say("No filter state to predict from")
            return
        self.host.push_screen(predict_table(estimates, last.time, horizon, step,
                                            self.host.config.lsq.conf_region_pct))

    def smoothing(self) -> None:
        """Kalman ▸ Smoothing, computed in a worker thread."""
        self.host.say("Smoothing …")
        self.host.run_worker(partial(self._smooth_worker, self._run), thread=True,
                             group="smooth", exit_on_error=False)

    def _smooth_worker(self, run: RunController) -> None:
        with run.lock:
            smoothed = run.session.smooth()
            history = list(run.session.history)
        self.host.call_from_thread(self._show_smoothed, smoothed, history)

    def _show_smoothed(self, smoothed: list[PositionEstimate],
                       history: list[CycleResult]) -> None:
        if not smoothed:
            self.host.say("Smoothing: nothing to smooth yet (no filter states collected)")
            return
        table = smoothing_table(smoothed, history, self.host.config.lsq.conf_region_pct)
        self.host.say("")
        self.host.push_screen(table)

    # ------------------------------------------------------------------ Statistics, Demo
    def messages(self) -> None:
        """Statistics ▸ Messages, F2: the message log."""
        from uvnav_tui.screens.message_screen import MessageScreen

        self.host.push_screen(MessageScreen(self.host.message_log))

    def demo_params(self) -> None:
        """Demo ▸ Parameters."""
        self._params("demo")

    def demo_corrections(self) -> None:
        """Demo ▸ Corrections."""
        self._params("corrections")

    def demo_lsq(self) -> None:
        """Demo ▸ LS params."""
        self._params("lsq")

    def demo_filter(self) -> None:
        """Demo ▸ Filter params."""
        self._params("filter")

    def _params(self, table: str) -> None:
        from uvnav_tui.dialogs.parameters_dialog import ParametersDialog

        def done(cmd: SetParameters | None) -> None:
            if cmd is not None and cmd.values:
                self.apply(cmd)

        self.host.push_screen(ParametersDialog(table, getattr(self.host.config, table)),
                              callback=done)

    # ------------------------------------------------------------------ Run
    def run_suspend(self) -> None:
        """Run ▸ Suspend: freeze after the last cycle."""
        run = self.host.control
        if run is None:
            return
        if run.suspended:
            self.host.say("The run is already suspended: Run ▸ Continue resumes it")
            return
        run.suspended = True
        self.host.refresh_display()

    def run_continue(self) -> None:
        """Run ▸ Continue: leave the suspended state (not past the end of the data)."""
        run = self.host.control
        if run is None:
            return
        if run.eof:
            self.host.say("End of data file: Run ▸ Start begins a new run")
            return
        if not run.suspended:
            self.host.say("The run is already working (Run ▸ Suspend freezes it)")
            return
        run.suspended = False
        run.note = ""
        self.host.refresh_display()
        self.host.kick()

    def run_start(self) -> None:
        """Run ▸ Start: a new run from Parameter Initialization (after confirmation)."""
        host = self.host

        def answered(yes: bool | None) -> None:
            if yes:
                host.stop_run()
                host.dev_mode = host.launch_dev_mode
                host.show_page(100)
                self.parameter_initialization()

        host.push_screen(ConfirmDialog("Run ▸ Start",
                                       "Start a new run? All parameters return to their "
                                       "defaults."), callback=answered)

    # ------------------------------------------------------------------ LOP rejection
    def ask_lop(self, result: CycleResult, first: bool = True) -> None:
        """A cycle flagged an LOP for rejection: ask (or answer by ``lop_policy``) whether to
        discard it; discarding recomputes the cycle, which may flag the next LOP."""
        if first:
            self._lop_excluded = ()
        host, run, fix = self.host, self.host.control, result.fix
        if run is None or fix is None or fix.candidate_slot is None:
            return
        slot = fix.candidate_slot
        row = next((lop for lop in fix.lops if lop.slot == slot), None)
        what = api.lop_name(slot, system=row.system if row is not None else "GPS",
                        manual=result.manual)
        w = f" (w = {row.w:.2f})" if row is not None and row.w == row.w else ""
        v = f"\nIts residual v = {row.v_m:.1f} m (Pg 631)." if row is not None \
            and row.v_m == row.v_m else ""
        question = f"The w-test rejects LOP {what}{w}.{v}\nDiscard LOP {what}?"
        if host.lop_policy in ("yes", "no"):
            self._lop_answer(slot, what, host.lop_policy == "yes")
            return
        # Raised by a cycle, not asked for: keys typed ahead must not answer it.
        # Not over the row it asks about: at the bottom under the LOP rows of Pg 631/633; on
        # Pg 100 at the top, over the position boxes, under the newest messages of the panel.
        host.push_screen(ConfirmDialog("LOP rejection", question, default=True,
                                       arm_s=LOP_QUESTION_ARM_S,
                                       place="top" if host.page == 100 else "bottom"),
                         callback=lambda yes: self._lop_answer(slot, what, bool(yes)))

    def _lop_answer(self, slot: int, what: str, discard: bool) -> None:
        host, run = self.host, self.host.control
        if run is None:
            return
        if discard:
            self._lop_excluded = (*self._lop_excluded, slot)
            result = run.recompute(self._lop_excluded)
            host.say(f"LOP {what} discarded")
            if result is not None and result.fix is not None \
                    and result.fix.candidate_slot is not None:
                host.refresh_display()
                self.ask_lop(result, first=False)
                return
        else:
            run.keep(slot)
            host.say(f"LOP {what} kept (monitored)")
        run.awaiting_answer = False
        host.refresh_display()
        host.kick()

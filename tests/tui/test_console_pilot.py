"""Pilot tests: drive every menu item and dialog of the console with the keyboard and check the
engine state it changed (configuration, pending observations, run state)."""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest
from test_console_support import (
    blunder_data,
    drive,
    make_app,
    start,
    text_of,
    wait_for,
)
from textual.command import CommandPalette
from textual.pilot import Pilot
from textual.widgets import DataTable, Input, OptionList, Static

from uvnav_tui.actions import LOP_QUESTION_ARM_S
from uvnav_tui.dialogs.confirm_dialog import ConfirmDialog
from uvnav_tui.dialogs.dialog import Dialog
from uvnav_tui.dialogs.init_dialog import InitDialog
from uvnav_tui.screens.console_screen import ConsoleScreen
from uvnav_tui.screens.table_screen import TableScreen
from uvnav_tui.widgets.pulldown import PulldownScreen
from uvnav_tui.widgets.validated_field import ValidatedField

SIZE = (100, 30)




async def goto(pilot: Pilot[None], field_id: str) -> Input:
    """Tab to the input of field ``field_id`` (keyboard only)."""
    app = pilot.app
    for _ in range(20):
        focused = app.focused
        if isinstance(focused, Input) and focused.id == f"{field_id}-input":
            return focused
        await pilot.press("tab")
    raise AssertionError(f"cannot tab to {field_id}")


async def fill(pilot: Pilot[None], field_id: str, text: str) -> ValidatedField:
    """Tab to a field (which selects its text) and paste ``text`` over it with Ctrl+V: one key
    press instead of one per character keeps the suite fast (typing key by key is covered by
    test_validation_as_you_type)."""
    await goto(pilot, field_id)
    pilot.app.copy_to_clipboard(text)
    await pilot.press("ctrl+a", "ctrl+k", "ctrl+v")
    return pilot.app.screen.query_one(f"#{field_id}", ValidatedField)


def message_of(field: ValidatedField) -> str:
    """The message line under a field."""
    return str(field.query_one(".field-message", Static).render()).strip()


async def menu(pilot: Pilot[None], *keys: str) -> None:
    """Open a menu with Alt+letter and pick items with their hot-keys (or press other keys)."""
    await pilot.press(*keys)


# ------------------------------------------------------------------------------------------
# Parameter Initialization


INIT_BAD = [
    ("init-datum", "XYZ", "Unknown datum !"),
    ("init-dr", "52 50 N 4 30 X", "Wrong position input format !"),
    ("init-depth", "-5", "Wrong depth input !"),
    ("init-speed", "fast", "Wrong speed input !"),
    ("init-set", "400", "Wrong direction input !"),
    ("init-run", "nofile", "File not found !"),
    ("init-run", "bad name!", "Wrong file name !"),
]


def test_init_dialog_rejects_bad_entries_and_keeps_them(data_dir: Path) -> None:
    """Every field: a bad entry shows the thesis message, keeps the text, and Return does not
    start the run (the other fields keep their values)."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await pilot.pause()
        for field, bad, message in INIT_BAD:
            widget = app.screen.query_one(f"#{field}", ValidatedField)
            good = widget.text
            await fill(pilot, field, bad)
            assert message in message_of(widget), field
            assert widget.text == bad
            await pilot.press("enter")
            assert isinstance(app.screen, InitDialog)
            assert app.control is None and widget.text == bad
            await fill(pilot, field, good)
            assert widget.error is None

    drive(app, script)


def test_validation_as_you_type(data_dir: Path) -> None:
    """Typing key by key: the message appears while the position is incomplete and goes away
    when it becomes valid; the text typed so far is kept throughout."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await pilot.pause()
        field_input = await goto(pilot, "init-dr")
        field = app.screen.query_one("#init-dr", ValidatedField)
        await pilot.press("end", "ctrl+u", *"52 50 N 4 30")
        assert field_input.value == "52 50 N 4 30"
        assert message_of(field) == "Wrong position input format !"
        await pilot.press("space", "E")
        assert field_input.value == "52 50 N 4 30 E"
        assert message_of(field) == "" and field.parsed == (52 + 50 / 60, 4.5)

    drive(app, script)


def test_init_dialog_values_go_into_the_run(data_dir: Path) -> None:
    """Edited values are applied to the configuration before the session opens."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await pilot.pause()
        await fill(pilot, "init-datum", "wgs84")
        await fill(pilot, "init-dr", "52 49.5 N 4 29.0 E")
        await fill(pilot, "init-depth", "12.5")
        await fill(pilot, "init-speed", "0.8")
        await fill(pilot, "init-set", "45")
        await pilot.press("enter")
        await pilot.pause()
        assert isinstance(app.screen, ConsoleScreen)
        cfg = app.control.session.config
        assert cfg.datum == "WGS84"
        assert cfg.dr_lat_deg == pytest.approx(52 + 49.5 / 60)
        assert cfg.dr_lon_deg == pytest.approx(4 + 29.0 / 60)
        assert (cfg.depth_m, cfg.current_speed_kn, cfg.current_set_deg) == (12.5, 0.8, 45.0)
        assert cfg.run_path.name == "920917_1.RUN"
        assert app.control.session.out_path.parent == data_dir
        await app.wait_cycles(2)
        assert app.control.latest.datum == "WGS84"

    drive(app, script)


def test_out_log_never_overwritten(data_dir: Path) -> None:
    """A second run gets a free .OUT name next to the .RUN file."""
    (data_dir / "920917_1.OUT").write_text("old log\n")
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot)
        assert app.control.session.out_path.name == "920917_1_1.OUT"

    drive(app, script)
    assert (data_dir / "920917_1.OUT").read_text() == "old log\n"


# ------------------------------------------------------------------------------------------
# Menus, run states


def test_menu_keyboard_navigation(data_dir: Path) -> None:
    """F10 opens the first menu, →/← move along the bar, Return opens a sub-menu, Esc closes
    one level at a time, and the run is interrupted meanwhile."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        assert app.state_word == "Working..."
        await menu(pilot, "f10")
        screen = app.screen
        assert isinstance(screen, PulldownScreen)
        assert screen.menu_index == 0
        assert app.state_word == "Interrupted..."
        await menu(pilot, "right", "right")
        assert screen.bar[screen.menu_index].label == "Setup"
        await menu(pilot, "enter")
        assert screen.current.label == "Datum" and screen.path == [0, 0]
        await menu(pilot, "down", "down")
        assert screen.current.label == "Current"
        await menu(pilot, "escape", "down", "right")
        assert screen.current.label == "GPS" and screen.path == [1, 0]
        await menu(pilot, "escape")
        assert screen.path == [1]
        await menu(pilot, "left")
        assert screen.bar[screen.menu_index].label == "Edit"
        await menu(pilot, "escape")
        assert isinstance(app.screen, ConsoleScreen)
        await pilot.pause()
        assert app.state_word == "Working..."

    drive(app, script)


def test_menu_mouse(data_dir: Path) -> None:
    """A click on a title opens it; a click on an item chooses it."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        await pilot.click("#menu-bar", offset=(20, 0))  # " Obs " spans columns 19-23
        await pilot.pause()
        screen = app.screen
        assert isinstance(screen, PulldownScreen)
        assert screen.bar[screen.menu_index].label == "Obs"
        await pilot.click(".menu-box", offset=(3, 2))  # second item: Distance
        await pilot.pause()
        assert isinstance(app.screen, Dialog)
        assert app.screen.TITLE == "Obs ▸ Distance"

    drive(app, script)


def test_cycles_pause_while_a_menu_is_open(data_dir: Path) -> None:
    """Interrupted: no cycle runs while a pulldown is open; they resume when it closes."""
    app = make_app(data_dir, "DEMO", hold=False, pace_override="x50")

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot)
        run = app.control
        await wait_for(pilot, lambda: run.cycles > 0, "a cycle")
        await menu(pilot, "f10")
        # The worker ends before the next cycle once the menu interrupts the run; from then on
        # no cycle may run, however long we look (a condition, then an invariant: no timing).
        await wait_for(pilot, lambda: not run.worker_active, "the cycle worker to stop")
        frozen = run.cycles
        for _ in range(10):
            await pilot.pause(0.02)
            assert run.cycles == frozen
        assert app.state_word == "Interrupted..."
        await menu(pilot, "escape")
        await wait_for(pilot, lambda: run.cycles > frozen, "the run to resume")
        app.actions.run_suspend()

    drive(app, script)


def test_suspend_continue_and_end_of_data(data_dir: Path) -> None:
    """Run ▸ Suspend freezes, Run ▸ Continue resumes, the end of the file suspends."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 3)
        await menu(pilot, "alt+r", "s")
        assert app.state_word == "Suspended..."
        assert "Suspended..." in text_of(app)
        await pilot.press("alt+r")
        await pilot.pause()
        assert app.state_word == "Suspended..."  # a menu over a suspended run stays suspended
        await pilot.press("c")
        await pilot.pause()
        assert app.state_word == "Working..."
        done = await app.wait_cycles(20)
        assert done == 7
        assert app.state_word == "Suspended..."
        screen = text_of(app)
        assert "End of data file" in screen and "Time 08:35:47Z" in screen
        await menu(pilot, "alt+r", "c")
        assert app.state_word == "Suspended..."
        assert "Run ▸ Start" in app.message

    drive(app, script)


def test_run_start_confirm_returns_to_init(data_dir: Path) -> None:
    """Run ▸ Start asks first; yes closes the run and shows Parameter Initialization."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 2)
        old = app.control
        await menu(pilot, "alt+r", "t")
        assert isinstance(app.screen, ConfirmDialog)
        await menu(pilot, "n")
        assert app.control is old
        await menu(pilot, "alt+r", "t", "y")
        assert isinstance(app.screen, InitDialog)
        assert app.control is None and old.stopped
        await menu(pilot, "enter")
        assert app.control is not None and app.control is not old

    drive(app, script)


def test_quit_asks_for_confirmation(data_dir: Path) -> None:
    """Quit ▸ Quit: No resumes, Yes leaves."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        await menu(pilot, "alt+q", "q")
        assert isinstance(app.screen, ConfirmDialog)
        await menu(pilot, "escape")
        assert isinstance(app.screen, ConsoleScreen)
        await menu(pilot, "ctrl+q")
        assert isinstance(app.screen, ConfirmDialog)
        await pilot.press("y")
        await pilot.pause()
        assert app.control is None

    drive(app, script)
    assert app.return_code == 0


def test_command_palette_runs_menu_items(data_dir: Path) -> None:
    """Every menu item is in the command palette (Ctrl+P), filtered by mode."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        names = [c.title for c in app.get_system_commands(app.screen)]
        assert "Setup ▸ Systems ▸ GPS" in names and "Run ▸ Suspend" in names
        assert not any(n.startswith("Data") for n in names)
        await pilot.press("ctrl+p")
        await wait_for(pilot, lambda: isinstance(app.screen, CommandPalette), "the palette")
        await pilot.press(*"run suspend")

        def first_hit() -> str:
            options = app.screen.query_one(OptionList)
            if options.option_count == 0 or options.highlighted is None:
                return ""
            return str(options.get_option_at_index(options.highlighted).prompt)

        await wait_for(pilot, lambda: "Run ▸ Suspend" in first_hit(), "the search result")
        await pilot.press("enter")
        await wait_for(pilot, lambda: app.state_word == "Suspended...", "the run suspended")

    drive(app, script)


# ------------------------------------------------------------------------------------------
# Edit, Setup


def test_hardcopy(data_dir: Path) -> None:
    """Edit ▸ Hardcopy writes UVNAV_<run>_<record time>_Pg100 .svg and .txt."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 2)
        await menu(pilot, "alt+e", "h")
        await pilot.pause()
        await menu(pilot, "alt+e", "h")
        await pilot.pause()

    drive(app, script)
    out = data_dir / "hardcopy"
    assert sorted(p.name for p in out.iterdir()) == [
        "UVNAV_920917_1_083539_Pg100.svg", "UVNAV_920917_1_083539_Pg100.txt",
        "UVNAV_920917_1_083539_Pg100_2.svg", "UVNAV_920917_1_083539_Pg100_2.txt"]
    text = (out / "UVNAV_920917_1_083539_Pg100.txt").read_text()
    assert "Pg 100" in text and "Time 08:35:39Z" in text and "Datum : ED50" in text
    assert "Hardcopy" not in text  # the Edit pulldown is closed before the copy is taken
    assert (out / "UVNAV_920917_1_083539_Pg100.svg").read_text().startswith("<svg")


def test_hardcopy_of_a_table_holds_the_whole_table(data_dir: Path) -> None:
    """A table taller and wider than an 80×24 terminal (40 rows, a long last column): the
    hardcopy's text is every row and every column, the SVG the screen (the text was the
    screen too, rows and the last column cut)."""
    from uvnav_tui.screens.table_screen import TableScreen

    app = make_app(data_dir)
    columns = ("t", "Time", "Note")
    rows = [[f"+{i}:00", f"10:{i:02d}:00Z", f"row {i} " + "x" * 60 + f" end {i}"]
            for i in range(40)]

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 2)
        app.push_screen(TableScreen("Kalman ▸ Predict.", "a long table", columns, rows,
                                    hardcopy_name="Predict"))
        await wait_for(pilot, lambda: isinstance(app.screen, TableScreen), "the table")
        await pilot.pause()
        assert app.actions.write_hardcopy() is not None

    drive(app, script, size=(80, 24))
    out = data_dir / "hardcopy"
    text = (out / "UVNAV_920917_1_083539_Predict.txt").read_text(encoding="utf-8")
    lines = text.splitlines()
    assert lines[:2] == ["Kalman ▸ Predict.", "a long table"]
    assert lines[3].split() == ["t", "Time", "Note"]
    assert len(lines) == 5 + 40
    assert all(f"end {i}" in lines[5 + i] for i in range(40))
    assert (out / "UVNAV_920917_1_083539_Predict.svg").read_text().startswith("<svg")


def test_setup_params(data_dir: Path) -> None:
    """Setup ▸ Params ▸ Datum / DR Pos / Current: bad entries are rejected and kept; good ones
    change the working datum, the DR position and the current."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 2)
        await menu(pilot, "alt+s", "p", "d")
        field = await fill(pilot, "datum-name", "ED51")
        assert message_of(field).startswith("Unknown datum !")
        await menu(pilot, "enter")
        assert isinstance(app.screen, Dialog) and field.text == "ED51"
        await fill(pilot, "datum-name", "wgs84")
        await menu(pilot, "enter")
        assert app.control.session.config.datum == "WGS84"
        await app.wait_cycles(1)
        assert app.control.latest.datum == "WGS84"
        assert "Datum : WGS84" in text_of(app)

        await menu(pilot, "alt+s", "p", "p")
        field = await fill(pilot, "dr-position", "52 51 N 004 32")
        assert message_of(field) == "Wrong position input format !"
        await fill(pilot, "dr-position", "52 51.0 N 004 32.0 E")
        await menu(pilot, "enter")
        nav = app.control.session.nav
        assert nav.mpp_lat_deg == pytest.approx(52 + 51 / 60)
        assert nav.mpp_lon_deg == pytest.approx(4 + 32 / 60)

        await menu(pilot, "alt+s", "p", "c")
        speed = await fill(pilot, "current-speed", "99")
        assert message_of(speed) == "Wrong speed input !"
        direction = await fill(pilot, "current-set", "3x0")
        assert message_of(direction) == "Wrong direction input !"
        await menu(pilot, "enter")
        assert isinstance(app.screen, Dialog)
        assert (speed.text, direction.text) == ("99", "3x0")
        await fill(pilot, "current-speed", "1.5")
        await fill(pilot, "current-set", "270")
        await menu(pilot, "enter")
        cfg = app.control.session.config
        assert (cfg.current_speed_kn, cfg.current_set_deg) == (1.5, 270.0)

    drive(app, script)


def test_develop_and_reset(data_dir: Path) -> None:
    """Setup ▸ Params ▸ Develop shows the Data menu and developer items; Reset hides them."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        assert "Data" not in text_of(app).splitlines()[0]
        await menu(pilot, "alt+s", "p", "v")
        assert app.dev_mode
        assert " Data " in text_of(app).splitlines()[0]
        await menu(pilot, "alt+a", "w")
        assert app.page == 830
        assert "Pg 830" in text_of(app) and "Weight matrix W = Cl⁻¹ :" in text_of(app)
        await menu(pilot, "alt+s", "p", "r")
        assert not app.dev_mode and app.page == 100
        assert "Data" not in text_of(app).splitlines()[0]

    drive(app, script)


def test_setup_systems(data_dir: Path) -> None:
    """Setup ▸ Systems: GPS off and on with a P-code receiver; Decca zone/lane checks and
    pattern selection; SINS, Omega and Loran-C listed but not connected."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        await menu(pilot, "alt+s", "y", "g", "space", "enter")
        assert not app.control.session.config.gps.on
        await app.wait_cycles(1)
        assert app.control.latest.systems == "....D"
        await menu(pilot, "alt+s", "y", "g", "space", "tab", "right", "space", "enter")
        gps = app.control.session.config.gps
        assert gps.on and gps.receiver == "P"

        await menu(pilot, "alt+s", "y", "d")
        red = await fill(pilot, "decca-red", "B24")
        assert message_of(red) == "Wrong zone/lane input !"
        await menu(pilot, "enter")
        assert isinstance(app.screen, Dialog) and red.text == "B24"
        await fill(pilot, "decca-red", "b21")
        await fill(pilot, "decca-purple", "")
        await menu(pilot, "tab", "tab", "tab", "space")  # use Purple, which has no entry
        await menu(pilot, "enter")
        assert isinstance(app.screen, Dialog)
        assert "No zone/lane entered for this pattern !" in text_of(app)
        await menu(pilot, "space", "enter")  # deselect Purple again
        decca = app.control.session.config.decca
        assert (decca.red, decca.purple, decca.select) == ("B21", "", ("red", "green"))

        for key, name in (("s", "SINS"), ("o", "Omega"), ("l", "Loran-C")):
            await menu(pilot, "alt+s", "y", key)
            assert app.message == f"{name}: System not connected !"
            assert "System not connected !" in text_of(app)

    drive(app, script)


def test_sensors(data_dir: Path) -> None:
    """Setup ▸ Sensors: switching the log off warns; the engine then has no log."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        await menu(pilot, "alt+s", "e")
        assert "Gyro and log" not in text_of(app)
        await menu(pilot, "tab", "space")  # log off
        assert "Gyro and log must stay switched on !" in text_of(app)
        await menu(pilot, "tab", "space", "enter")  # rudder on
        sensors = app.control.session.config.sensors
        assert (sensors.gyro, sensors.log, sensors.rudder) == ("on", "off", "on")
        await app.wait_cycles(1)
        assert app.control.latest.sensors.status[:3] == (1, 0, 1)
        assert "LOG OFF" in text_of(app) and "RUDR " in text_of(app)

    drive(app, script)


# ------------------------------------------------------------------------------------------
# Obs


def test_obs_bearing(data_dir: Path) -> None:
    """Obs ▸ Bearing: a periscope bearing is queued with the periscope σ."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        await menu(pilot, "alt+o", "b")
        await fill(pilot, "obs-station", "Heiloo")
        pos = await fill(pilot, "obs-position", "52 35 30 N 4 43")
        assert message_of(pos) == "Wrong position input format !"
        pos = await fill(pilot, "obs-position", "52 35 30.089 N 004 43 47.118 E")
        brg = await fill(pilot, "obs-bearing", "361")
        assert message_of(brg) == "Wrong bearing input !"
        await menu(pilot, "enter")
        assert isinstance(app.screen, Dialog) and brg.text == "361"
        await fill(pilot, "obs-bearing", "152.5")
        await menu(pilot, "tab", "right", "space", "enter")  # taken with the periscope
        (obs,) = app.control.session.nav.pending_obs
        cfg = app.control.session.config
        assert (obs.kind, obs.station, obs.value, obs.sensor) == (
            "bearing", "Heiloo", 152.5, "periscope")
        assert obs.sigma == cfg.lsq.sigma_periscope_deg
        assert obs.lat_deg == pytest.approx(52 + 35 / 60 + 30.089 / 3600)
        await app.wait_cycles(1)
        assert app.control.latest.manual == (obs,)
        assert app.control.session.nav.pending_obs == ()

    drive(app, script)


def test_obs_distance_and_radar(data_dir: Path) -> None:
    """Obs ▸ Distance in nm (×1852 m) and Obs ▸ Radar (bearing + distance, one station)."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        await menu(pilot, "alt+o", "d")
        await fill(pilot, "obs-station", "Heiloo")
        await fill(pilot, "obs-position", "52 35.5 N 4 43.8 E")
        dist = await fill(pilot, "obs-distance", "0")
        assert message_of(dist) == "Wrong distance input !"
        await fill(pilot, "obs-distance", "17.5")
        await menu(pilot, "enter")
        await menu(pilot, "alt+o", "r")
        station = await fill(pilot, "obs-station", "   ")
        assert message_of(station) == "Wrong station name !"
        await fill(pilot, "obs-station", "Den Helder")
        await fill(pilot, "obs-position", "52 57 N 4 45 E")
        await fill(pilot, "obs-bearing", "40")
        await fill(pilot, "obs-distance", "9")
        await menu(pilot, "enter")
        lsq = app.control.session.config.lsq
        d, rb, rd = app.control.session.nav.pending_obs
        assert (d.kind, d.value, d.sigma, d.sensor) == (
            "distance", 17.5 * 1852, lsq.sigma_radar_range_m, "radar")
        assert (rb.kind, rb.value, rb.sigma, rb.sensor, rb.station) == (
            "bearing", 40.0, lsq.sigma_radar_bearing_deg, "radar", "Den Helder")
        assert (rd.kind, rd.value, rd.station) == ("distance", 9 * 1852.0, "Den Helder")

    drive(app, script)


# ------------------------------------------------------------------------------------------
# Kalman, Demo, Statistics


def test_kalman_menu(data_dir: Path) -> None:
    """Kalman ▸ Predict. (checked inputs; a table of positions and growing ellipses; the run is
    not changed), Kalman ▸ Smoothing (one position per cycle) and Kalman ▸ Filtering off."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 3)
        await menu(pilot, "alt+k", "p")
        interval = await fill(pilot, "predict-interval", "-1")
        assert message_of(interval) == "Wrong time interval input !"
        step = await fill(pilot, "predict-step", "abc")
        assert message_of(step) == "Wrong step size input !"
        step = await fill(pilot, "predict-step", "0.1")  # below the table's 1 s resolution
        assert message_of(step) == "Wrong step size input !"
        await fill(pilot, "predict-interval", "5")
        await fill(pilot, "predict-step", "30")
        await menu(pilot, "enter")
        assert isinstance(app.screen, TableScreen)
        table = app.screen.query_one(DataTable)
        assert table.row_count == 10
        first, last = table.get_row_at(0), table.get_row_at(9)
        assert (first[0], first[1]) == ("+0:30", "08:36:10Z")
        assert (last[0], last[1]) == ("+5:00", "08:40:40Z")
        assert float(last[4][:-1]) > float(first[4][:-1])  # a grows
        before = app.control.cycles
        await menu(pilot, "escape")
        assert isinstance(app.screen, ConsoleScreen)
        assert app.control.cycles == before

        await menu(pilot, "alt+k", "s")
        await wait_for(pilot, lambda: isinstance(app.screen, TableScreen), "the smoothing table")
        table = app.screen.query_one(DataTable)
        assert table.row_count == 3
        assert table.get_row_at(2)[1] == "08:35:40Z"
        await menu(pilot, "escape")

        await menu(pilot, "alt+k", "f", "space", "enter")
        assert not app.control.session.config.filter.on
        await app.wait_cycles(1)
        assert app.control.latest.filter_status == "OFF"

    drive(app, script)


def test_demo_parameters(data_dir: Path) -> None:
    """Demo ▸ Parameters: the configuration's own checks; changes go in one command."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        await menu(pilot, "alt+d", "p")
        delta = await fill(pilot, "param-delta_t_s", "0")
        assert message_of(delta).startswith("Out of range")
        pace = await fill(pilot, "param-pace", "slow")
        assert message_of(pace) == 'Must be "real", "fast" or a multiplier like "x10" !'
        weight = await fill(pilot, "param-s_weight", "x")
        assert message_of(weight) == "Wrong number input !"
        await menu(pilot, "enter")
        assert isinstance(app.screen, Dialog)
        await fill(pilot, "param-delta_t_s", "2")
        await fill(pilot, "param-pace", "x10")
        await fill(pilot, "param-s_weight", "1.025")
        await menu(pilot, "enter")
        demo = app.control.session.config.demo
        assert (demo.delta_t_s, demo.pace, demo.s_weight) == (2, "x10", 1.025)

    drive(app, script)


def test_developer_parameter_dialogs(data_dir: Path) -> None:
    """Demo ▸ Corrections / LS params / Filter params exist only for the developer."""
    app = make_app(data_dir, dev_mode=True)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        await menu(pilot, "alt+d", "c")
        await fill(pilot, "param-decca_red_lanes", "0.02")
        await menu(pilot, "enter")
        await menu(pilot, "alt+d", "l")
        await fill(pilot, "param-lop_reject", "Y")
        await fill(pilot, "param-conf_region_pct", "99")
        cf = await fill(pilot, "param-decca_cf", "autumn")
        assert message_of(cf) == 'Decca.CF: "auto", a number > 0 or SD, WD, SN, WN !'
        await menu(pilot, "enter")
        assert isinstance(app.screen, Dialog) and cf.text == "autumn"  # kept, not applied
        await fill(pilot, "param-decca_cf", "winter night")
        await menu(pilot, "enter")
        await menu(pilot, "alt+d", "f")
        await fill(pilot, "param-q_scale", "2")
        tau = await fill(pilot, "param-fix_tau_s", "soon")
        assert message_of(tau) == '"auto" or a number !'
        await fill(pilot, "param-fix_tau_s", "300")
        await fill(pilot, "param-preset", "thesis")  # issue 11: sets model, p0, bias_noise
        await menu(pilot, "enter")
        cfg = app.control.session.config
        f = cfg.filter
        assert (f.preset, f.model, f.p0, f.bias_noise, f.fix_tau_s) == (
            "thesis", "thesis", "thesis", False, 300.0)
        assert f.fix_sigma_frac == "auto"  # not edited, not changed
        assert cfg.corrections.decca_red_lanes == 0.02
        assert (cfg.lsq.lop_reject, cfg.lsq.conf_region_pct) == ("Y", 99.0)
        assert cfg.lsq.decca_cf == 1.0 / 2.25  # winter night (A8.2)
        assert cfg.filter.q_scale == 2.0
        await menu(pilot, "alt+s", "p", "r", "alt+d", "l")
        screen = app.screen
        assert isinstance(screen, PulldownScreen)  # "l" picks nothing for the navigator
        # The navigator keeps the Demo page (Pg 710) and Parameters; the rest is dev-only (A4).
        assert [i.label for i in screen.level_items(0)] == ["Page", "Parameters"]

    drive(app, script)


def test_statistics_pages_and_sub_pages(data_dir: Path) -> None:
    """Statistics items open their numbered page beside the left status column; PgDn/PgUp
    cycle through the sub-pages of a group (THEORY D37); Data pages need developer mode."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 2)
        await menu(pilot, "alt+t", "s", "g")
        screen = text_of(app)
        assert app.page == 611 and "Pg 611" in screen and "GPS statistical data :" in screen
        assert "Systems: G...D" in screen and "LOPs : 4" in screen and "CM 005°00.00'E" in screen
        await pilot.press("pagedown")
        assert app.page == 615 and "Decca statistical data :" in text_of(app)
        await pilot.press("pagedown")
        assert app.page == 611
        await menu(pilot, "alt+t", "l")
        assert app.page == 631
        await pilot.press("pagedown")
        assert app.page == 633 and "S²" in text_of(app)
        await menu(pilot, "alt+t", "p", "l")
        assert app.page == 642
        await pilot.press("pagedown")
        assert app.page == 643
        await pilot.press("pageup", "pageup")
        assert app.page == 641 and "LSE :" in text_of(app)
        await pilot.press("pageup")
        assert app.page == 643
        app.show_page(850)  # as a script's "page 850" would: refused for the navigator
        assert app.page == 643 and "developer page" in app.message
        await menu(pilot, "alt+t", "m")
        assert app.page == 100 and "LSE" in text_of(app)
        await pilot.press("pagedown")
        assert app.page == 100

    drive(app, script)


def test_data_kalman_sub_pages(data_dir: Path) -> None:
    """Data ▸ Kalman (Pg 850) and its sub-pages 851–853 by PgDn, in developer mode."""
    app = make_app(data_dir, dev_mode=True)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 2)
        await menu(pilot, "alt+a", "k")
        assert app.page == 850
        seen = {app.page: text_of(app)}
        for _ in range(3):
            await pilot.press("pagedown")
            seen[app.page] = text_of(app)
        assert list(seen) == [850, 851, 852, 853]
        assert "transition matrix" in seen[852] and "gain K" in seen[853]
        await pilot.press("pagedown")
        assert app.page == 850
        await menu(pilot, "alt+s", "p", "r")
        assert app.page == 100  # leaving developer mode leaves the Data pages

    drive(app, script)


def test_a_question_not_asked_for_ignores_keys_typed_ahead() -> None:
    """The LOP question opens unasked, between keys typed for something else: until its arming
    time has passed (on its clock) Y, N, Esc and Return answer nothing; then they do."""
    from textual.app import App

    now = [100.0]
    answers: list[bool | None] = []

    class Host(App[None]):
        def on_mount(self) -> None:
            self.push_screen(ConfirmDialog("LOP rejection", "Discard LOP GPS Lat?", default=True,
                                           arm_s=LOP_QUESTION_ARM_S, clock=lambda: now[0]),
                             callback=answers.append)

    app = Host()

    async def script(pilot: Pilot[None]) -> None:
        await wait_for(pilot, lambda: isinstance(app.screen, ConfirmDialog), "the question")
        for key in ("enter", "y", "n", "escape"):
            await pilot.press(key)
        now[0] += LOP_QUESTION_ARM_S * 0.99
        await pilot.press("enter")
        assert isinstance(app.screen, ConfirmDialog) and answers == []
        now[0] += LOP_QUESTION_ARM_S * 0.02
        await pilot.press("enter")  # Yes is focused (the thesis' default answer)
        await wait_for(pilot, lambda: answers == [True], "the answer")

    async def main() -> None:
        async with app.run_test() as pilot:
            await script(pilot)

    asyncio.run(main())


def test_lop_kept_is_logged(tmp_path: Path) -> None:
    """LOPReject 'A', No: the LOP stays, and the .OUT says so with an ACT line as it does for a
    discarded one (a No, or a stray Esc, left no trace in the log)."""
    app = make_app(blunder_data(tmp_path), hold=False)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot)
        await wait_for(pilot, lambda: isinstance(app.screen, ConfirmDialog), "the LOP question")
        await wait_for(pilot, lambda: app.screen.armed, "the question to take answers")
        await pilot.press("escape")
        await wait_for(pilot, lambda: app.control.eof, "the end of the data file")
        out = app.control.session.out_path
        app.stop_run()
        acts = [ln for ln in out.read_text(encoding="utf-8").splitlines()
                if ln.startswith("ACT ")]
        assert acts == ['ACT cycle=5 text="LOP kept (0,): GPS Lat"']
        assert "LOP GPS Lat kept (monitored)" in [e.text for e in app.message_log.since(0)[1]]

    drive(app, script)


def test_lop_reject_ask(tmp_path: Path) -> None:
    """LOPReject 'A': a flagged LOP interrupts the run; Yes recomputes without it."""
    data_dir = blunder_data(tmp_path)
    app = make_app(data_dir, hold=False)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot)
        await wait_for(pilot, lambda: isinstance(app.screen, ConfirmDialog), "the LOP question")
        assert app.control.cycles == 5 and app.state_word == "Interrupted..."
        assert "Discard LOP GPS Lat?" in text_of(app)
        await wait_for(pilot, lambda: app.screen.armed, "the question to take answers")
        await pilot.press("y")
        await wait_for(pilot, lambda: app.control.eof, "the end of the data file")
        history = list(app.control.session.history)
        assert [r.n for r in history] == list(range(1, 11))
        fix = history[4].fix
        assert fix.candidate_slot is None and fix.n_used == 3
        assert not next(lop for lop in fix.lops if lop.slot == 0).used
        assert "LOP GPS Lat discarded" in app.message

    drive(app, script)

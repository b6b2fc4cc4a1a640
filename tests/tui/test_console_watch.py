"""Pilot tests of issue 16 ("the console fit for a watch"): operator and file text shown
literally, dialogs that change nothing nobody edited, bad records on the screen, the message
log, glyph check boxes, dialog labels and the use of tall terminals.

Each test here failed before its fix (noted per test)."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from test_console_support import (
    blunder_data,
    copy_data,
    drive,
    make_app,
    start,
    text_of,
    wait_for,
)
from textual.pilot import Pilot
from textual.widgets import Static

from engine.api import ManualObservation, lop_name
from uvnav_tui.app import UVNAVApp
from uvnav_tui.dialogs.dialog import Dialog
from uvnav_tui.dialogs.parameters_dialog import ParametersDialog
from uvnav_tui.screens.console_screen import ConsoleScreen
from uvnav_tui.screens.message_screen import MessageScreen
from uvnav_tui.widgets.message_line import MESSAGE_TTL_S, MessageLine
from uvnav_tui.widgets.message_log import MessageLog
from uvnav_tui.widgets.message_panel import MessagePanel
from uvnav_tui.widgets.status_column import StatusColumn
from uvnav_tui.widgets.validated_field import ValidatedField, number_text

SIZE = (100, 30)

NASTY = [
    "[/]",
    "[bold]Heiloo",
    "[link=x]Den Helder[/link]",
    "\\[",
    "Ærøskøbing ✓ Ω 灯台",
    "[" * 3 + "Texel" + "]" * 3,
    "Very long station name " * 6 + "[/]",
]
"""Operator text that Rich/Textual markup would eat, misread or choke on."""




async def paste(pilot: Pilot[None], text: str) -> None:
    """Replace the focused input's text with ``text`` (one key press for the whole text)."""
    pilot.app.copy_to_clipboard(text)
    await pilot.press("ctrl+a", "ctrl+k", "ctrl+v")


async def fill(pilot: Pilot[None], field_id: str, text: str) -> ValidatedField:
    """Focus field ``field_id`` and paste ``text`` over it."""
    field = pilot.app.screen.query_one(f"#{field_id}", ValidatedField)
    field.focus_input()
    await pilot.pause()
    await paste(pilot, text)
    return field


def flat(text: str) -> str:
    """Screen text without line breaks and frame characters (long texts wrap)."""
    for ch in "│┌┐└┘─\n":
        text = text.replace(ch, " ")
    return " ".join(text.split())


# ------------------------------------------------------------------------------------------
# 1. Operator text is data, never markup


def test_station_names_are_shown_literally(data_dir: Path) -> None:
    """Obs ▸ Bearing/Distance/Radar with names that are markup: the console does not die
    (before: MarkupError on ``[/]``) and the message line and the log show the name as typed."""
    app = make_app(data_dir, lop_policy="yes")

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        for i, name in enumerate(NASTY):
            kind = ("b", "d", "r")[i % 3]
            await pilot.press("alt+o", kind)
            await pilot.pause()
            await fill(pilot, "obs-station", name)
            await fill(pilot, "obs-position", "52 57 N 004 43 E")
            if kind in ("b", "r"):
                await fill(pilot, "obs-bearing", "48")
            if kind in ("d", "r"):
                await fill(pilot, "obs-distance", "3.5")
            await pilot.press("enter")
            await pilot.pause()
            assert isinstance(app.screen, ConsoleScreen)
            assert name in app.message
            line = app.screen.query_one(MessageLine).text
            assert name[:30] in line
            await app.wait_cycles(1)
        entries = app.message_log.since(0)[1]
        for name in NASTY:
            assert any(name in e.text for e in entries), name
        await pilot.press("f2")
        await pilot.pause()
        assert isinstance(app.screen, MessageScreen)
        shown = text_of(app)
        for name in NASTY[:5]:
            assert name in shown, name

    drive(app, script, size=(160, 50))


def test_every_dialog_field_takes_markup_text(data_dir: Path) -> None:
    """Every text field of every dialog: the nasty texts stay in the field as typed and the
    dialog keeps working (message lines and hints render literally)."""
    app = make_app(data_dir, dev_mode=True)
    actions = ["datum", "dr_pos", "current", "decca", "obs_bearing", "obs_radar", "predict",
               "demo_params", "demo_corrections", "demo_lsq", "demo_filter"]

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        for action in actions:
            app.do_menu_action(action)
            await pilot.pause()
            dialog = app.screen
            assert isinstance(dialog, Dialog), action
            for field in list(dialog.query(ValidatedField)):
                for text in (NASTY[0], NASTY[2], NASTY[3]):
                    await fill(pilot, field.id or "", text)
                    await pilot.pause()
                    assert field.text == text, (action, field.id)
            await pilot.press("escape")
            await pilot.pause()
            assert isinstance(app.screen, ConsoleScreen), action

    drive(app, script)


def test_hardcopy_path_with_markup_is_shown_literally(tmp_path: Path) -> None:
    """A hardcopy directory named like markup: the message names it as it is (before: the
    console died on the ``[/]`` in the path)."""
    data_dir = copy_data(tmp_path / "data")
    target = tmp_path / "hc [/] [bold]x"
    app = make_app(data_dir, hardcopy_dir=target)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        await pilot.press("alt+e", "h")
        for _ in range(50):
            await pilot.pause()
            if app.hardcopies:
                break
        assert app.hardcopies and str(target) in app.message
        assert str(target)[:40] in app.screen.query_one(MessageLine).text

    drive(app, script, size=(200, 30))


# ------------------------------------------------------------------------------------------
# 2. Data-file names with brackets


def add_markup_names(data_dir: Path) -> tuple[str, str]:
    """A datum and a Decca chain whose names are markup, copied from ED50 and chain 9B."""
    datum = "ED50 [/] [link=x]"
    dat = data_dir / "TO_WGS84.DAT"
    lines = dat.read_text().splitlines()
    ed50 = next(ln for ln in lines if ln.startswith("ED50\t"))
    lines.insert(lines.index(ed50) + 1, ed50.replace("ED50", datum, 1))
    dat.write_text("\n".join(lines) + "\n")
    chain = "[b]9B"
    chn = data_dir / "DECCA.CHN"
    text = chn.read_text()
    block = text[text.index("\n9B\n") + 1:text.index("\n2E\n") + 1]
    end = text.index("* End of Data")
    chn.write_text(text[:end] + block.replace("9B\n", f"{chain}\n", 1) + text[end:])
    return datum, chain


def test_datum_and_chain_names_with_brackets(data_dir: Path) -> None:
    """``ED50 [DMA]`` and ``ED50 [UKOOA]`` are listed as written (before: three ``ED50``), the
    start-up hint names them, and a datum and a chain named like markup work everywhere."""
    datum, chain = add_markup_names(data_dir)
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await pilot.pause()
        field = await fill(pilot, "init-datum", "ED5")
        await pilot.pause()
        hint = str(field.query_one(".field-message", Static).render())
        assert "ED50 [DMA]" in hint and "ED50 [UKOOA]" in hint and datum in hint
        await fill(pilot, "init-datum", "ED50")
        assert field.error is None
        await start(pilot, 1)
        await pilot.press("alt+s", "p", "d")
        await pilot.pause()
        listed = text_of(app)
        for name in ("ED50 [DMA]", "ED50 [UKOOA]", "WGS72 [DMA]", datum):
            assert name in listed, name
        await fill(pilot, "datum-name", datum)
        await pilot.press("enter")
        await pilot.pause()
        assert app.control.session.config.datum == datum
        await app.wait_cycles(1)
        assert f"Datum : {datum}" in text_of(app)
        app.do_menu_action("decca")
        await pilot.pause()
        assert chain in text_of(app)
        await pilot.press("escape")

    drive(app, script, size=(120, 40))


# ------------------------------------------------------------------------------------------
# 3. A dialog never changes a value nobody edited


def run_state(app: UVNAVApp) -> dict[str, Any]:
    """Everything an operator dialog could change: the configuration and the navigation
    state (positions, Decca lane tracking, the filter's x and P, pending observations)."""
    session = app.control.session
    nav = session.nav
    state: dict[str, Any] = {"config": session.config}
    for f in dataclasses.fields(nav):
        value = getattr(nav, f.name)
        if f.name == "filter" and value is not None:
            state["filter.x"] = np.array(value.x).tolist()
            state["filter.P"] = np.array(value.P).tolist()
        else:
            state[f.name] = repr(value)
    return state


DIALOGS = ["datum", "dr_pos", "current", "gps", "decca", "sensors", "filtering",
           "demo_params", "demo_corrections", "demo_lsq", "demo_filter"]


def test_ok_without_edits_changes_nothing(data_dir: Path) -> None:
    """Every setting dialog, opened and confirmed with Return: the run is exactly as before
    (before: Demo ▸ Parameters rounded press_ref_freq_hz 39939.662 to 39939.7, DR Pos reset the
    position to the rounded MPP, Current re-set the filter's current states, Decca reset the
    lane tracking)."""
    app = make_app(data_dir, name="DEMO", dev_mode=True)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 3)
        for action in DIALOGS:
            before = run_state(app)
            app.do_menu_action(action)
            await pilot.pause()
            assert isinstance(app.screen, Dialog), action
            await pilot.press("enter")
            await pilot.pause()
            assert isinstance(app.screen, ConsoleScreen), action
            after = run_state(app)
            changed = [k for k in before if before[k] != after[k]]
            assert not changed, (action, changed)

    drive(app, script)


def test_parameters_show_round_trip_digits(data_dir: Path) -> None:
    """Demo ▸ Parameters shows 39939.662 (before: 39939.7); editing one field changes that
    key only, and exactly to what was typed."""
    app = make_app(data_dir, name="DEMO")

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        await pilot.press("alt+d", "p")
        await pilot.pause()
        field = app.screen.query_one("#param-press_ref_freq_hz", ValidatedField)
        assert field.text == "39939.662"
        await fill(pilot, "param-plot_scale_m", "2500")
        sent: list[Any] = []
        apply = app.control.apply
        app.control.apply = lambda cmd: sent.append(cmd) or apply(cmd)  # type: ignore[method-assign]
        await pilot.press("enter")
        await pilot.pause()
        assert [c.values for c in sent] == [(("plot_scale_m", 2500.0),)]
        demo = app.control.session.config.demo
        assert demo.press_ref_freq_hz == 39939.662 and demo.plot_scale_m == 2500.0

    drive(app, script)


@pytest.mark.parametrize("value", [39939.662, 0.1, 1e-05, 123456789.123, 2.0, 1 / 3, 7])
def test_number_text_round_trips(value: float) -> None:
    """The pre-filled text reads back as the same float (the old ``{:g}`` kept 6 digits)."""
    text = number_text(value)
    assert float(text) == value
    assert not text.endswith(".0")


# ------------------------------------------------------------------------------------------
# 4. Bad .RUN records on the screen


def test_bad_record_reported_and_counted(data_dir: Path) -> None:
    """A record with a bad heading: the message line and the log name file, line and field,
    and the status column counts it (before: only a BAD line in the .OUT)."""
    run = data_dir / "920917_1.RUN"
    lines = run.read_text().splitlines()
    lines[3] = lines[3].replace("232.2", "2x2.2")
    run.write_text("\n".join(lines) + "\n")
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 3)
        texts = [e.text for e in app.message_log.since(0)[1]]
        bad = [t for t in texts if t.startswith("Bad record")]
        assert bad == ["Bad record skipped: 920917_1.RUN:4 heading: Not a number ! "
                       "(got '2x2.2')"], texts
        assert "Bad record skipped: 920917_1.RUN:4" in app.screen.query_one(MessageLine).text
        app.show_page(620)
        await pilot.pause()
        assert app.screen.query_one(StatusColumn).bad_records == 1
        assert "Bad rec : 1" in text_of(app)
        await app.wait_cycles(20)
        assert "End of data file (1 bad record skipped)" in text_of(app)

    drive(app, script)


def test_all_bad_file_says_so(data_dir: Path) -> None:
    """A file whose records are all bad ends with a note that says so (before: "End of data
    file" and ``Time --:--:--Z`` with no hint why)."""
    (data_dir / "ALLBAD.RUN").write_text(
        "Date\tTime\tGPS lat\n920917\t08353x\tjunk\n920917\t083539\t52 50 N\n")
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await pilot.pause()
        await fill(pilot, "init-run", "ALLBAD")
        await start(pilot)
        await app.wait_cycles(1)
        await pilot.pause()
        screen = text_of(app)
        assert "no valid record (2 bad, none used)" in screen
        texts = [e.text for e in app.message_log.since(0)[1]]
        assert sum(t.startswith("Bad record skipped: ALLBAD.RUN:") for t in texts) == 2

    drive(app, script)


# ------------------------------------------------------------------------------------------
# 5. Message log and message line


def test_message_line_shows_the_newest_and_ages() -> None:
    """The line shows the newest entry with its record time and clears after the TTL; the log
    keeps every entry, numbered for ever, the oldest dropped beyond its limit."""
    log = MessageLog(limit=3)
    for i in range(5):
        log.add(f"m{i}", None, "engine", wall_s=100.0 + i)
    assert log.total == 5 and len(log) == 3 and log.dropped == 2
    start, entries = log.since(0)
    assert start == 2 and [e.text for e in entries] == ["m2", "m3", "m4"]
    assert log.since(4)[1][0].text == "m4" and log.since(5)[1] == []
    line = MessageLine()
    line._log = log  # noqa: SLF001 - exercising the ageing without a running app
    line._entry = log.newest()  # noqa: SLF001
    line._update(104.0 + MESSAGE_TTL_S - 1)  # noqa: SLF001
    assert line.text == "--:--:--Z m4"
    line._update(104.0 + MESSAGE_TTL_S + 1)  # noqa: SLF001
    assert line.text == ""


def test_engine_messages_name_lops_as_the_dialogs(tmp_path: Path) -> None:
    """A GPS blunder under LOPReject 'A': the engine's messages say ``LOP GPS Lat`` (before:
    ``LOP 0`` / ``LOP in slot 0``), every message is in the log with its record time, and an old
    console message no longer hides them."""
    data_dir = blunder_data(tmp_path)
    app = make_app(data_dir, lop_policy="yes")

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 10)
        entries = app.message_log.since(0)[1]
        texts = [e.text for e in entries]
        assert any(t.startswith("LOP GPS Lat fails the w-test") for t in texts), texts
        assert any(t.startswith("LOP GPS Lat: w = ") for t in texts), texts
        assert "LOP GPS Lat discarded" in texts
        assert not any("LOP 0" in t or "slot 0" in t for t in texts)
        flagged = next(e for e in entries if e.text.startswith("LOP GPS Lat fails"))
        assert flagged.stamp == "08:35:42Z"
        out = app.control.session.out_path
        app.stop_run()
        assert "LOP discarded (0,): GPS Lat" in out.read_text()

    drive(app, script)


def test_lop_names() -> None:
    """Slots are named as on Pg 631 and in the dialogs."""
    obs = (ManualObservation("bearing", "[/]Heiloo", 52.6, 4.7, 48.0, 0.5, "periscope"),
           ManualObservation("distance", "Texel", 53.0, 4.8, 5000.0, 50.0, "radar"))
    assert [lop_name(s, manual=obs) for s in range(7)] == [
        "GPS Lat", "GPS Lon", "Decca Red", "Decca Grn", "Decca Prp",
        "periscope Brg [/]Heiloo", "radar Dist Texel"]
    assert lop_name(0, system="KF") == "KF Lat" and lop_name(9) == "slot 9"


def test_message_panel_on_tall_terminals(data_dir: Path) -> None:
    """Pg 100 at 160×50 shows the message log under the page; at 80×24 it has no room."""
    for size, shown in (((160, 50), True), ((80, 24), False)):
        app = make_app(data_dir)

        async def script(pilot: Pilot[None], shown: bool = shown, app: UVNAVApp = app) -> None:
            await start(pilot, 2)
            app.say("[/] panel check")
            await pilot.pause()
            panel = app.screen.query_one(MessagePanel)
            assert panel.display is shown
            if shown:
                assert panel.region.height >= 20
                assert "[/] panel check" in text_of(app)

        drive(app, script, size=size)


def test_message_panel_rewraps_when_the_terminal_grows(data_dir: Path) -> None:
    """Messages logged at 80×24 (the panel hidden: its lines wrapped at RichLog's 20-column
    minimum), then the terminal grown to 200×60: the panel's lines are as wide as it is, not
    a 60-character message cut into 20-column pieces (it stayed so until the next message)."""
    app = make_app(data_dir)
    text = "a message of sixty characters, so wider than twenty columns."

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 2)
        app.say(text)
        await pilot.pause()
        panel = app.screen.query_one(MessagePanel)
        assert panel.display is False
        await pilot.resize_terminal(200, 60)
        await wait_for(pilot, lambda: panel.display and panel.region.width > 100,
                       "the panel on the grown terminal")
        await pilot.pause()
        lines = [strip.text.rstrip() for strip in panel.lines]
        assert any(ln.endswith(text) for ln in lines), lines
        assert max(len(ln) for ln in lines) > 60

    drive(app, script, size=(80, 24))


def test_a_chain_chosen_since_does_not_label_the_last_cycles_lanes(data_dir: Path) -> None:
    """Setup ▸ Systems ▸ Decca to chain 2E with the run suspended: Pg 100 and Pg 615 go on
    naming 9B for the last cycle's 9B lanes and say 2E comes next (they showed "2E" beside 9B
    numbers); after the next cycle they show 2E alone."""
    from engine.api import SetDecca

    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 3)
        assert "Chain 9B" in text_of(app) and "next)" not in text_of(app)
        assert app.actions.apply(SetDecca(on=True, chain="2E", red="B20", green="F34", purple="A51",
                                                 select=("red", "green")))
        await pilot.pause()
        assert "Chain 9B (2E next)" in text_of(app)
        app.show_page(615)
        await pilot.pause()
        assert "Chain : 9B (2E from the next cycle)" in text_of(app)
        await app.wait_cycles(1)
        await pilot.pause()
        assert "Chain : 2E" in text_of(app) and "from the next cycle" not in text_of(app)
        app.show_page(100)
        await pilot.pause()
        assert "Chain 2E" in text_of(app) and "next)" not in text_of(app)

    drive(app, script)


# ------------------------------------------------------------------------------------------
# 7. State by glyphs


def test_check_boxes_and_radio_buttons_show_state_by_glyphs(data_dir: Path) -> None:
    """GPS dialog: ``[x] GPS on`` / ``[ ] GPS on`` and ``(•)`` on the receiver in force, also
    in the text hardcopy of the screen (before: ``▐X▌`` either way)."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        await pilot.press("alt+s", "y", "g")
        await pilot.pause()
        text = text_of(app)
        assert "[x] GPS on" in text and "(•) C/A code (SPS)" in text
        assert "( ) P code (PPS)" in text and "▐X▌" not in text
        await pilot.press("space")
        await pilot.pause()
        assert "[ ] GPS on" in text_of(app)
        app.actions.write_hardcopy()
        txt = app.hardcopies[-1][1].read_text()
        assert "[ ] GPS on" in txt and "(•) C/A code (SPS)" in txt

    drive(app, script)


# ------------------------------------------------------------------------------------------
# 8. Dialog labels and sizes


def test_parameter_labels_and_sizes(data_dir: Path) -> None:
    """Human labels with units; the pace message is shown whole; at 80×24 the dialog fits and
    at 160×50 all twenty filter fields show without scrolling (before: raw keys, a cut message,
    a 16-row list at any size)."""
    for size in ((80, 24), (160, 50)):
        app = make_app(data_dir, name="DEMO", dev_mode=True)

        async def script(pilot: Pilot[None], size: tuple[int, int] = size,
                         app: UVNAVApp = app) -> None:
            await start(pilot, 1)
            await pilot.press("alt+d", "p")
            await pilot.pause()
            text = text_of(app)
            assert "Pressure reference frequency (Hz)" in text
            assert "press_ref_freq_hz" not in text.split("[demo]")[0]
            await fill(pilot, "param-pace", "slow")
            await pilot.pause()
            assert 'Must be "real", "fast" or a multiplier like "x10" !' in flat(text_of(app))
            frame = app.screen.query_one("#dialog-frame")
            assert frame.region.bottom <= size[1] and frame.region.right <= size[0]
            await pilot.press("escape")
            await pilot.pause()
            app.do_menu_action("demo_lsq")
            await pilot.pause()
            labels = {f.id: f.label for f in app.screen.query(ValidatedField)}
            assert labels["param-sigma_periscope_deg"] == "σ periscope bearing (°)"
            assert labels["param-decca_cf"] == "Decca CF (auto/SD/WD/SN/WN/no.)"
            if size == (160, 50):  # the whole list shows: no raw key anywhere but the help
                text = text_of(app).split("[lsq]")[0]
                assert "σ periscope bearing (°)" in text and "sigma_" not in text
            await pilot.press("escape")
            await pilot.pause()
            app.do_menu_action("demo_filter")
            await pilot.pause()
            dialog = app.screen
            assert isinstance(dialog, ParametersDialog)
            fields = dialog.query_one("#param-fields")
            if size == (160, 50):
                assert fields.max_scroll_y == 0
            assert dialog.query_one("#dialog-frame").region.bottom <= size[1]

        drive(app, script, size=size)


def test_modified_data_file_is_warned_on_the_console(tmp_path: Path) -> None:
    """A DECCA.CHN that differs from the bundled one (here only a comment line is added, so it
    still loads) is said on the message line and kept in the log when the run starts, as
    `uvnav replay` says it on standard error (issue 15 item 5)."""
    data = copy_data(tmp_path / "data")
    chn = data / "DECCA.CHN"
    chn.write_bytes(b"* a local edit\n" + chn.read_bytes())
    app = make_app(data)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        await pilot.pause()
        log = [e.text for e in app.message_log.since(0)[1]]
        assert any(t.startswith("Warning: ") and "DECCA.CHN: differs from the bundled" in t
                   for t in log), log
        assert not any("TO_WGS84.DAT" in t for t in log)  # the datum file is the shipped one

    drive(app, script)


def test_a_new_run_does_not_show_the_last_runs_message(tmp_path: Path) -> None:
    """Run ▸ Start while the last run's message is still fresh on the message line: the new
    run's screen does not show it (it did, its record time later than the new run's clock);
    the message log (F2) keeps it."""
    from uvnav_tui.dialogs.confirm_dialog import ConfirmDialog
    from uvnav_tui.dialogs.init_dialog import InitDialog

    data_dir = blunder_data(tmp_path)
    app = make_app(data_dir, lop_policy="yes")

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 10)
        line = app.screen.query_one(MessageLine)
        old = line.text
        assert old, "the first run left no message to carry over"
        app.do_menu_action("run_start")
        await wait_for(pilot, lambda: isinstance(app.screen, ConfirmDialog), "the question")
        await pilot.press("y")
        await wait_for(pilot, lambda: isinstance(app.screen, InitDialog), "the init dialog")
        await pilot.press("enter")
        await wait_for(pilot, lambda: app.control is not None and app.control.cycles == 0
                       and not isinstance(app.screen, InitDialog), "the new run")
        await pilot.pause()
        assert app.screen.query_one(MessageLine).text != old
        assert any(e.line() == old for e in app.message_log.since(0)[1])

    drive(app, script)

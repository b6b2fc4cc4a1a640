"""Keys typed ahead land where the operator meant them: every key reaches the widget that has
the focus once the keys before it have been handled, whatever the pace.  The keys here are
queued in one go (no key waits for the one before, as a fast typist or ``tmux send-keys`` with
0–20 ms gaps delivers them), so the dialog a key opens is not on screen yet when the next keys
arrive.

Every wait is for a condition (:func:`test_console_support.wait_for`), never a fixed time."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from test_console_support import drive, make_app, start, wait_for
from textual import events
from textual._xterm_parser import XTermParser
from textual.command import CommandPalette
from textual.pilot import Pilot

from uvnav_tui.app import UVNAVApp
from uvnav_tui.dialogs.init_dialog import InitDialog
from uvnav_tui.dialogs.obs_dialog import ObsDialog
from uvnav_tui.screens.console_screen import ConsoleScreen
from uvnav_tui.terminal import ConsoleKeyParser
from uvnav_tui.widgets.validated_field import ValidatedField

TYPED_S = 20.0
"""Seconds the typed keys may take to be handled on the loaded 2-core machine (each takes
milliseconds; the wait ends as soon as they are)."""


def keys_of(text: str) -> list[str]:
    """The key names that type ``text`` (space as ``space``)."""
    return ["space" if c == " " else c for c in text]


def type_ahead(app: UVNAVApp, *keys: str) -> None:
    """Queue ``keys`` in the app's input queue in one go, as the terminal driver does: no key
    waits for the previous one to be handled."""
    for key in keys:
        char = " " if key == "space" else key if len(key) == 1 else None
        app.post_message(events.Key(key, char))


def field_text(app: UVNAVApp, field_id: str) -> str:
    """What is typed in the field ``field_id`` of the screen on top."""
    return app.screen.query_one(f"#{field_id}", ValidatedField).text


def test_obs_radar_typed_ahead_fills_each_field(data_dir: Path) -> None:
    """``Alt+O r`` then ``ABC Tab 52 35 30 N 004 43 47 E Tab 150 Tab 20`` in one go: each part
    in its own field.  Before, everything went into the station name (the dialog's fields did
    not exist yet, and each Tab moved the focus after the keys behind it had been delivered):
    ``ABC52 35 30 N 004 43 47 E15020``."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 2)
        type_ahead(app, "alt+o", "r", *keys_of("ABC"), "tab",
                   *keys_of("52 35 30 N 004 43 47 E"), "tab", *keys_of("150"), "tab",
                   *keys_of("20"))
        await wait_for(pilot, lambda: isinstance(app.screen, ObsDialog)
                       and app.screen.is_mounted and field_text(app, "obs-distance") == "20",
                       "the distance typed", TYPED_S)
        assert field_text(app, "obs-station") == "ABC"
        assert field_text(app, "obs-position") == "52 35 30 N 004 43 47 E"
        assert field_text(app, "obs-bearing") == "150"

    drive(app, script)


def test_parameter_initialization_typed_ahead_at_start(data_dir: Path) -> None:
    """Typed from the moment the console starts, before Parameter Initialization is drawn:
    ``Tab Ctrl+U 52 50 N 4 30 E Tab Ctrl+U 10`` leaves the datum as it was and puts the position
    and the depth in their fields.  Before: ``WGS8452 50 N 4 30 E10`` in the datum field."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        type_ahead(app, "tab", "ctrl+u", *keys_of("52 50 N 4 30 E"), "tab", "ctrl+u",
                   *keys_of("10"))
        await wait_for(pilot, lambda: isinstance(app.screen, InitDialog)
                       and app.screen.is_mounted and field_text(app, "init-depth") == "10",
                       "the depth typed", TYPED_S)
        assert field_text(app, "init-datum") == app.base_config.datum
        assert field_text(app, "init-dr") == "52 50 N 4 30 E"

    drive(app, script)


def test_escape_closes_the_palette_typed_ahead(data_dir: Path) -> None:
    """On a page, ``6 4 3 Ctrl+P Esc 1 0 0`` in one go: Pg 643, the palette opened and closed,
    then Pg 100.  Before, the Esc was lost and the palette stayed open, taking ``100``."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 2)
        type_ahead(app, "6", "4", "3", "ctrl+p", "escape", "1", "0", "0")
        await wait_for(pilot, lambda: app.page == 100 and isinstance(app.screen, ConsoleScreen)
                       and not app.screen.query_one("#hint-line").typed,  # type: ignore
                       "Pg 100 with no palette open", TYPED_S)
        assert not any(isinstance(s, CommandPalette) for s in app.screen_stack)

    drive(app, script, size=(80, 24))


def test_dialog_typed_ahead_during_a_fast_run(data_dir: Path) -> None:
    """The Obs ▸ Bearing dialog typed ahead while the run goes at pace fast (the worker asks
    for a refresh whenever the UI has handled the last one): the fields are filled as typed."""
    app = make_app(data_dir, "DEMO", hold=False)
    # no LOP question in between (LOPReject 'N'): it would take the focus from the dialog
    app.base_config = replace(app.base_config, lsq=replace(app.base_config.lsq, lop_reject="N"))

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot)
        run = app.control
        assert run is not None
        await wait_for(pilot, lambda: run.cycles >= 20, "20 cycles")
        type_ahead(app, "alt+o", "b", *keys_of("XYZ"), "tab", *keys_of("52 40 N 4 40 E"),
                   "tab", *keys_of("45"))
        await wait_for(pilot, lambda: isinstance(app.screen, ObsDialog)
                       and app.screen.is_mounted and field_text(app, "obs-bearing") == "45",
                       "the bearing typed", TYPED_S)
        assert field_text(app, "obs-station") == "XYZ"
        assert field_text(app, "obs-position") == "52 40 N 4 40 E"
        type_ahead(app, "escape")
        await wait_for(pilot, lambda: isinstance(app.screen, ConsoleScreen), "dialog closed")
        app.actions.run_suspend()

    drive(app, script)


# ------------------------------------------------------------------------------------------
# The terminal's bytes: Esc and Alt+letter typed fast


def parsed_keys(parser: XTermParser, *chunks: str) -> list[str]:
    """The keys ``parser`` reads from ``chunks``, each arriving as one read (a key at a time,
    less than the 100 ms escape delay apart, as at typing speed)."""
    return [event.key for chunk in chunks for event in parser.feed(chunk)
            if isinstance(event, events.Key)]


def test_alt_letter_and_esc_typed_fast_are_read_as_typed() -> None:
    """``Alt+O r A``, ``Esc 1 0`` and ``Esc Ctrl+P`` with each key a separate read less than
    100 ms after the one before: read as typed; cursor and function keys (``ESC [ A``,
    ``ESC O P``) are unchanged.  Textual's own parser read the first as ``^ o r A`` (no menu)
    and the second as ``¡ 0`` (the Esc lost), as checked here too."""
    chunks = ("\x1bo", "r", "A", "\x1b", "1", "0", "\x1b[A", "\x1bOP", "\x1b", "\x10", "x")
    assert parsed_keys(ConsoleKeyParser(), *chunks) == [
        "alt+o", "r", "A", "escape", "1", "0", "up", "f1", "escape", "ctrl+p", "x"]
    textual_keys = parsed_keys(XTermParser(), *chunks)
    assert textual_keys[:6] == ["circumflex_accent", "o", "r", "A",
                                "inverted_exclamation_mark", "0"]


def test_pasted_text_takes_its_turn(data_dir: Path) -> None:
    """Text pasted right behind ``Alt+O r`` (a terminal's bracketed paste) goes into the
    station name, and the keys typed after it into the next field: the paste waits for the
    dialog as a key does.  Before, the paste went to the page, before the dialog existed."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 2)
        type_ahead(app, "alt+o", "r")
        app.post_message(events.Paste("Heiloo"))
        type_ahead(app, "tab", *keys_of("52 35 N 4 40 E"))
        await wait_for(pilot, lambda: isinstance(app.screen, ObsDialog) and app.screen.is_mounted
                       and field_text(app, "obs-position") == "52 35 N 4 40 E",
                       "the position typed", TYPED_S)
        assert field_text(app, "obs-station") == "Heiloo"

    drive(app, script)

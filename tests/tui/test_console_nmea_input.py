"""The console's run-file field takes an NMEA 0183 log (by content, docs/NMEA.md)."""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path

from test_console_support import drive, make_app, start, wait_for
from textual.pilot import Pilot
from textual.widgets import Static

from tests.nmea_lines import voyage
from uvnav_tui.dialogs.init_dialog import NOT_A_RUN_FILE_MESSAGE, InitDialog, _shown_run_name
from uvnav_tui.widgets.validated_field import ValidatedField


async def _paste(pilot: Pilot[None], field_id: str, text: str) -> ValidatedField:
    field = pilot.app.screen.query_one(f"#{field_id}", ValidatedField)
    field.focus_input()
    await pilot.pause()
    pilot.app.copy_to_clipboard(text)
    await pilot.press("ctrl+a", "ctrl+k", "ctrl+v")
    return field


def test_shown_run_name() -> None:
    assert _shown_run_name("/x/920917_1.RUN") == "920917_1"
    assert _shown_run_name("920917_1") == "920917_1"
    assert _shown_run_name("/x/trip.nmea") == "trip.nmea"


def test_init_dialog_runs_an_nmea_log(data_dir: Path) -> None:
    lines = [ln for ln in voyage(10, damage=False) if ln[3:6] not in ("HDT", "VHW")]  # a yacht
    (data_dir / "trip.nmea").write_text("\n".join(lines) + "\n")
    (data_dir / "notes.txt").write_text("not a log\n")
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await wait_for(pilot, lambda: isinstance(app.screen, InitDialog)
                       and app.screen.is_mounted, "Parameter Initialization")
        field = await _paste(pilot, "init-run", "notes.txt")
        message = str(field.query_one(".field-message", Static).render()).strip()
        assert message == NOT_A_RUN_FILE_MESSAGE and field.error is not None
        field = await _paste(pilot, "init-run", "trip.nmea")
        assert field.error is None and field.parsed == "trip.nmea"
        await start(pilot, cycles=3)
        session = app.control.session  # type: ignore[union-attr]
        assert session.nmea_stats is not None
        assert session.config.run_path == data_dir / "trip.nmea"
        assert session.last is not None
        assert session.last.time == datetime(2026, 12, 2, 12, 0, 2, tzinfo=UTC)
        texts = [e.text for e in app.message_log.since(0)[1]]
        assert "NMEA log: no heading (HDT/HDG/VHW) in the log" in texts
        assert "NMEA log: no water speed (VHW/VBW) in the log" in texts
        assert not any("no depth" in t for t in texts)

    drive(app, script)


def test_console_says_where_the_variation_of_compass_headings_came_from(data_dir: Path) -> None:
    """A yacht log with a magnetic HDG and no variation: the heading is used with the IGRF-14
    variation and the console says so (model and value) when the run starts."""
    from tests.nmea_lines import nmea

    lines = [nmea("HCHDG,44.0,,,,") if ln[3:6] == "HDT" else ln
             for ln in voyage(10, damage=False)]
    (data_dir / "yacht.nmea").write_text("\n".join(lines) + "\n")
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await wait_for(pilot, lambda: isinstance(app.screen, InitDialog)
                       and app.screen.is_mounted, "Parameter Initialization")
        field = await _paste(pilot, "init-run", "yacht.nmea")
        assert field.error is None
        await start(pilot, cycles=3)
        texts = [e.text for e in app.message_log.since(0)[1]]
        said = [t for t in texts if "made true with the IGRF-14 variation" in t]
        assert len(said) == 1 and said[0].startswith(
            "NMEA log: magnetic headings without variation: ")
        assert "°E at 52.83°N 4.50°E on 2026-12-02" in said[0]
        assert not any("no heading" in t for t in texts)

    drive(app, script)

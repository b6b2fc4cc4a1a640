"""The LOP rejection question does not cover the row it asks about: it opens at the bottom of
the screen, so the flagged LOP's row on Pg 631 (LOP table) and Pg 633 (its w-test) stays in
view, and it says the row's residual itself."""

from __future__ import annotations

from pathlib import Path

import pytest
from textual.pilot import Pilot

from tests.tui.test_console_support import blunder_data, drive, make_app, start, text_of, wait_for
from uvnav_tui.dialogs.confirm_dialog import ConfirmDialog


@pytest.mark.parametrize(("size", "page"), [((80, 24), "633"), ((120, 40), "633"),
                                            ((200, 60), "631")])
def test_lop_question_leaves_the_row_in_view(tmp_path: Path, size: tuple[int, int],
                                             page: str) -> None:
    app = make_app(blunder_data(tmp_path), lop_policy="ask", hold=False, pace_override="x4")

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot)
        await pilot.press(*page)
        await wait_for(pilot, lambda: isinstance(app.screen, ConfirmDialog), "the question")
        await pilot.pause()
        frame = app.screen.query_one(".confirm-frame")
        lines = text_of(app).splitlines()
        rows = [i for i, ln in enumerate(lines) if "GPS" in ln and "Lat" in ln
                and "│" in ln[:20] and "LOP" not in ln]
        assert rows, "\n".join(lines)
        top, bottom = frame.region.y, frame.region.y + frame.region.height
        assert all(not (top <= i < bottom) for i in rows), (rows, top, bottom)
        assert "Its residual v = -145.6 m" in text_of(app)
        assert lines[-1].lstrip().startswith("Y Yes")  # the key line stays visible
        app.stop_run()

    drive(app, script, size=size)


def test_lop_question_on_pg100_leaves_the_newest_messages_in_view(tmp_path: Path) -> None:
    """On Pg 100 at 200×60 the question opens at the top (over the position boxes), so the
    message panel's line of the w-test's verdict stays in view."""
    app = make_app(blunder_data(tmp_path), lop_policy="ask", hold=False, pace_override="x4")

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot)
        await wait_for(pilot, lambda: isinstance(app.screen, ConfirmDialog), "the question")
        await pilot.pause()
        frame = app.screen.query_one(".confirm-frame")
        lines = text_of(app).splitlines()
        rows = [i for i, ln in enumerate(lines) if "WARN  LOP GPS Lat fails the w-test" in ln]
        assert rows, "\n".join(lines)
        assert frame.region.y + frame.region.height <= min(rows)
        app.stop_run()

    drive(app, script, size=(200, 60))

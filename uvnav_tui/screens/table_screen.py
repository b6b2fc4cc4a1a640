"""A full-page table over the console (Kalman ▸ Predict. results, Kalman ▸ Smoothing).

Esc or Return closes it; the run stays interrupted while it is open.  The menus work over it
(F10, Alt+letter): Edit ▸ Hardcopy saves the table itself, named after what it shows
(``…_Predict``, ``…_Smoothing``); any other menu item closes the table first.
"""

from __future__ import annotations

from collections.abc import Sequence
from datetime import datetime, timedelta
from typing import TYPE_CHECKING, cast

from textual.actions import SkipAction
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Vertical
from textual.screen import ModalScreen
from textual.widgets import Static

from engine.api import (
    format_angle_deg,
    format_lat_dms,
    format_lon_dms,
    format_metres,
    format_time_z,
)
from uvnav_tui.host import ConsoleHost
from uvnav_tui.keys_help import menu_key_bindings
from uvnav_tui.menus import visible_bar

if TYPE_CHECKING:
    from engine.api import CycleResult, PositionEstimate


class TableScreen(ModalScreen[None]):
    """Title, a note line and a read-only table."""

    CSS_PATH = "table_screen.tcss"

    BINDINGS = [
        Binding("escape", "close", "Close", show=False, priority=True),
        Binding("enter", "close", "Close", show=False, priority=True),
        Binding("question_mark", "app.help", "Help", show=False, priority=True),
        *menu_key_bindings(),
    ]

    def __init__(self, title: str, note: str, columns: Sequence[str],
                 rows: Sequence[Sequence[str]], *, hardcopy_name: str = "Table") -> None:
        super().__init__()
        self.hardcopy_name = hardcopy_name
        """What a hardcopy of this table is named after (``Predict``, ``Smoothing``)."""
        self.title_text = title
        self.note = note
        self.columns = list(columns)
        self.rows = [list(r) for r in rows]

    def compose(self) -> ComposeResult:
        """Frame with the table (DataTable is imported here: it is not needed at start-up)."""
        from textual.widgets import DataTable

        with Vertical(classes="table-frame") as frame:
            frame.border_title = self.title_text
            frame.border_subtitle = "Esc closes"
            yield Static(self.note, classes="table-note")
            yield DataTable(id="table", zebra_stripes=False, cursor_type="row")

    def on_mount(self) -> None:
        """Fill the table."""
        from textual.widgets import DataTable

        table = self.query_one(DataTable)
        table.add_columns(*self.columns)
        table.add_rows(self.rows)
        table.focus()

    def full_text(self) -> str:
        """The whole table as plain text (title, note, a header and every row, columns
        left-aligned two spaces apart): Edit ▸ Hardcopy's text file, which a screenshot of a
        table taller or wider than the terminal would cut."""
        widths = [max(len(str(c)), *(len(r[i]) for r in self.rows)) if self.rows else len(c)
                  for i, c in enumerate(self.columns)]

        def line(cells: Sequence[str]) -> str:
            return "  ".join(f"{c:<{w}}" for c, w in zip(cells, widths, strict=True)).rstrip()

        return "\n".join([self.title_text, self.note, "", line(self.columns),
                          line(["-" * w for w in widths]), *(line(r) for r in self.rows)]) + "\n"

    def help_topic(self) -> str:
        """F1 or ? over the table: what it shows, its columns and keys."""
        return (f"{self.title_text}\n\n{self.note}\n\n{TABLE_COLUMNS_HELP}\n\n"
                "↑ ↓ PgUp PgDn scroll, Esc or Enter closes, F10 or Alt+letter opens the menus "
                "(Alt+E H: a hardcopy of the whole table).")

    def action_open_menu(self, index: int) -> None:
        """F10: the menu bar over the table."""
        app = cast(ConsoleHost, self.app)
        app.open_menu(index)

    def action_open_hot(self, key: str) -> None:
        """Alt+letter: the bar menu with that hot-key (skipped if none is visible)."""
        app = cast(ConsoleHost, self.app)
        for i, item in enumerate(visible_bar(app.dev_mode)):
            if item.key == key:
                app.open_menu(i)
                return
        raise SkipAction()

    def action_close(self) -> None:
        """Back to the page."""
        self.dismiss(None)


PREDICT_COLUMNS = ("t", "Time", "Lat", "Lon", "a", "b", "Az")
TABLE_COLUMNS_HELP = (
    "Columns: t, the time after the last cycle (min:s) or # (the cycle); Time (UTC, record time); "
    "Lat, Lon on the working datum; a, b the error ellipse's semi-axes (m) at the ConfRegion "
    "level; Az the azimuth of a (°). 999.99: no ellipse (no filter state).")
"""The columns of both tables, for their help."""
SMOOTH_COLUMNS = ("#", "Time", "Lat", "Lon", "a", "b", "Az")


def estimate_row(offset: str, when: str, p: PositionEstimate, level: float) -> list[str]:
    """One row: offset, time, latitude, longitude, ellipse semi-axes a, b (m) at ``level``
    (0–1) and the azimuth of a (degrees); ``999.99`` where there is no ellipse."""
    a = b = az = "999.99"
    if p.ellipse is not None:
        sa, sb = p.ellipse.scaled(level)
        a, b = format_metres(sa, space=False), format_metres(sb, space=False)
        az = format_angle_deg(p.ellipse.az_deg)
    return [offset, when, format_lat_dms(p.lat_deg), format_lon_dms(p.lon_deg), a, b, az]


def predict_table(estimates: Sequence[PositionEstimate], start: datetime, horizon_s: float,
                  step_s: float, conf_pct: float) -> TableScreen:
    """Kalman ▸ Predict.: one row per step from ``start`` (the last one at the horizon), the
    ellipses at ``conf_pct`` %."""
    level = conf_pct / 100.0
    rows = []
    n_steps = len(estimates)
    for i, p in enumerate(estimates, start=1):
        t = step_s * i if i < n_steps else horizon_s
        rows.append(estimate_row(f"+{int(t // 60):d}:{int(t % 60):02d}",
                                 format_time_z(start + timedelta(seconds=t)), p, level))
    note = (f"From {format_time_z(start)}, step {step_s:g} s, interval {horizon_s / 60:g} min;"
            f" ellipse axes at {conf_pct:g} %.")
    return TableScreen("Kalman ▸ Predict.", note, PREDICT_COLUMNS, rows, hardcopy_name="Predict")


def smoothing_table(smoothed: Sequence[PositionEstimate], history: Sequence[CycleResult],
                    conf_pct: float) -> TableScreen:
    """Kalman ▸ Smoothing: the smoothed positions, timed by the last cycles of ``history``,
    the ellipses at ``conf_pct`` %."""
    level = conf_pct / 100.0
    times = [format_time_z(r.time) for r in history[-len(smoothed):]] \
        if len(smoothed) <= len(history) else [""] * len(smoothed)
    rows = [estimate_row(str(i), t, p, level)
            for i, (t, p) in enumerate(zip(times, smoothed, strict=True), start=1)]
    note = (f"Rauch-Tung-Striebel smoothing of the last {len(smoothed)} filter states "
            "(post-processing, not in the 1993 program).")
    return TableScreen("Kalman ▸ Smoothing", note, SMOOTH_COLUMNS, rows,
                       hardcopy_name="Smoothing")

"""The left status column of every page but Pg 100 (THEORY §12.7; thesis Pg 611 footer)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from textual.widgets import Static

from engine.api import (
    PLACEHOLDER,
    RunConfig,
    format_angle_deg,
    format_lat_dm,
    format_lon_dm,
    format_metres,
    format_time_z,
)

if TYPE_CHECKING:
    from engine.api import CycleResult


def fix_age_text(age_s: float | None) -> str:
    """``fix 37 s ago``, ``fix 12 min ago``, ``fix 2 h 05 min ago``; ``no fix yet`` (None)."""
    if age_s is None:
        return "no fix yet"
    s = int(age_s)
    if s < 120:
        return f"fix {s} s ago"
    if s < 3600:
        return f"fix {s // 60} min ago"
    return f"fix {s // 3600} h {s % 3600 // 60:02d} min ago"


def status_lines(r: CycleResult | None, cfg: RunConfig, bad_records: int = 0,
                 fix_age_s: float | None = None) -> list[str]:
    """``Time``, ``Systems:``, ``LOPs :``, ``Filter :``, ``CM``, ``MPP`` block (its source,
    ``DR`` while a live source is lost), ``RMS`` and the age of the last fix (not in the
    thesis); then ``Bad rec : N`` once ``.RUN`` records have been skipped as bad (not in the
    thesis either)."""
    bad = [f"Bad rec : {bad_records}"] if bad_records else []
    if r is None:
        return ["Time --:--:--Z", "Systems: .....", "LOPs : 0", "Filter : N/A", "CM", "", "MPP",
                *([""] + bad if bad else [])]
    level = cfg.lsq.conf_region_pct / 100.0
    a = b = PLACEHOLDER + " m"
    az = PLACEHOLDER
    ell = r.mpp.ellipse
    if ell is not None:
        sa, sb = ell.scaled(level)
        if math.isfinite(sa) and math.isfinite(sb):
            a, b, az = format_metres(sa), format_metres(sb), format_angle_deg(ell.az_deg)
    lops = r.fix.n_used if r.fix is not None and r.fix.ok else 0
    rms = PLACEHOLDER + " m"
    if r.fix is not None and r.fix.ok and math.isfinite(r.fix.rms_m):
        rms = format_metres(r.fix.rms_m)
    return [
        f"Time {format_time_z(r.time)}",
        f"Systems: {r.systems}",
        f"LOPs : {lops}",
        f"Filter : {r.filter_status}",
        f"CM {format_lon_dm(r.cm_deg)}",
        "",
        f"MPP {r.mpp.source}",
        f"Lat {format_lat_dm(r.mpp.lat_deg)}",
        f"Lon {format_lon_dm(r.mpp.lon_deg)}",
        f"a {a}",
        f"b {b}",
        f"Az {az}",
        "",
        f"RMS {rms}",
        fix_age_text(fix_age_s),
        *bad,
    ]


class StatusColumn(Static):
    """The column; :meth:`show` repaints it only when its text changes."""

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__("", id=id, markup=False)
        self._text = ""
        self.bad_records = 0
        """Bad ``.RUN`` records skipped so far (set by the console before :meth:`show`)."""
        self.fix_age_s: float | None = None
        """Seconds since the last fix (set by the console before :meth:`show`)."""
        self.dead_reckoned: CycleResult | None = None
        """The cycle with its MPP dead-reckoned while a live source is lost (set by the
        console before :meth:`show`): shown instead of the cycle's."""

    def show(self, r: CycleResult | None, cfg: RunConfig) -> None:
        """Render the cycle ``r`` (its dead-reckoned MPP while a live source is lost)."""
        if self.dead_reckoned is not None:
            r = self.dead_reckoned
        text = "\n".join(status_lines(r, cfg, self.bad_records, self.fix_age_s))
        if text != self._text:
            self._text = text
            self.update(text, layout=False)

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


def status_lines(r: CycleResult | None, cfg: RunConfig, bad_records: int = 0) -> list[str]:
    """``Time``, ``Systems:``, ``LOPs :``, ``Filter :``, ``CM``, ``MPP`` block and ``RMS``; then
    ``Bad rec : N`` once ``.RUN`` records have been skipped as bad (not in the thesis)."""
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
        "MPP",
        f"Lat {format_lat_dm(r.mpp.lat_deg)}",
        f"Lon {format_lon_dm(r.mpp.lon_deg)}",
        f"a {a}",
        f"b {b}",
        f"Az {az}",
        "",
        f"RMS {rms}",
        *bad,
    ]


class StatusColumn(Static):
    """The column; :meth:`show` repaints it only when its text changes."""

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__("", id=id, markup=False)
        self._text = ""
        self.bad_records = 0
        """Bad ``.RUN`` records skipped so far (set by the console before :meth:`show`)."""

    def show(self, r: CycleResult | None, cfg: RunConfig) -> None:
        """Render the cycle ``r``."""
        text = "\n".join(status_lines(r, cfg, self.bad_records))
        if text != self._text:
            self._text = text
            self.update(text, layout=False)

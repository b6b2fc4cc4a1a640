"""Pg 641, Statistics ▸ Position ▸ Positions (THEORY §12.8; thesis L9102–9119, THEORY
§14.4).

The LSE, the filter's prediction (KF, P_{k+1|k}) and the MPP, each as latitude, longitude and
grid x/y; the a posteriori VCV of the MPP (m², x/y) and its ellipse: standard and ``ConfRegion``
semi-axes a b c, azimuth and elevation of the major axis::

    Datum : ED50   Projection : TM   CM : 005°00'00.000" E
              Lat               Lon                  x           y
    LSE : 52°50'32.373" N  004°31'50.958" E   -31615.40  5857300.16
    KF  : 52°49'59.742" N  004°29'59.447" E   -33709.65  5856305.50
    MPP : 52°50'32.373" N  004°31'50.958" E   -31615.40  5857300.16
    a posteriori VCV matrix of MPP :  814.936  -298.408 …
    Standard : 30.59  8.73  0.00       95.0% : 74.87  21.37  0.00
    Azimuth : 112.0                    Elevation : 0.0
"""

from __future__ import annotations

import numpy as np

from engine.api import (
    CycleResult,
    PositionEstimate,
    Session,
    format_lat_dms,
    format_lon_dms,
    lse_estimate,
)
from uvnav_tui.pages.page_text import MISSING, TextPage, conf_level, labelled_matrix, num, pct
from uvnav_tui.pages.registry import register_page

PAGE_NUMBER = 641
TITLE = "Positions :"
SOURCES = {"KF": "filtered (KF)", "LSE": "least squares (LSE)", "DR": "dead reckoning"}


def position_line(label: str, p: PositionEstimate | None) -> str:
    """``LSE : 52°50'32.373" N  004°31'50.958" E   -31615.40  5857300.16``."""
    head = f"{label:<3} : "
    if p is None:
        return head + MISSING
    return (head + format_lat_dms(p.lat_deg) + "  " + format_lon_dms(p.lon_deg)
            + num(p.x_m, 2, 12) + num(p.y_m, 2, 12))


def render(r: CycleResult, session: Session) -> str:
    """The text of Pg 641 for cycle ``r``."""
    mpp = r.mpp
    out = [
        TITLE,
        "",
        f"Datum : {r.datum}   Projection : TM   CM : {format_lon_dms(r.cm_deg)}",
        " " * 10 + "Lat".ljust(18) + "Lon".ljust(16) + "x".rjust(9) + "y".rjust(12),
        position_line("LSE", lse_estimate(r)),
        position_line("KF", r.kf_pred),
        position_line("MPP", mpp),
        "",
        f"MPP source : {SOURCES.get(mpp.source, mpp.source)}   Filter : {r.filter_status}",
        "",
    ]
    cov = np.asarray(mpp.cov)
    if np.all(np.isfinite(cov)):
        out += labelled_matrix("a posteriori VCV matrix of MPP :", cov[:2, :2], 3, 10)
    else:
        out.append(f"a posteriori VCV matrix of MPP : {MISSING}")
    ell = mpp.ellipse
    level = conf_level(session)
    if ell is None:
        out += ["", f"Standard : {MISSING}", f"Azimuth : {MISSING}"]
    else:
        a, b = ell.scaled(level)
        # The MPP's region is a horizontal ellipse: c = 0 and elevation 0 (THEORY §12.8).
        std = f"Standard : {num(ell.a_m, 2)}  {num(ell.b_m, 2)}  {num(0.0, 2)}"
        conf = f"{pct(level)} : {num(a, 2)}  {num(b, 2)}  {num(0.0, 2)}"
        out += [
            "",
            std.ljust(35) + conf,
            f"Azimuth : {num(ell.az_deg, 1)}".ljust(35) + f"Elevation : {num(0.0, 1)}",
        ]
    return "\n".join(out)


class PositionsPage(TextPage):
    """Pg 641 body."""

    NUMBER = PAGE_NUMBER
    TITLE = TITLE


register_page(PAGE_NUMBER, "Positions", PositionsPage)

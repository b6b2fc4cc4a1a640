"""Pg 631, Statistics ▸ LSE: the LOP table (THEORY §12.8; thesis L9046–9075, THEORY §14.2).

One row per LOP of the fix in slot order (GPS Lat/Lon or the filter's KF pseudo-LOPs, Decca
Red/Grn/Prp, then Brg/Dist observations): the reading on the working datum, the correction C-O,
the value computed at the LSE, the metric residual v (m, blank when not used), the LOP azimuth
(°) and ``*`` when used (``R`` rejected by the w-test, ``?`` the operator is asked).  Footer:
datum, projection and CM, the LS MPP (the LSE) and its ``ConfRegion`` ellipse::

    Syst  Pat  Read          C-O   Calc               v      Az  Sel
    GPS   Lat  52°50.55'N    0.00  52°50.54'N     -12.5    90.0   *
    Decca Red  44.86        -0.05  44.81            1.6    61.3   *
    Datum : ED50  Proj.: TM  CM : 005°00'00.000" E
    MPP : 52°50'32.373" N 004°31'50.958" E
    a/b/c : 74.87m 21.37m 0.00m
    Az/elev. : 112.0° 0.0°
"""

from __future__ import annotations

from engine.api import (
    CycleResult,
    FixResult,
    LopRow,
    Session,
    format_angle_deg,
    format_lat_dm,
    format_lat_dms,
    format_lon_dm,
    format_lon_dms,
    format_metres,
    lse_estimate,
)
from uvnav_tui.pages.page_text import MISSING, TextPage, conf_axes, conf_level, num
from uvnav_tui.pages.registry import register_page

PAGE_NUMBER = 631
TITLE = "LOP table :"
HEADER = ("Syst".ljust(6) + "Pat".ljust(5) + "Read".ljust(13) + "C-O".rjust(6) + "  "
          + "Calc".ljust(13) + "v".rjust(8) + "Az".rjust(8) + "  Sel")


def _value(lop: LopRow, value: float) -> str:
    """A reading or calculated value in its row's unit (position, lanes, bearing, distance)."""
    if lop.pattern == "Lat":
        return format_lat_dm(value)
    if lop.pattern == "Lon":
        return format_lon_dm(value)
    if lop.pattern == "Brg":
        return format_angle_deg(value)
    if lop.pattern == "Dist":
        return format_metres(value, space=False)
    return num(value, 2)


def _sel(lop: LopRow, fix: FixResult) -> str:
    if lop.used:
        return "*"
    if lop.slot in fix.rejected_slots:
        return "R"
    if fix.candidate_slot == lop.slot:
        return "?"
    return ""


def lop_line(lop: LopRow, fix: FixResult) -> str:
    """One row of the table."""
    v = num(lop.v_m, 1, 8) if lop.used else " " * 8
    return (lop.system[:5].ljust(6) + lop.pattern.ljust(5) + _value(lop, lop.read).ljust(13)
            + num(lop.correction, 2, 6) + "  " + _value(lop, lop.calc).ljust(13) + v
            + num(lop.az_deg, 1, 8) + "   " + _sel(lop, fix)).rstrip()


def footer(r: CycleResult, session: Session) -> list[str]:
    """Datum/projection/CM and the LS MPP with its ellipse (a/b/c at ConfRegion, Az/elev.)."""
    out = [f"Datum : {r.datum}  Proj.: TM  CM : {format_lon_dms(r.cm_deg)}"]
    lse = lse_estimate(r)
    if lse is None:
        return out + ["MPP : no LSE this cycle"]
    out.append(f"MPP : {format_lat_dms(lse.lat_deg)} {format_lon_dms(lse.lon_deg)}")
    level = conf_level(session)
    axes = conf_axes(lse, level)
    if axes is None or lse.ellipse is None:
        return out + [f"a/b/c : {MISSING}", f"Az/elev. : {MISSING}"]
    # The LSE is 2-D: c = 0 and elevation 0 (THEORY §12.8).
    return out + [
        f"a/b/c : {format_metres(axes[0], space=False)} {format_metres(axes[1], space=False)} "
        f"{format_metres(0.0, space=False)}   ({100.0 * level:g} %)",
        f"Az/elev. : {format_angle_deg(lse.ellipse.az_deg)} {format_angle_deg(0.0)}",
    ]


def render(r: CycleResult, session: Session) -> str:
    """The text of Pg 631 for cycle ``r``."""
    out = [TITLE, ""]
    fix = r.fix
    if fix is None:
        out += ["No LOPs this cycle.", ""]
    elif not fix.lops:
        out += [f"No LS fix: {fix.reason or 'no LOPs'}", ""]
    else:
        out.append(HEADER)
        out += [lop_line(lop, fix) for lop in fix.lops]
        out.append("")
        notes = []
        if fix.rejected_slots:
            notes.append("R = rejected by the w-test")
        if fix.candidate_slot is not None:
            notes.append("? = fails the w-test, discard it?")
        if fix.uses_prior:
            notes.append("KF = filter prediction as two position LOPs (too few LOPs)")
        out += [";  ".join(notes), ""] if notes else []
    out += footer(r, session)
    return "\n".join(out)


class LopTablePage(TextPage):
    """Pg 631 body."""

    NUMBER = PAGE_NUMBER
    TITLE = TITLE


register_page(PAGE_NUMBER, "LOP table", LopTablePage)

"""Pg 611, Statistics ▸ Systems ▸ GPS (THEORY §12.8; thesis L9001–9004, THEORY §14.2).

The GPS fix on WGS84 (with the height that puts it at height 0 on the working datum) and on the
working datum, the grid observed / calculated values (obs = the converted fix, calc = the LSE),
the operator's corrections (C-O) and the a priori VCV of the two GPS LOPs (m²)::

    GPS statistical data :
    datum    lat                lon                 Hg
    WGS84    52°50'30.000" N    004°31'46.200" E    39.5
    ED50     52°50'32.777" N    004°31'51.052" E    0.00
    x : -31613.554 / -31615.400
    y : 5857312.625 / 5857300.165
    a priori VCV matrix :   2500.000     0.000
                               0.000  2500.000

A record with the receiver's figures (NMEA GGA: fix quality, HDOP, satellites) adds two lines
after "input": the fix in words and the σ per axis with its origin, e.g.
``σ 1.27 m = HDOP 1.2 × UERE 1.5 m (DGPS) / √2`` (docs/GNSS_WEIGHTS.md).
"""

from __future__ import annotations

from engine.api import (
    CycleResult,
    GpsWeight,
    Session,
    format_lat_dms,
    format_lon_dms,
    lse_estimate,
    quality_name,
)
from uvnav_tui.pages.page_text import TextPage, labelled_matrix, num
from uvnav_tui.pages.registry import register_page

PAGE_NUMBER = 611
TITLE = "GPS statistical data :"


def render(r: CycleResult, session: Session) -> str:
    """The text of Pg 611 for cycle ``r``."""
    cfg = session.config
    out = [TITLE, ""]
    if not cfg.gps.on:
        return "\n".join(out + ["GPS is off (Setup ▸ Systems ▸ GPS)."])
    g = r.gps
    if g is None:
        return "\n".join(out + ["No GPS fix in this record."])
    dw = max(9, len(r.datum) + 1)  # a long datum name ("ED50 [DMA]") widens its column
    out += [
        f"{'datum':<{dw}}{'lat':<19}{'lon':<20}Hg",
        f"{'WGS84':<{dw}}{format_lat_dms(g.wgs84_lat_deg):<19}"
        f"{format_lon_dms(g.wgs84_lon_deg):<20}{num(g.hg_m, 1)}",
        # Hg on the working datum is 0 by construction (THEORY §12.8: hg_m is the WGS84 height
        # that puts the fix at height 0 on the working datum).
        f"{r.datum:<{dw}}{format_lat_dms(g.lat_deg):<19}{format_lon_dms(g.lon_deg):<20}0.00",
        "",
        input_line(g.weight, cfg.run_gps_datum, cfg.gps.receiver),
        *weight_lines(g.weight),
        "",
        "    obs / calc (LSE)",
    ]
    lse = lse_estimate(r)
    calc_x = num(lse.x_m, 3) if lse is not None else num(None)
    calc_y = num(lse.y_m, 3) if lse is not None else num(None)
    out += [f"x : {num(g.x_m, 3)} / {calc_x}", f"y : {num(g.y_m, 3)} / {calc_y}"]
    fix = r.fix
    # The GPS rows in slot order (north, east); on the hybrid path they hold the filter's
    # prediction, which is not GPS.
    rows = [lop for lop in fix.rows_of("gps") if lop.system == "GPS"] if fix is not None else []
    if len(rows) == 2:
        out.append(f"C-O : north {num(rows[0].correction, 2)} m   "
                   f"east {num(rows[1].correction, 2)} m")
    out.append("")
    cl = fix.apriori_vcv("gps") if fix is not None and rows else None
    if cl is not None:
        out += labelled_matrix("a priori VCV matrix :", cl, 3, 10)
    else:
        out.append("a priori VCV matrix : (GPS not in the LS fix)")
    if lse is None:
        out.append("calc : no LSE this cycle")
    return "\n".join(out)


def input_line(w: GpsWeight | None, datum: str, receiver: str) -> str:
    """Where the fix came from: a 1993 ``.RUN`` record of the configured receiver type, or an
    NMEA fix with the receiver's own figures (then the C/A or P receiver type does not weigh
    it and is not named)."""
    if w is not None and w.receiver_weighted:
        return f"input : NMEA fix on {datum}, weighted by the receiver's HDOP"
    if w is not None and w.origin == "sps":
        return f"input : fix on {datum} without HDOP, after SA: SPS PS 2008 weight"
    if w is not None and (w.hdop is not None or w.quality is not None):
        return f"input : NMEA fix on {datum}, receiver {receiver} weight"
    return f"input : .RUN record on {datum}, receiver {receiver}"


def weight_lines(w: GpsWeight | None) -> list[str]:
    """The receiver's figures and the σ they give (docs/GNSS_WEIGHTS.md), only for a record
    that carries them (NMEA GGA): a 1993 ``.RUN`` record has none and its page is unchanged."""
    if w is None or (w.hdop is None and w.quality is None and w.sats is None
                     and w.origin != "sps"):
        return []
    hdop = "—" if w.hdop is None else f"{w.hdop:.1f}"
    sats = "—" if w.sats is None else str(w.sats)
    origin = ("receiver" if w.receiver_weighted else "no HDOP, SA off" if w.origin == "sps"
              else "fixed (gps.weights or no usable HDOP)")
    return [f"fix : {quality_name(w.quality)}   HDOP {hdop}   satellites {sats}",
            f"weight per axis : {w.describe()}   [{origin}]"]


class GpsStatisticsPage(TextPage):
    """Pg 611 body."""

    NUMBER = PAGE_NUMBER
    TITLE = TITLE


register_page(PAGE_NUMBER, "GPS statistics", GpsStatisticsPage)

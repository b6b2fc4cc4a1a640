"""Pg 810, Data ▸ Decca (developer): the chain and its geometry at the LSE (THEORY §12.9;
thesis L9123–9144, THEORY §14.2).

The chain's stations on the working datum (DMS), the uncorrected total lane counts, the grid
coordinates of the ship (the LSE, where the geometry is evaluated) and of the four stations,
then the geometry: spheroidal distance ship → master and its azimuth (rad); per slave the
distance ship → slave, the master–slave baseline, the azimuth to the slave (rad), the lane
expansion factor and the LOP azimuth (rad)::

    177026.82   1.32392
    365220.90   227344.07   0.81675   3.98609   1.07034
"""

from __future__ import annotations

from engine.api import CycleResult, Session, format_lat_dms, format_lon_dms
from uvnav_tui.pages.page_text import TextPage, num
from uvnav_tui.pages.registry import register_page

PAGE_NUMBER = 810
TITLE = "Decca chain data :"
ROLES = ("Master", "Red", "Green", "Purple")


def render(r: CycleResult, session: Session) -> str:
    """The text of Pg 810 for cycle ``r``."""
    cfg = session.config
    ctx = session.context
    chain = ctx.chains.get(cfg.decca.chain)
    name = f"  {chain.name}" if chain is not None else "  (not in the chain file)"
    out = [TITLE, "", f"Datum : {r.datum}    Chain : {cfg.decca.chain}{name}"]
    if not cfg.decca.on:
        return "\n".join(out + ["", "Decca is off (Setup ▸ Systems ▸ Decca)."])
    placed = ctx.placed_chain(r.cm_deg)
    if chain is None or placed is None:
        return "\n".join(out)
    stations = (chain.master, chain.red, chain.green, chain.purple)
    for role, st, (lat, lon) in zip(ROLES, stations, placed.station_latlon_deg, strict=True):
        out.append(f"{role:<7}: {format_lat_dms(float(lat))}  {format_lon_dms(float(lon))}"
                   f"   {st.name}")
    fix = r.fix
    geom = fix.decca_geometry if fix is not None and fix.ok else None
    if fix is None or geom is None:
        return "\n".join(out + ["", "No Decca fix this cycle: no geometry."])
    out += ["", "Readings (total lanes) :" + "".join(
        num(v, 3, 10) for v in fix.decca_observed)]
    out += ["", "Grid (m)".ljust(8) + "x".rjust(14) + "y".rjust(15),
            "Ship".ljust(8) + num(fix.x_m, 3, 14) + num(fix.y_m, 3, 15)]
    for role, (x, y) in zip(ROLES, placed.station_xy_m, strict=True):
        out.append(role.ljust(8) + num(float(x), 3, 14) + num(float(y), 3, 15))
    out += ["", "".ljust(8) + "D (m)".rjust(12) + "B (m)".rjust(12) + "Az (rad)".rjust(10)
            + "LEF".rjust(10) + "LOP az (rad)".rjust(14),
            "Master".ljust(8) + num(geom.d_master_m, 2, 12) + " " * 12
            + num(geom.az_master_rad, 5, 10)]
    for i, role in enumerate(ROLES[1:]):
        out.append(role.ljust(8) + num(float(geom.d_slave_m[i]), 2, 12)
                   + num(float(geom.baseline_m[i]), 2, 12)
                   + num(float(geom.az_slave_rad[i]), 5, 10) + num(float(geom.lef[i]), 5, 10)
                   + num(float(geom.lop_azimuth_rad[i]), 5, 14))
    return "\n".join(out)


class DeccaDataPage(TextPage):
    """Pg 810 body."""

    NUMBER = PAGE_NUMBER
    TITLE = TITLE


register_page(PAGE_NUMBER, "Decca chain data", DeccaDataPage)

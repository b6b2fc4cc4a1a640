"""Pg 615, Statistics ▸ Systems ▸ Decca (THEORY §12.8; thesis L9008–9042, THEORY §14.2).

Per pattern: the observed total lane count (Obs), the operator's correction (C-O, A7), the count
computed at the LSE (Calc), the lane expansion factor (LEF) and the LOP azimuth (Az, °); then the
a priori VCV of the three Decca LOPs (m²) for the cycle's ``Decca.CF`` condition, "(SD)" = summer's
day (``decca_cf = "auto"``: the condition the sun gave this cycle)::

            Obs      C-O     Calc       LEF      Az
    Red  :   44.86   -0.05    44.81   3.98609    61.3
    Green:  274.34   -0.05   274.29   1.58335   295.0
    Purple:   1.11   -0.05     1.01  33.45517   257.6
    a priori VCV matrix (SD) :  916.877   18.050    0.000 …
"""

from __future__ import annotations

from engine.api import CycleResult, Session, decca_cf_condition, slots_of
from uvnav_tui.pages.page_text import TextPage, labelled_matrix, num
from uvnav_tui.pages.registry import register_page

PAGE_NUMBER = 615
TITLE = "Decca statistical data :"
PATTERN_NAMES = ("Red", "Green", "Purple")
def condition_label(cf: float) -> str:
    """``SD`` for Decca.CF 64 (summer's day) …, else ``CF <value>``."""
    return decca_cf_condition(cf) or f"CF {cf:g}"


def render(r: CycleResult, session: Session) -> str:
    """The text of Pg 615 for cycle ``r``."""
    cfg = session.config
    # the chain r's lanes are of (a chain chosen since applies from the next cycle)
    chain = (session.cycle_config or cfg).decca.chain
    later = f" ({cfg.decca.chain} from the next cycle)" if cfg.decca.chain != chain else ""
    out = [TITLE, "", f"Chain : {chain}{later}", ""]
    if not cfg.decca.on:
        return "\n".join(out + ["Decca is off (Setup ▸ Systems ▸ Decca)."])
    fix = r.fix
    if fix is None or not fix.ok or fix.decca_geometry is None:
        reason = fix.reason if fix is not None and fix.reason else "no LS fix with Decca"
        return "\n".join(out + [f"No Decca statistics this cycle: {reason}."])
    geom = fix.decca_geometry
    rows = {lop.slot: lop for lop in fix.lops if lop.system == "Decca"}
    out.append(" " * 7 + "Obs".rjust(8) + "C-O".rjust(8) + "Calc".rjust(9) + "LEF".rjust(10)
               + "Az".rjust(8) + "  Sel")
    for i, (name, slot) in enumerate(zip(PATTERN_NAMES, slots_of("decca"), strict=True)):
        lop = rows.get(slot)
        head = f"{name}:".ljust(7) if len(name) > 5 else f"{name:<5}:".ljust(7)
        if lop is None:
            out.append(head + num(None, 2, 8) + "   (no reading)")
            continue
        out.append(head + num(lop.read, 2, 8) + num(lop.correction, 2, 8) + num(lop.calc, 2, 9)
                   + num(float(geom.lef[i]), 5, 10) + num(lop.az_deg, 1, 8)
                   + ("    *" if lop.used else ""))
    out.append("")
    cl = fix.apriori_vcv("decca")
    if cl is not None:
        cf = r.decca_cf if r.decca_cf is not None else cfg.lsq.decca_cf
        code = r.decca_condition or (None if isinstance(cf, str) else condition_label(cf))
        label = f"a priori VCV matrix ({code}) : "
        out += labelled_matrix(label, cl, 3, 9)
        chosen = " (auto: by the sun)" if r.decca_condition else ""
        cf_text = cf if isinstance(cf, str) else f"{cf:g}"
        out += ["", f"Decca.CF {cf_text}{chosen}; unselected patterns: variance 1, "
                "covariances 0 (L6552)"]
    return "\n".join(out)


class DeccaStatisticsPage(TextPage):
    """Pg 615 body."""

    NUMBER = PAGE_NUMBER
    TITLE = TITLE


register_page(PAGE_NUMBER, "Decca statistics", DeccaStatisticsPage)

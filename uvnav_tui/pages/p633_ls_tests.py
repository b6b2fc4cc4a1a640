"""Pg 633, Statistics ▸ LSE (second page): residuals and tests (THEORY §12.8; thesis
L9079–9098, THEORY §6, §14.2).

One row per LOP of the fix in slot order: residual v (m), σ_d (eq. 5.8b), Baarda's w (5.8c),
the reliability factor r = τ = σ_d/σ (5.11), the variance factor VF (5.12, ``!`` when > 0.9 =
unreliable), ``*`` when used, and the w-test verdict (accept / MONITOR / REJECT).  A row not used
shows ``0.0 999.99 999.99 999.99``.  Below: S² = v̂ᵀWv̂/(n−m), its χ² test, and the cumulative
unit variance σ² with the cumulative redundancy R (eq. 5.18)::

                v     σ_d       w       r      VF  sel
    GPS   Lat  -12.5   52.09    0.26    1.04    0.08   *   accept
    Decca Prp   0.0  999.99  999.99  999.99  999.99
    S² : 0.034
    σ² : 0.021 (4)
"""

from __future__ import annotations

import math

from engine.api import REJECT_BOUND, CycleResult, LopRow, Session, w_critical
from uvnav_tui.pages.page_text import SLOT_NAMES, TextPage, num
from uvnav_tui.pages.registry import register_page

PAGE_NUMBER = 633
TITLE = "LS residuals and tests :"
VF_LIMIT = 0.9
"""VF above this marks the LOP unreliable (thesis L6694, eq. 5.12)."""
VERDICTS = {"accept": "accept", "monitor": "MONITOR", "reject": "REJECT"}
HEADER = (" " * 10 + "v".rjust(7) + "σ_d".rjust(8) + "w".rjust(8) + "r".rjust(8) + "VF".rjust(8)
          + "  sel  test")


def row_line(lop: LopRow) -> str:
    """One row of the table (the 999.99 placeholders when the LOP was not used)."""
    label = f"{lop.system[:5]:<6}{lop.pattern}".ljust(10)
    if not lop.used:
        return (label + "0.0".rjust(7) + num(None, 2, 8, "999.99") * 3
                + num(None, 2, 8, "999.99")).rstrip()
    vf = num(lop.vf, 2, 8, "999.99")
    mark = "!" if math.isfinite(lop.vf) and lop.vf > VF_LIMIT else " "
    return (label + num(lop.v_m, 1, 7) + num(lop.sigma_d, 2, 8, "999.99")
            + num(lop.w, 2, 8, "999.99") + num(lop.tau, 2, 8, "999.99") + vf + mark
            + "  *   " + VERDICTS.get(lop.verdict, "")).rstrip()


def render(r: CycleResult, session: Session) -> str:
    """The text of Pg 633 for cycle ``r``."""
    out = [TITLE, ""]
    fix = r.fix
    if fix is None or not fix.lops:
        reason = "no LOPs" if fix is None else (fix.reason or "no LOPs")
        out.append(f"No LS fix this cycle: {reason}.")
    else:
        out.append(HEADER)
        out += [row_line(lop) for lop in fix.lops]
        out.append("")
        s2 = "999.99" if fix.s2 is None else num(fix.s2, 3)
        out.append(f"S² : {s2}   (n = {fix.n_used}, category {fix.category})")
        tested = fix.tested
        vt = tested.variance_test if tested is not None else None
        if vt is not None:
            verdict = "accept" if vt.accepted else "REJECT"
            out.append(f"     χ² test: {num(vt.lower, 4)} < S² < {num(vt.upper, 3)}"
                       f"  (dof {vt.dof})  {verdict}")
        if tested is not None:
            for slot, w in tested.rejected:
                out.append(f"rejected : {SLOT_NAMES[slot]}  w = {num(w, 2)}")
            if tested.not_identifiable:
                out.append("outlier detected, not identifiable (redundancy 1)")
    c = r.cumulative
    out.append(f"σ² : {num(c.sigma2, 3)} ({c.R})")
    alpha = session.config.lsq.reliab_interval_pct / 100.0
    out += [
        "",
        f"|w| ≤ {w_critical(alpha):.3f} accept;  ≤ {REJECT_BOUND:.3f} monitor;  "
        f"> {REJECT_BOUND:.3f} reject",
        f"r = τ = σ_d/σ;  VF > {VF_LIMIT:g}: unreliable (!)",
    ]
    return "\n".join(out)


class LsTestsPage(TextPage):
    """Pg 633 body."""

    NUMBER = PAGE_NUMBER
    TITLE = TITLE


register_page(PAGE_NUMBER, "LS residuals and tests", LsTestsPage)

"""Pg 850, Data ▸ Kalman (developer): the filter's vectors (THEORY §12.9, D38; THEORY
§8.14, §14.4).  Sub-pages 851 (P as a correlation matrix), 852 (Φ) and 853 (K, H, R).

The state x̂(k|k) after this cycle with √diag P in the filter's own SI units (m, m/s, rad), then
this cycle's update: the innovation v̂ = z − H x̂(k+1|k) per measurement row with its VCV
C_v̂ = H P(k+1|k) Hᵀ + R, the LOM statistic and the LS t_i.
"""

from __future__ import annotations

import numpy as np

from engine.api import CycleResult, Session
from uvnav_tui.pages.page_text import TextPage, matrix_lines, num, state_labels
from uvnav_tui.pages.registry import register_page

PAGE_NUMBER = 850
TITLE = "Kalman filter data : state and innovation"
SUB_PAGES = "Sub-pages: 851 P (correlations)   852 Φ   853 K, H, R"


def render(r: CycleResult, session: Session) -> str:
    """The text of Pg 850 for cycle ``r``."""
    out = [TITLE, ""]
    fs = r.filter_state
    if fs is None:
        return "\n".join(out + ["n/a: the filter has not started.", "", SUB_PAGES])
    out.append(f"x̂(k|k) at t = {num(fs.t, 1)} s, Filter : {r.filter_status}  (m, m/s, rad)")
    out.append(" " * 7 + "x̂".rjust(16) + "√P".rjust(14))
    sd = np.sqrt(np.clip(np.diag(fs.P), 0.0, None))
    for i, label in enumerate(state_labels(fs)):
        out.append(label.ljust(7) + num(float(fs.x[i]), 5, 16) + num(float(sd[i]), 5, 14))
    out.append("")
    u = r.filter_update
    if u is None:
        out.append("Innovation v̂ and C_v̂ : n/a (no filter update this cycle)")
    else:
        p = len(u.labels)
        out.append("Innovation v̂ = z − H x̂(k+1|k) and C_v̂ = H P(k+1|k) Hᵀ + R :")
        out.append(" " * 7 + "v̂".rjust(11) + "  " + "C_v̂".ljust(10 * p))
        cv = matrix_lines(u.S, 3, 10)
        for i, label in enumerate(u.labels):
            out.append(label.ljust(7) + num(float(u.innovation[i]), 5, 11) + "  " + cv[i])
        t = u.ls.t
        out.append(f"LOM T = {num(u.lom.t, 5)} (p = {u.lom.dof}) {u.lom.verdict};  LS t : "
                   + " ".join(num(float(v), 5) for v in t))
    out += ["", SUB_PAGES]
    return "\n".join(out)


class KalmanDataPage(TextPage):
    """Pg 850 body."""

    NUMBER = PAGE_NUMBER
    TITLE = TITLE


register_page(PAGE_NUMBER, "Kalman matrices", KalmanDataPage)

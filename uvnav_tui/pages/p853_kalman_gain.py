"""Pg 853, Data ▸ Kalman, sub-page 4 (developer): the gain K of this cycle's update (one column
per measurement row, 5 decimals), and what the cycle result does not keep: H, R and ΓQΓᵀ (the
engine keeps S = H P Hᵀ + R on Pg 850, not its parts).
"""

from __future__ import annotations

from engine.api import CycleResult, Session
from uvnav_tui.pages.page_text import TextPage, matrix_lines, state_labels
from uvnav_tui.pages.registry import register_page

PAGE_NUMBER = 853
TITLE = "Kalman filter data : gain K, H, R"
NOT_KEPT = [
    "H    : n/a (not kept in the cycle result)",
    "R    : n/a (not kept in the cycle result; C_v̂ = H P Hᵀ + R is on Pg 850)",
    "ΓQΓᵀ : n/a (not kept in the cycle result)",
]


def render(r: CycleResult, session: Session) -> str:
    """The text of Pg 853 for cycle ``r``."""
    out = [TITLE, ""]
    u = r.filter_update
    if u is None or r.filter_state is None:
        out.append("K : n/a (no filter update this cycle)")
    else:
        labels = state_labels(u.state)
        out.append("K (rows: states, columns: measurement rows)")
        out.append(" " * 7 + "".join(lab[:10].rjust(12) for lab in u.labels))
        out += matrix_lines(u.K, 5, 12, labels=labels, label_width=7)
    out += [""] + NOT_KEPT
    return "\n".join(out)


class KalmanGainPage(TextPage):
    """Pg 853 body."""

    NUMBER = PAGE_NUMBER
    TITLE = TITLE


register_page(PAGE_NUMBER, "Kalman gain, H and R", KalmanGainPage)

"""Pg 853, Data ▸ Kalman, sub-page 4 (developer): this cycle's update, the gain K (one column
per measurement row, 5 decimals), its design matrix H and measurement VCV R, and the process
noise ΓQΓᵀ the step into this epoch added. The cycle result keeps K, S = H P Hᵀ + R and the
prediction (its smoother link); H and R are recovered from K, S and the prior P, and ΓQΓᵀ from
the prediction (:mod:`engine.filter.explain`), each checked against what the filter computed.
"""

from __future__ import annotations

import numpy as np

from engine.api import CycleResult, Session, added_process_noise, update_matrices
from uvnav_tui.pages.page_text import TextPage, compact_matrix_lines, matrix_lines, state_labels
from uvnav_tui.pages.registry import register_page

PAGE_NUMBER = 853
TITLE = "Kalman filter data : gain K, H, R, ΓQΓᵀ"
H_EPS = 1e-9
"""Entries of the recovered H below this (relative to its largest) are shown as 0."""


def render(r: CycleResult, session: Session) -> str:
    """The text of Pg 853 for cycle ``r``."""
    out = [TITLE, ""]
    u = r.filter_update
    link = r.smoother_link
    if u is None or r.filter_state is None:
        out.append("K, H, R : n/a (no filter update this cycle)")
    else:
        labels = state_labels(u.state)
        head = " " * 7 + "".join(lab[:10].rjust(12) for lab in u.labels)
        out.append("K = P Hᵀ S⁻¹ (rows: states, columns: measurement rows)")
        out.append(head)
        out += matrix_lines(u.K, 5, 12, labels=labels, label_width=7)
        out.append("")
        parts = None if link is None else update_matrices(link[1].P, u.K, u.S, u.state.P)
        if parts is None:
            out.append("H, R : n/a (this update started from a state the cycle does not keep: "
                       "the filter re-initialised, or fix-error states added)")
        else:
            H, R = parts
            # recovered by a solve: structural zeros and ones come back to ~1e-12, shown exact
            H = np.where(np.abs(H) < H_EPS * max(float(np.max(np.abs(H))), 1.0), 0.0, H)
            out.append("H (rows: measurement rows, columns: states)")
            out += compact_matrix_lines(H, 7, list(u.labels), 6, col_labels=labels)
            out.append("")
            out.append("R (measurement VCV, m² / (m/s)² / rad²)")
            out.append(head)
            out += matrix_lines(R, 3, 12, labels=[lab[:6] for lab in u.labels], label_width=7)
    out.append("")
    if link is None:
        out.append("ΓQΓᵀ : n/a (no filter step this cycle)")
    else:
        before, pred, phi = link
        q = added_process_noise(before.P, pred.P, phi)
        if q is None:
            out.append("ΓQΓᵀ : n/a (the step added fix-error states)")
        else:
            out.append(f"ΓQΓᵀ = P(k+1|k) − Φ P(k|k) Φᵀ over Δt = {r.dt_s:.1f} s")
            out += compact_matrix_lines(q, 7, state_labels(pred), 6)
    return "\n".join(out)


class KalmanGainPage(TextPage):
    """Pg 853 body."""

    NUMBER = PAGE_NUMBER
    TITLE = TITLE


register_page(PAGE_NUMBER, "Kalman gain, H, R and ΓQΓᵀ", KalmanGainPage)

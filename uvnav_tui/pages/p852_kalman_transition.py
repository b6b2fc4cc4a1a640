"""Pg 852, Data ▸ Kalman, sub-page 3 (developer): the transition matrix Φ of this cycle's step
(eq. 6.31, THEORY §8.7), from the cycle's smoother link (state before the step, its
prediction, Φ).  Entries are compact (``0``, ``1``, ``-.766``, ``4.17``) so the matrix fits.
"""

from __future__ import annotations

from engine.api import CycleResult, Session
from uvnav_tui.pages.page_text import TextPage, compact_matrix_lines, num, state_labels
from uvnav_tui.pages.registry import register_page

PAGE_NUMBER = 852
TITLE = "Kalman filter data : transition matrix Φ"


def render(r: CycleResult, session: Session) -> str:
    """The text of Pg 852 for cycle ``r``."""
    out = [TITLE, ""]
    link = r.smoother_link
    if link is None:
        return "\n".join(out + ["Φ : n/a (no filter step this cycle)"])
    before, _pred, phi = link
    labels = state_labels(before)
    out.append(f"Φ(t + Δt, t), Δt = {num(r.dt_s, 1)} s, from t = {num(before.t, 1)} s")
    out += compact_matrix_lines(phi, 7, labels, 6)
    return "\n".join(out)


class KalmanTransitionPage(TextPage):
    """Pg 852 body."""

    NUMBER = PAGE_NUMBER
    TITLE = TITLE


register_page(PAGE_NUMBER, "Kalman transition matrix", KalmanTransitionPage)

"""Pg 851, Data ▸ Kalman, sub-page 2 (developer): the filter's P(k|k) as a correlation matrix
(THEORY §14.4: "P (or its correlation matrix)"), with σ = √diag P in SI units.

Entries are correlations ρ_ij = P_ij/(σ_i σ_j) to two decimals, leading zeros dropped (``.12``,
``-.12``) so that all 11 (or 13 with the fix-error states) columns fit the page width.
"""

from __future__ import annotations

import numpy as np

from engine.api import CycleResult, Session
from uvnav_tui.pages.page_text import (
    TextPage,
    compact_matrix_lines,
    corr_text,
    correlation,
    num,
    state_labels,
)
from uvnav_tui.pages.registry import register_page

PAGE_NUMBER = 851
TITLE = "Kalman filter data : P(k|k) as correlations"


def render(r: CycleResult, session: Session) -> str:
    """The text of Pg 851 for cycle ``r``."""
    out = [TITLE, ""]
    fs = r.filter_state
    if fs is None:
        return "\n".join(out + ["n/a: the filter has not started."])
    labels = state_labels(fs)
    out += compact_matrix_lines(correlation(fs.P), 5, labels, 6, fmt=corr_text)
    sd = np.sqrt(np.clip(np.diag(fs.P), 0.0, None))
    out += ["", "σ = √diag P (m, m/s, rad) :"]
    line = ""
    for label, s in zip(labels, sd, strict=True):
        item = f"{label} {num(float(s), 5)}   "
        if len(line) + len(item) > 78:
            out.append(line.rstrip())
            line = ""
        line += item
    out.append(line.rstrip())
    return "\n".join(out)


class KalmanCovariancePage(TextPage):
    """Pg 851 body."""

    NUMBER = PAGE_NUMBER
    TITLE = TITLE


register_page(PAGE_NUMBER, "Kalman P as correlations", KalmanCovariancePage)

"""Pg 830, Data ▸ Weights (developer): the LS weight matrix W = C_l⁻¹ (THEORY §12.9; thesis
L9172–9190, THEORY §14.4).

All ten rows (GPS 2, Decca 3, BRR 5) and the first five columns, 5 decimals, as on the thesis
page; unused slots have weight 0::

    Lat    0.00040  0.00000  0.00000  0.00000  0.00000
    Red    0.00000  0.00000  0.00110 -0.00024  0.00000
"""

from __future__ import annotations

from engine.api import CycleResult, Session
from uvnav_tui.pages.page_text import (
    SLOT_NAMES,
    TextPage,
    adjustment_of,
    matrix_lines,
    no_adjustment_text,
)
from uvnav_tui.pages.registry import register_page

PAGE_NUMBER = 830
TITLE = "Weight matrix W = Cl⁻¹ :"
COLUMNS = 5
"""Columns shown (the thesis page shows 5 of the 10)."""


def render(r: CycleResult, session: Session) -> str:
    """The text of Pg 830 for cycle ``r``."""
    out = [TITLE, ""]
    adj = adjustment_of(r)
    if adj is None:
        return "\n".join(out + [no_adjustment_text(r)])
    W = adj.W
    n = W.shape[0]
    k = min(COLUMNS, W.shape[1])
    out.append(f"rows 1–{n}, columns 1–{k} of {W.shape[1]} (1/m²)")
    out.append(" " * 6 + "".join(SLOT_NAMES[j].rjust(10) for j in range(k)))
    out += matrix_lines(W[:, :k], 5, 10, labels=SLOT_NAMES[:n], label_width=6)
    out += ["", "Unused slots (deselected, rejected or empty) have weight 0 (L6565)."]
    return "\n".join(out)


class WeightsPage(TextPage):
    """Pg 830 body."""

    NUMBER = PAGE_NUMBER
    TITLE = TITLE


register_page(PAGE_NUMBER, "Weights", WeightsPage)

"""Pg 821, Data ▸ A-prio (developer): design matrix, misclosures and a priori VCV of the LS fix
(THEORY §12.9; thesis L9148–9168, THEORY §5.3, §14.2).

``[A | b]`` for the first five observation slots (GPS Lat, GPS Lon, Decca Red, Green, Purple;
then any bearing/distance slots in use): the metric design-matrix row (∂F/∂x, ∂F/∂y) and
O − C (m) of the last iteration; then the 5 × 5 a priori VCV C_l (m²).  Unused slots have a zero
row and b, variance 1 and covariances 0::

    Lat    0.00000  1.00000   12.45880
    Red   -0.47409  0.88046   -1.60637
"""

from __future__ import annotations

import numpy as np

from engine.api import CycleResult, Session, slots_of
from uvnav_tui.pages.page_text import (
    SLOT_NAMES,
    TextPage,
    adjustment_of,
    matrix_lines,
    no_adjustment_text,
    num,
)
from uvnav_tui.pages.registry import register_page

PAGE_NUMBER = 821
TITLE = "A-priori data :"
FIRST_ROWS = 5
"""Slots shown (the thesis page shows 5 of the 10 rows)."""


def render(r: CycleResult, session: Session) -> str:
    """The text of Pg 821 for cycle ``r``."""
    out = [TITLE, ""]
    adj = adjustment_of(r)
    if adj is None:
        return "\n".join(out + [no_adjustment_text(r)])
    A, b, cl, used = adj.A, adj.b, adj.Cl, adj.used
    n = used.size
    brr0 = slots_of("manual").start
    rows = list(range(min(FIRST_ROWS, n))) + [i for i in range(brr0, n) if used[i]]
    out.append(f"[A | b]   (rows 1–{FIRST_ROWS} of {n}"
               + (", and the BRR rows in use)" if len(rows) > FIRST_ROWS else ")"))
    out.append(" " * 6 + "A1".rjust(9) + "A2".rjust(9) + "b".rjust(11) + "  sel")
    for i in rows:
        line = (SLOT_NAMES[i].ljust(6) + "".join(num(float(v), 5, 9) for v in A[i])
                + num(float(b[i]), 5, 11) + ("    *" if used[i] else ""))
        out.append(line.rstrip())
    out += ["", f"a priori VCV matrix (m²), rows/columns 1–{FIRST_ROWS} :"]
    k = min(FIRST_ROWS, n)
    out += matrix_lines(cl[:k, :k], 3, 10, labels=SLOT_NAMES[:k], label_width=6)
    brr = [i for i in range(brr0, n) if used[i]]
    if brr:
        out += ["", "BRR variances (m²) : " + "  ".join(
            f"{SLOT_NAMES[i]} {num(float(cl[i, i]), 3)}" for i in brr)]
    out += ["", f"iterations {adj.iterations}, last |δx̂| = "
            f"{num(adj.steps[-1] if adj.steps else None, 3)} m; b of the last linearisation"]
    if r.fix is not None and r.fix.uses_prior:
        out.append("Lat/Lon rows: the filter's prediction as two position LOPs (too few LOPs)")
    if not np.all(np.isfinite(A)):
        out.append("(non-finite entries: the adjustment failed)")
    return "\n".join(out)


class APrioriPage(TextPage):
    """Pg 821 body."""

    NUMBER = PAGE_NUMBER
    TITLE = TITLE


register_page(PAGE_NUMBER, "A-prio: design matrix and a-priori VCV", APrioriPage)

"""Pg 840, Data ▸ Ellipsoid (developer): error ellipses and ellipsoids (THEORY §12.9; thesis
L9194–9210, THEORY §7, §8.12, §14.4).

Three blocks: the LSE (2-D, from C_x̂), the filter's prediction KF (3-D, from the x/y/depth block
of P_{k+1|k}) and the MPP (3-D from P_{k+1|k+1} when the filter gives it, else the 2-D LSE).
Each block: eigenvalue λ_i (m²) and row i of the eigenvector matrix E, the azimuth and elevation
of the major axis (°), the rotation angles ρ θ φ of eq. 5.28 (°); beside them the standard,
``ConfRegion`` and 99.9 % semi-axes a b c (m)::

    LSE :   935.48   0.92721   0.37455
             76.21  -0.37455   0.92721
            112.00      0.00
              0.00      0.00    -22.00
"""

from __future__ import annotations

import numpy as np

from engine.api import (
    CycleResult,
    Ellipse,
    Ellipsoid3,
    FilterState,
    Session,
    error_ellipsoid,
    lse_estimate,
)
from uvnav_tui.pages.page_text import TextPage, conf_level, ellipse_block, up_cov3
from uvnav_tui.pages.registry import register_page

PAGE_NUMBER = 840
TITLE = "Error ellipses and ellipsoids :"


def filter_ellipsoid(fs: FilterState | None) -> Ellipsoid3 | None:
    """The 3-D error ellipsoid (x East, y North, z Up) of a filter state's position block."""
    if fs is None or not np.all(np.isfinite(fs.P[:3, :3])):
        return None
    return error_ellipsoid(up_cov3(fs.P))


def _block(label: str, e: Ellipse | Ellipsoid3 | None, level: float, why: str) -> list[str]:
    if e is None:
        return [f"{label} :".ljust(6) + f"  ({why})"]
    return ellipse_block(label, e, level)


def render(r: CycleResult, session: Session) -> str:
    """The text of Pg 840 for cycle ``r``."""
    level = conf_level(session)
    lse = lse_estimate(r)
    pred = r.smoother_link[1] if r.smoother_link is not None else None
    if r.mpp.source == "LSE":
        mpp: Ellipse | Ellipsoid3 | None = r.mpp.ellipse
        mpp_note = f"MPP = LSE (Filter {r.filter_status}), 2-D"
    else:
        mpp = filter_ellipsoid(r.filter_state)
        mpp_note = f"MPP = {r.mpp.source}: P(k+1|k+1), 3-D"
    out = [TITLE, ""]
    out += _block("LSE", lse.ellipse if lse is not None else None, level, "no LSE this cycle")
    out.append("")
    out += _block("KF", filter_ellipsoid(pred), level, f"empty: filter {r.filter_status}")
    out.append("")
    out += _block("MPP", mpp, level, "no precision")
    out += ["", f"LSE: C_x̂, 2-D.  KF: P(k+1|k), 3-D.  {mpp_note}.",
            "Rows: λ (m²) | row of E;  Az elev. (°);  ρ θ φ (°).  z is up."]
    return "\n".join(out)


class EllipsoidPage(TextPage):
    """Pg 840 body."""

    NUMBER = PAGE_NUMBER
    TITLE = TITLE


register_page(PAGE_NUMBER, "Ellipsoid", EllipsoidPage)

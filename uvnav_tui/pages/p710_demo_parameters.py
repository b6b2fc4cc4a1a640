"""Pg 710, the Demo page: the demo parameters in force, read-only (THEORY §12.6, §12.11, D36).

The navigator sees the layout and performance parameters (plot scale and size, specific weight,
sample interval, playback pace, Pool of Errors rate ε, pressure reference); in developer mode the
page adds the observation corrections, the LS and testing parameters (ScaleVCV, epsilon,
LOPReject, ReliabInterval, ConfRegion, Decca.CF, GPS.SE_SF) and the filter's Q scale.  Values,
units and meanings come from the configuration's own key tables, so the page always shows what
the engine uses.  Editing is the console's Demo-menu dialogs' business, not this page's.
"""

from __future__ import annotations

import textwrap

from engine.api import (
    CorrectionsConfig,
    CycleResult,
    DemoConfig,
    FilterConfig,
    Key,
    LsqConfig,
    RunConfig,
    Session,
    decca_cf_condition,
)
from uvnav_tui.pages.registry import register_page
from uvnav_tui.pages.throttled_page import ThrottledTextPage

PAGE_NUMBER = 710

DOC_OVERRIDES = {
    "plot_scale_m": "half-width of the position plot (Pg 642), centred on the MPP",
    "plot_size": "fraction of the page the position plot takes (at most 1)",
}
"""How the plot pages use a key, where that says more than the key's own description."""

NAVIGATOR_ROWS: tuple[tuple[str, str], ...] = (
    ("plot_scale_m", "Plot scale"),
    ("plot_size", "Plot size"),
    ("s_weight", "s_weight"),
    ("delta_t_s", "DeltaT"),
    ("pace", "Pace"),
    ("poe_expansion_m_h", "POE rate ε"),
    ("press_ref_freq_hz", "Press. ref."),
)
"""``[demo]`` attributes shown to the navigator, with their labels (A8.2 names where any)."""

LSQ_ROWS: tuple[tuple[str, str], ...] = (
    ("scale_vcv", "ScaleVCV"),
    ("epsilon_m", "epsilon"),
    ("lop_reject", "LOPReject"),
    ("reliab_interval_pct", "ReliabInterval"),
    ("conf_region_pct", "ConfRegion"),
    ("decca_cf", "Decca.CF"),
    ("gps_se_sf", "GPS.SE_SF"),
)
"""``[lsq]`` attributes shown in developer mode (A4), with their A8.2 names."""

CORRECTION_ROWS: tuple[tuple[str, str], ...] = (
    ("gps_north_m", "GPS north"),
    ("gps_east_m", "GPS east"),
    ("decca_red_lanes", "Decca Red"),
    ("decca_green_lanes", "Decca Green"),
    ("decca_purple_lanes", "Decca Purple"),
)
FILTER_ROWS: tuple[tuple[str, str], ...] = (("q_scale", "Q scale"),)

LABEL_W = 15
VALUE_W = 14


def _key(cls: type, attr: str) -> Key:
    for k in cls.KEYS:  # type: ignore[attr-defined]
        if k.attr == attr:
            return k
    raise KeyError(attr)


def value_text(value: object, unit: str) -> str:
    """``2000 m``, ``on``/``off``, ``real``, ``1.026``: a value with its unit (none for "—")."""
    if isinstance(value, bool):
        text = "on" if value else "off"
    elif isinstance(value, float):
        text = f"{value:.10g}"
    else:
        text = str(value)
    if unit and unit != "—" and not isinstance(value, bool):
        text += f" {unit}"
    return text


def _shown(attr: str, value: object, unit: str) -> str:
    """:func:`value_text`, with Decca.CF's condition code (``64 SD``, A8.2)."""
    text = value_text(value, unit)
    if attr == "decca_cf" and isinstance(value, float):
        code = decca_cf_condition(value)
        text = f"{text} {code}" if code else text
    return text


MEANINGS_NOTE = "(what each means: F1, a larger terminal or Edit ▸ Hardcopy)"
"""Shown when the navigator's rows fit the page only without their meanings."""


def _rows(table: object, cls: type, rows: tuple[tuple[str, str], ...], width: int,
          describe: bool = True) -> list[str]:
    """One row per key: label, value with unit, and (``describe``) its meaning, wrapped under
    the meaning's column when longer than ``width`` (cut at the edge before)."""
    out = []
    indent = 2 + LABEL_W + VALUE_W + 1
    for attr, label in rows:
        key = _key(cls, attr)
        line = (f"  {label:<{LABEL_W}}{_shown(attr, getattr(table, attr), key.unit):<{VALUE_W}}"
                f" {DOC_OVERRIDES.get(attr, key.doc) if describe else ''}").rstrip()
        if len(line) <= width or width < indent + 12:
            out.append(line[:width].rstrip())
        else:
            out.extend(textwrap.wrap(line, width, subsequent_indent=" " * indent,
                                     break_on_hyphens=False))
    return out


def _compact_dev_rows(cfg: RunConfig, width: int) -> list[str]:
    """The developer rows without descriptions: corrections on two lines, the LS and filter
    parameters in two columns."""
    c = cfg.corrections
    out = [
        f"  {'GPS N / E':<{LABEL_W}}{c.gps_north_m:.10g} / {c.gps_east_m:.10g} m",
        f"  {'Decca R/G/P':<{LABEL_W}}{c.decca_red_lanes:.10g} / {c.decca_green_lanes:.10g}"
        f" / {c.decca_purple_lanes:.10g} lanes",
    ]
    cells = []
    for table, cls, rows in ((cfg.lsq, LsqConfig, LSQ_ROWS), (cfg.filter, FilterConfig,
                                                               FILTER_ROWS)):
        for attr, label in rows:
            unit = _key(cls, attr).unit
            cells.append(f"{label:<{LABEL_W}}{_shown(attr, getattr(table, attr), unit):<{VALUE_W}}")
    for i in range(0, len(cells), 2):
        out.append("  " + "".join(cells[i:i + 2]).rstrip())
    return [ln[:width] for ln in out]


def demo_page_lines(cfg: RunConfig | None, dev_mode: bool, width: int,
                    height: int | None = None) -> list[str]:
    """The text of Pg 710 for the configuration in force (lines of at most ``width``).  In
    developer mode, if the full table is taller than ``height``, the developer rows are
    compacted (no descriptions, two columns)."""
    width = max(width, 20)
    if cfg is None:
        return ["Demo parameters", "", "no run"]
    out = ["Demo parameters in force (read-only)"[:width], ""]
    nav = _rows(cfg.demo, DemoConfig, NAVIGATOR_ROWS, width)
    if height is not None and len(out) + len(nav) + 2 > height:
        nav = _rows(cfg.demo, DemoConfig, NAVIGATOR_ROWS, width, describe=False)
        nav.append(MEANINGS_NOTE[:width])
    out += nav
    if not dev_mode:
        out += ["", "Corrections and LS/filter parameters: developer mode"[:width]]
        return out
    full = ["", "Corrections (developer)"[:width]]
    full += _rows(cfg.corrections, CorrectionsConfig, CORRECTION_ROWS, width)
    full += ["", "LS and testing (developer)"[:width]]
    full += _rows(cfg.lsq, LsqConfig, LSQ_ROWS, width)
    full += ["", "Filter (developer)"[:width]]
    full += _rows(cfg.filter, FilterConfig, FILTER_ROWS, width)
    if height is None or len(out) + len(full) <= height:
        return out + full
    return out + ["Developer: corrections, LS and filter"[:width]] + _compact_dev_rows(cfg, width)


class DemoPage(ThrottledTextPage):
    """Pg 710 body (developer rows follow the console's ``dev_mode``)."""

    def _dev_mode(self) -> bool:
        return bool(getattr(self.app, "dev_mode", False))

    def help_text(self) -> str:
        """F1 on this page: every row with its meaning (the page may have no room for them)."""
        r, session = self._shown
        return "\n".join(self.page_lines(r, session, 10_000, 10_000))  # wrapped by the help

    def page_key(self, r: CycleResult | None, session: Session | None) -> tuple[object, ...]:
        """The text depends on the configuration in force and the menu mode only."""
        cfg = None if session is None else session.config
        return (cfg, self._dev_mode())

    def page_lines(self, r: CycleResult | None, session: Session | None, width: int,
                   height: int) -> list[str]:
        """:func:`demo_page_lines` of the session's configuration."""
        return demo_page_lines(None if session is None else session.config, self._dev_mode(),
                               width, height)


register_page(PAGE_NUMBER, "Demo parameters", DemoPage)

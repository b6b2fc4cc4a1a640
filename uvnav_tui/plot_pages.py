"""Registers the plot and Demo pages with the console's page registry (import for the effect).

Pg 642 position plot (:mod:`uvnav_tui.page_642`), Pg 643 History (:mod:`uvnav_tui.page_643`) and
Pg 710 Demo parameters (:mod:`uvnav_tui.page_710`); each module calls
:func:`uvnav_tui.pages.register_page` when imported.
"""

from __future__ import annotations

from uvnav_tui import page_642, page_643, page_710

PAGES = {
    page_642.PAGE_NUMBER: page_642.PositionPlotPage,
    page_643.PAGE_NUMBER: page_643.HistoryPage,
    page_710.PAGE_NUMBER: page_710.DemoPage,
}
"""The pages this module registers: number → body class."""

__all__ = ["PAGES"]

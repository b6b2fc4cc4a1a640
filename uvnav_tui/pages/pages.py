"""Registry of the numbered pages (program.md §4.1, A5): page number → page body widget.

Pg 100 is :class:`uvnav_tui.pages.main_page.MainPage`. Every other page lives in its own
``page_nnn`` module, which registers its body here when imported (:mod:`uvnav_tui.pages.all_pages`
imports them all). A page body is a widget with ``show(result, session)``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from textual.widget import Widget

from engine.run.cycle import CycleResult
from engine.run.session import Session


class PageBody(Protocol):
    """What the console calls on the visible page after every (throttled) refresh."""

    def show(self, r: CycleResult | None, session: Session | None) -> None:
        """Render the latest cycle."""


PAGE_FACTORIES: dict[int, Callable[[], Widget]] = {}
"""Page builders registered by the page modules."""


def register_page(number: int, factory: Callable[[], Widget]) -> None:
    """Use ``factory()`` for page ``number`` from now on."""
    PAGE_FACTORIES[number] = factory


def make_page(number: int) -> Widget:
    """The body widget of page ``number``; ``KeyError`` if no module registered it."""
    return PAGE_FACTORIES[number]()

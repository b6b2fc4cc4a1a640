"""Registry of the numbered pages (program.md §4.1, A5): page number → page body widget.

Pg 100 is :class:`uvnav_tui.main_page.MainPage`. The Statistics (6xx) and Data (8xx) pages are
built in another issue; until a page is registered here, :class:`PlaceholderPage` stands in and
says so. A page body is a widget with ``show(result, session)``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from textual.widget import Widget

from engine.cycle import CycleResult
from engine.session import Session
from uvnav_tui.menus import PAGE_TITLES
from uvnav_tui.placeholder_page import PlaceholderPage


class PageBody(Protocol):
    """What the console calls on the visible page after every (throttled) refresh."""

    def show(self, r: CycleResult | None, session: Session | None) -> None:
        """Render the latest cycle."""


PAGE_FACTORIES: dict[int, Callable[[], Widget]] = {}
"""Page builders registered by the page modules (empty: every 6xx/8xx page is a placeholder)."""


def register_page(number: int, factory: Callable[[], Widget]) -> None:
    """Use ``factory()`` for page ``number`` from now on."""
    PAGE_FACTORIES[number] = factory


def make_page(number: int) -> Widget:
    """The body widget of page ``number`` (a placeholder if none is registered)."""
    factory = PAGE_FACTORIES.get(number)
    if factory is not None:
        return factory()
    return PlaceholderPage(number, PAGE_TITLES.get(number, "page"))

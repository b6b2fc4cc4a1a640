"""The one registry of the console's numbered pages (THEORY §12.7, D37): number, title and body.

Pg 100 is the main page (:class:`uvnav_tui.pages.main_page.MainPage`, always on the console
screen).  Every other page lives in its own module ``pNNN_what_it_shows.py`` in this package,
which registers itself with :func:`register_page` when imported; :func:`pages` imports every such
module the first time it is asked.  Adding a page is therefore one module (and its test): the
menus, command palette, help page map, page-number keys and sub-page keys all read this registry.

A page body is a widget with ``show(result, session)``, called after every (throttled) refresh.
"""

from __future__ import annotations

import importlib
import pkgutil
import re
from collections.abc import Callable
from dataclasses import dataclass

from textual.widget import Widget

MAIN_PAGE = 100
"""The main page's number."""
DEV_PAGES_FROM = 800
"""Pages from this number on (Data 8xx) are developer-only (A4)."""

PACKAGE = "uvnav_tui.pages"
_MODULE_NAME = re.compile(r"p\d{3}_\w+")
"""Page modules: ``p`` + the page number + ``_`` + what the page shows."""


@dataclass(frozen=True)
class Page:
    """One page: its number, its title (command palette, help page map) and how to build its
    body (None for the main page, which the console screen builds)."""

    number: int
    title: str
    factory: Callable[[], Widget] | None = None


_PAGES: dict[int, Page] = {MAIN_PAGE: Page(MAIN_PAGE, "Main page")}
_loaded = False


def register_page(number: int, title: str, factory: Callable[[], Widget]) -> None:
    """Page ``number`` is titled ``title`` and its body is ``factory()`` (called by the page
    modules when they are imported)."""
    _PAGES[number] = Page(number, title, factory)


def pages() -> dict[int, Page]:
    """Every page by number, in number order (imports the page modules once)."""
    global _loaded
    if not _loaded:
        _loaded = True
        package = importlib.import_module(PACKAGE)
        for info in pkgutil.iter_modules(package.__path__):
            if _MODULE_NAME.fullmatch(info.name):
                importlib.import_module(f"{PACKAGE}.{info.name}")
    return dict(sorted(_PAGES.items()))


def page_titles() -> dict[int, str]:
    """Page number → title, in number order."""
    return {n: p.title for n, p in pages().items()}


def make_page(number: int) -> Widget:
    """A new body widget of page ``number``; ``KeyError`` if there is no such page (or it is
    the main page)."""
    factory = pages()[number].factory
    if factory is None:
        raise KeyError(number)
    return factory()


def page_refusal(number: int, dev_mode: bool) -> str:
    """Why page ``number`` cannot be shown in the given mode ("" if it can)."""
    if number not in pages():
        return f"No page {number}"
    if number >= DEV_PAGES_FROM and not dev_mode:
        return f"Pg {number} is a developer page (Setup ▸ Params ▸ Develop)"
    return ""


def sub_pages(number: int) -> tuple[int, ...]:
    """The sub-pages of ``number``'s group, in order: the pages sharing its hundreds and tens
    digit (THEORY §12.7: the units digit numbers the sub-page), e.g. 641 → (641, 642, 643)."""
    return tuple(n for n in pages() if n // 10 == number // 10)


def next_sub_page(number: int, step: int) -> int:
    """The sub-page ``step`` (+1 PgDn, −1 PgUp) away from ``number`` in its group, cycling
    round; ``number`` itself if it has no sub-pages."""
    group = sub_pages(number)
    if number not in group:
        return number
    return group[(group.index(number) + step) % len(group)]

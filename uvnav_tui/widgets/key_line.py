"""The bottom line of the console: the keys of the current context (page, menu, dialog, table,
help, command palette), always with F1 and Ctrl+Q, and the page number being typed."""

from __future__ import annotations

from typing import Any

from textual.command import CommandPalette
from textual.screen import Screen
from textual.widgets import Static

from uvnav_tui import keys_help as kh
from uvnav_tui.dialogs.confirm_dialog import ConfirmDialog
from uvnav_tui.dialogs.dialog import Dialog
from uvnav_tui.pages.page_frame import PageFrame
from uvnav_tui.screens.help_screen import HelpScreen
from uvnav_tui.screens.table_screen import TableScreen
from uvnav_tui.widgets.pulldown import PulldownScreen

SYNC_S = 0.5
"""Seconds between two checks whether the page body has become scrollable."""


def context_hints(screen: Screen[Any], page: int, scrollable: bool) -> list[kh.KeyHint]:
    """The key hints for the screen on top (``page`` and ``scrollable`` for the console); a
    screen with its own ``KEY_HINTS`` names them."""
    own = getattr(screen, "KEY_HINTS", None)
    if own:
        return list(own)
    if isinstance(screen, PulldownScreen):
        return list(kh.MENU_KEYS)
    if isinstance(screen, ConfirmDialog):
        return list(kh.CONFIRM_KEYS)
    if isinstance(screen, Dialog):
        return list(kh.DIALOG_KEYS)
    if isinstance(screen, TableScreen):
        return list(kh.TABLE_KEYS)
    if isinstance(screen, HelpScreen):
        return list(kh.HELP_KEYS)
    if isinstance(screen, CommandPalette):
        return list(kh.PALETTE_KEYS)
    return kh.console_hints(page, scrollable)


class KeyLine(Static):
    """`` F1 Help  F10 Menu  Ctrl+Q Quit …`` for the screen on top; ``Pg 6__`` while a page
    number is typed."""

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__("", markup=False, id=id)
        self.typed = ""
        self._text = ""

    def on_mount(self) -> None:
        """Follow the screen stack."""
        self.app.screen_change_signal.subscribe(self, lambda _screen: self.sync())
        self.set_interval(SYNC_S, self.sync)  # a page body may grow past the screen later
        self.sync()

    def _page_scrollable(self) -> bool:
        """True if the page body shown beside the status column is larger than its area."""
        for frame in self.screen.query(PageFrame):
            body = frame.body
            if frame.display and body is not None and body.display:
                return body.max_scroll_x > 0 or body.max_scroll_y > 0
        return False

    def on_resize(self) -> None:
        """Re-fit the hints to the new width."""
        self.sync()

    def sync(self) -> None:
        """Show the hints of the screen on top (or the page number being typed)."""
        app: Any = self.app
        width = max(self.size.width, 20)
        if self.typed:
            text = f" Go to page {self.typed.ljust(3, '_')}   Esc cancels  Backspace erases"
        else:
            page = int(getattr(app, "page", 100))
            text = kh.key_line(context_hints(app.screen, page, self._page_scrollable()), width)
        if text != self._text:
            self._text = text
            self.update(text)

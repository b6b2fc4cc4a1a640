"""The console's base screen: menu bar, state line, the current page, message and key lines.

Whenever another screen (a pulldown, a dialog, the command palette) covers it, the run is
*interrupted*; when it is uncovered the run resumes (program.md §2.1, A22).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, cast

from textual import events, on
from textual.app import ComposeResult
from textual.binding import Binding
from textual.screen import Screen
from textual.widgets import ContentSwitcher, Static

from uvnav_tui.main_page import MainPage
from uvnav_tui.menu_bar import MenuBar
from uvnav_tui.menus import visible_bar
from uvnav_tui.message_line import MessageLine
from uvnav_tui.message_panel import MessagePanel, PanelArea
from uvnav_tui.page_frame import PageFrame
from uvnav_tui.state_line import StateLine

if TYPE_CHECKING:
    from uvnav_tui.app import UVNAVApp

HINT = " F10 menu  Alt+letter a menu  Ctrl+P commands  PgUp/PgDn sub-pages  Esc closes"


class ConsoleScreen(Screen[None]):
    """Menu bar, state line, Pg 100 or a framed page, message line, key hints."""

    BINDINGS = [
        Binding("f10", "open_menu(0)", "Menu", show=False),
        Binding("enter", "open_menu(0)", "Menu", show=False),
        Binding("space", "open_menu(0)", "Menu", show=False),
        Binding("pagedown", "sub_page(1)", "Next sub-page", show=False),
        Binding("pageup", "sub_page(-1)", "Previous sub-page", show=False),
        Binding("f2", "messages", "Messages", show=False),
    ]

    @property
    def uvnav(self) -> UVNAVApp:
        """The console application."""
        return cast("UVNAVApp", self.app)

    def compose(self) -> ComposeResult:
        """The fixed frame of every page."""
        yield MenuBar(dev_mode=self.uvnav.dev_mode, id="menu-bar")
        yield StateLine(id="state-line")
        with ContentSwitcher(initial="page-main", id="pages"):
            with PanelArea(id="page-main"):
                yield MainPage(id="main-page")
                yield MessagePanel(id="message-panel")
            yield PageFrame(id="page-frame")
        yield MessageLine(id="message-line")
        yield Static(HINT, id="hint-line")

    def action_open_menu(self, index: int) -> None:
        """Open a pulldown (the first menu for F10/Return/Space)."""
        self.uvnav.open_menu(index)

    def action_messages(self) -> None:
        """F2: the message log (Statistics ▸ Messages)."""
        self.uvnav.do_menu_action("messages")

    def action_sub_page(self, step: int) -> None:
        """PgDn / PgUp between the sub-pages of the page shown."""
        self.uvnav.sub_page(step)

    def on_key(self, event: events.Key) -> None:
        """Alt+letter opens the menu with that hot-key."""
        key = event.key
        if key.startswith("alt+") and len(key) == 5:
            for i, item in enumerate(visible_bar(self.uvnav.dev_mode)):
                if item.key == key[-1]:
                    event.stop()
                    self.uvnav.open_menu(i)
                    return

    @on(MenuBar.Opened)
    def _bar_clicked(self, event: MenuBar.Opened) -> None:
        event.stop()
        self.uvnav.open_menu(event.index)

    def on_screen_suspend(self) -> None:
        """Covered by a menu or dialog: the run is interrupted."""
        self.uvnav.set_interrupted(True)

    def on_screen_resume(self) -> None:
        """Uncovered: the run resumes as soon as possible."""
        self.uvnav.set_interrupted(False)

"""The console's base screen: menu bar, state line, the current page, message and key lines.

Whenever another screen (a pulldown, a dialog, the command palette) covers it, the run is
*interrupted*; when it is uncovered the run resumes (THEORY §12.2, D44).
"""

from __future__ import annotations

from typing import cast

from textual import events, on
from textual.actions import SkipAction
from textual.app import ComposeResult
from textual.binding import Binding
from textual.screen import Screen
from textual.widgets import ContentSwitcher

from engine.api import RunConfig, format_time_z
from uvnav_tui.host import ConsoleHost
from uvnav_tui.keys_help import menu_key_bindings
from uvnav_tui.menus import visible_bar
from uvnav_tui.pages.input_kind import RUN_FILE, input_kind
from uvnav_tui.pages.main_page import MainPage
from uvnav_tui.pages.page_frame import PageFrame
from uvnav_tui.run_control import RunController
from uvnav_tui.widgets.key_line import KeyLine
from uvnav_tui.widgets.menu_bar import MenuBar
from uvnav_tui.widgets.message_line import MessageLine
from uvnav_tui.widgets.message_panel import MessagePanel, PanelArea
from uvnav_tui.widgets.state_line import StateLine
from uvnav_tui.widgets.status_column import StatusColumn

HARDCOPY_WIDTH = 132
"""Columns a page drawn to the screen's size (710) gets in a text hardcopy at least: a line
printer's width, so no description is cut."""


HARDCOPY_ROWS = 66
"""Rows such a page gets at least: a line printer's page (Pg 710 then shows every meaning)."""


class ConsoleScreen(Screen[None]):
    """Menu bar, state line, Pg 100 or a framed page, message line, key hints."""

    # Keys that open another screen are *priority* bindings: they run in the app's own message
    # loop as the key is read, so the screen is on top before the next key is dispatched.  As
    # plain key handlers they ran later, in this screen's queue, and a hot-key typed right after
    # Alt+letter went to this screen instead of the menu (issue 16, defect 10).
    BINDINGS = [
        *menu_key_bindings(),
        Binding("enter", "open_menu(0)", "Menu", show=False, priority=True),
        Binding("space", "open_menu(0)", "Menu", show=False, priority=True),
        Binding("f1", "app.help", "Help", show=False, priority=True),
        Binding("question_mark", "app.help", "Help", show=False, priority=True),
        Binding("pagedown", "sub_page(1)", "Next sub-page", show=False),
        Binding("pageup", "sub_page(-1)", "Previous sub-page", show=False),
        Binding("escape", "cancel_number", "Cancel", show=False),
        Binding("backspace", "erase_digit", "Erase", show=False),
        Binding("f2", "messages", "Messages", show=False),
    ]

    @property
    def uvnav(self) -> ConsoleHost:
        """The console application."""
        return cast(ConsoleHost, self.app)

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
        yield KeyLine(id="hint-line")

    def action_open_menu(self, index: int) -> None:
        """Open a pulldown (the first menu for F10/Return/Space)."""
        self.cancel_number()
        self.uvnav.open_menu(index)

    def action_open_hot(self, key: str) -> None:
        """Alt+letter: open the bar menu with that hot-key (skipped if none is visible)."""
        for i, item in enumerate(visible_bar(self.uvnav.dev_mode)):
            if item.key == key:
                self.action_open_menu(i)
                return
        raise SkipAction()

    def help_topic(self) -> str:
        """F1 or ? over a page: its number, title and how it is reached."""
        from uvnav_tui.keys_help import page_map_lines

        number = self.uvnav.page
        line = next((ln for ln in page_map_lines() if ln.startswith(f"Pg {number} ")), "")
        body = self.query_one(PageFrame).body if number != 100 else None
        own = getattr(body, "help_text", None)
        extra = f"\n\n{own()}" if callable(own) else ""
        return (f"{' '.join(line.split())}{extra}\n\nType another page's number to go there, "
                "F10 or Alt+letter for the menus, Ctrl+P to search every command.")

    def full_text(self) -> str | None:
        """Edit ▸ Hardcopy's text of a page other than Pg 100: a heading (page, title, record
        time, run state), the page's whole text however much of it the terminal shows, then
        the status column; None for Pg 100 (its boxes are the screen)."""
        from uvnav_tui.pages.page_text import TextPage
        from uvnav_tui.pages.registry import page_titles
        from uvnav_tui.pages.throttled_page import ThrottledTextPage
        from uvnav_tui.widgets.status_column import status_lines

        host = self.uvnav
        body = self.query_one(PageFrame).body if host.page != 100 else None
        if body is None:
            return None
        run = host.control
        r = run.latest if run is not None else None
        session = run.session if run is not None else None
        if isinstance(body, TextPage):
            text = body.text
        elif isinstance(body, ThrottledTextPage):
            width, height = body.content_size
            text = "\n".join(body.page_lines(r, session, max(width, HARDCOPY_WIDTH),
                                              max(height, HARDCOPY_ROWS)))
        else:
            return None
        when = format_time_z(r.time) if r is not None else "--:--:--Z"
        # the run's own state: the menu that asked for the hardcopy interrupts it for a moment
        state = "no run" if run is None else "Suspended..." if run.suspended else "Working..."
        heading = f"UVNAV  Pg {host.page} {page_titles().get(host.page, '')}  Time {when}  {state}"
        status = status_lines(r, host.config, run.bad_records if run is not None else 0)
        return "\n".join([heading, "", text.rstrip("\n"), "", *status]).rstrip() + "\n"

    def select_page(self, number: int) -> None:
        """Switch to page ``number`` (100 = main page) and focus its body."""
        switcher = self.query_one("#pages", ContentSwitcher)
        if number == 100:
            switcher.current = "page-main"
        else:
            self.query_one(PageFrame).select(number)
            switcher.current = "page-frame"
        self.page_shown()

    def repaint(self, run: RunController | None, state_word: str, config: RunConfig, *,
                panel: bool = True) -> None:
        """Paint the state line, the visible page and the message line from the run's latest
        cycle (``config``: the configuration in force; ``panel``: the message panel under
        Pg 100 too)."""
        host = self.uvnav
        r = run.latest if run is not None else None
        dr = run.dead_reckoned() if run is not None else None
        fix_age = run.fix_age_s() if run is not None else None
        line = self.query_one(StateLine)
        line.alarm = run.alarm_text if run is not None else ""
        line.alarm_acked = run.alarm_acked if run is not None else False
        if run is not None and run.bell_due():
            self.app.bell()
        line.state_word = state_word
        line.time_text = format_time_z(r.time) if r is not None else "--:--:--Z"
        line.pace = run.pace if run is not None else ""
        line.note = run.status_note if run is not None else ""
        line.dev_mode = host.dev_mode
        line.page = host.page
        self.query_one(MenuBar).dev_mode = host.dev_mode
        if host.page == 100:
            kind = (input_kind(run.session, run.live.nmea_stats if run.live else None)
                    if run is not None else RUN_FILE)
            self.query_one(MainPage).show(dr or r, config,
                                          run.session.cycle_config if run is not None else None,
                                          fix_age_s=fix_age, kind=kind)
            if panel:
                self.query_one(MessagePanel).sync(host.message_log)
        else:
            column = self.query_one(StatusColumn)
            column.bad_records = run.bad_records if run else 0
            column.fix_age_s, column.dead_reckoned = fix_age, dr
            self.query_one(PageFrame).show(r, run.session if run is not None else None)
        self.query_one(MessageLine).show(host.message_log,
                                         since_s=run.started_wall_s if run is not None else None)

    def page_shown(self) -> None:
        """A page was selected: focus its body (so the cursor keys scroll it) and show its
        keys once it is laid out."""
        frame = self.query_one(PageFrame)
        body = frame.body if self.uvnav.page != 100 else None
        if body is not None and body.can_focus:
            body.focus()
        elif self.focused is not None:
            self.set_focus(None)
        self.call_after_refresh(self.key_line.sync)

    # ------------------------------------------------------------------ go to page nnn
    @property
    def key_line(self) -> KeyLine:
        """The bottom line."""
        return self.query_one(KeyLine)

    def type_digit(self, digit: str) -> None:
        """A digit of a page number; the third one shows the page (``No page nnn`` if none)."""
        line = self.key_line
        line.typed += digit
        if len(line.typed) == 3:
            number = int(line.typed)
            line.typed = ""
            self.uvnav.show_page(number)
        line.sync()

    def cancel_number(self) -> None:
        """Forget the digits typed so far."""
        line = self.key_line
        if line.typed:
            line.typed = ""
            line.sync()

    def action_cancel_number(self) -> None:
        """Esc: forget a page number being typed."""
        if not self.key_line.typed:
            raise SkipAction()
        self.cancel_number()

    def action_erase_digit(self) -> None:
        """Backspace: erase the last digit of a page number being typed."""
        line = self.key_line
        if not line.typed:
            raise SkipAction()
        line.typed = line.typed[:-1]
        line.sync()

    def action_messages(self) -> None:
        """F2: the message log (Statistics ▸ Messages)."""
        self.uvnav.do_menu_action("messages")

    def action_sub_page(self, step: int) -> None:
        """PgDn / PgUp between the sub-pages of the page shown."""
        self.uvnav.sub_page(step)

    def on_key(self, event: events.Key) -> None:
        """Digits type a page number (three digits: ``6 4 2`` shows Pg 642)."""
        if event.character is not None and event.character.isdigit() and len(event.key) == 1:
            event.stop()
            self.type_digit(event.character)

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

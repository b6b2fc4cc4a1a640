"""Line 1 of every page: the menu bar ``Quit Edit Setup Obs Kalman Statistics Demo Data Run``."""

from __future__ import annotations

from rich.text import Text
from textual import events
from textual.message import Message
from textual.reactive import reactive
from textual.widget import Widget

from uvnav_tui.menus import MenuItem, visible_bar

PAD = 1
"""Blank columns on each side of a title."""


def title_spans(items: tuple[MenuItem, ...]) -> list[tuple[int, int]]:
    """(first column, width) of each title on the bar."""
    spans = []
    x = 0
    for item in items:
        width = len(item.label) + 2 * PAD
        spans.append((x, width))
        x += width
    return spans


class MenuBar(Widget):
    """The bar of menu titles; the open menu's title is shown in reverse video.

    Hot-key letters are underlined (Alt+letter opens that menu). A click on a title posts
    :class:`MenuBar.Opened`.
    """

    COMPONENT_CLASSES = {"menu-bar--active", "menu-bar--hotkey"}

    active: reactive[int | None] = reactive(None)
    dev_mode: reactive[bool] = reactive(False)

    class Opened(Message):
        """A title was clicked."""

        def __init__(self, index: int) -> None:
            super().__init__()
            self.index = index

    class Painted(Message):
        """The bar was drawn for the first time: the frame being written shows it (the
        console's first paint, issue 14). Posted once per bar, handled once that frame is out."""

    def __init__(self, *, dev_mode: bool = False, active: int | None = None,
                 id: str | None = None) -> None:
        super().__init__(id=id)
        self.set_reactive(MenuBar.dev_mode, dev_mode)
        self.set_reactive(MenuBar.active, active)
        self._painted = False

    @property
    def items(self) -> tuple[MenuItem, ...]:
        """The titles shown in the current mode."""
        return visible_bar(self.dev_mode)

    def render(self) -> Text:
        """One line of titles, hot-keys underlined, the active one reversed."""
        if not self._painted:
            self._painted = True
            self.post_message(self.Painted())
        hot = self.get_component_rich_style("menu-bar--hotkey", partial=True)
        act = self.get_component_rich_style("menu-bar--active", partial=True)
        text = Text(no_wrap=True, overflow="crop")
        for i, item in enumerate(self.items):
            part = Text(" " * PAD + item.label + " " * PAD)
            pos = item.label.lower().find(item.key)
            if pos >= 0:
                part.stylize(hot, PAD + pos, PAD + pos + 1)
            if i == self.active:
                part.stylize(act)
            text.append_text(part)
        return text

    def index_at(self, x: int) -> int | None:
        """The title under column ``x`` (None between or after the titles)."""
        for i, (start, width) in enumerate(title_spans(self.items)):
            if start <= x < start + width:
                return i
        return None

    def on_click(self, event: events.Click) -> None:
        """Open the clicked menu."""
        index = self.index_at(event.x)
        if index is not None:
            event.stop()
            self.post_message(self.Opened(index))

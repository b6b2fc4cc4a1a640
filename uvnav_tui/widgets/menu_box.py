"""One open pulldown (or sub-menu) box: a framed list of items, the highlighted one reversed."""

from __future__ import annotations

from rich.text import Text
from textual import events
from textual.message import Message
from textual.widget import Widget

from uvnav_tui.menus import MenuItem

SUBMENU_MARK = "▸"


def box_width(items: tuple[MenuItem, ...]) -> int:
    """Outer width of a box for ``items`` (frame, padding, label, sub-menu mark)."""
    inner = max((len(i.label) for i in items), default=4) + 4
    return inner + 2


class MenuBox(Widget):
    """Items of one menu level. Clicking an item posts :class:`MenuBox.Picked`."""

    COMPONENT_CLASSES = {"menu-box--highlight", "menu-box--hotkey"}

    class Picked(Message):
        """An item was clicked."""

        def __init__(self, level: int, index: int) -> None:
            super().__init__()
            self.level = level
            self.index = index

    def __init__(self, level: int, items: tuple[MenuItem, ...], highlight: int) -> None:
        super().__init__(classes="menu-box")
        self.level = level
        self.items = items
        self.highlight = highlight
        self.styles.width = box_width(items)
        self.styles.height = len(items) + 2

    def set_highlight(self, index: int) -> None:
        """Move the highlight (repaints only this box)."""
        if index != self.highlight:
            self.highlight = index
            self.refresh()

    def render(self) -> Text:
        """The item lines; hot-keys underlined, sub-menus marked with ▸."""
        hot = self.get_component_rich_style("menu-box--hotkey", partial=True)
        high = self.get_component_rich_style("menu-box--highlight", partial=True)
        width = box_width(self.items) - 2
        lines = []
        for i, item in enumerate(self.items):
            mark = SUBMENU_MARK if item.children else " "
            line = Text(f" {item.label}".ljust(width - 2) + mark + " ")
            pos = item.label.lower().find(item.key)
            if pos >= 0:
                line.stylize(hot, 1 + pos, 2 + pos)
            if i == self.highlight:
                line.stylize(high)
            lines.append(line)
        return Text("\n").join(lines)

    def on_click(self, event: events.Click) -> None:
        """Pick the clicked item."""
        offset = event.get_content_offset(self)
        if offset is not None and 0 <= offset.y < len(self.items):
            event.stop()
            self.post_message(self.Picked(self.level, offset.y))

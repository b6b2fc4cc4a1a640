"""The open menu: the bar with one title active and its pulldown and sub-menu boxes.

Keyboard-first (thesis L5496: cursor keys and Return move and select): ↑/↓ move, → or Return
opens a sub-menu, ← closes it, ←/→ on the top level move to the neighbouring menu, a hot-key
letter picks an item, Esc closes one level, F10 closes all. Mouse: click a title or an item;
a click elsewhere closes the menu. The screen is dismissed with the chosen action id (or None);
with ``on_choose`` it is dismissed with None and ``on_choose(action)`` runs at once, in the same
step, so a dialog the action opens is on top before the next key is read.

The boxes hang from line 3, under the state line, so the run-state word (``Interrupted...``)
stays visible while a menu is open.  Hot-key letters, Return and Esc are priority bindings: they
are handled as each key is read, never after a key typed behind them (issue 16, defect 10).
"""

from __future__ import annotations

from collections.abc import Callable
from string import ascii_lowercase

from textual import events, on
from textual.actions import SkipAction
from textual.app import ComposeResult
from textual.binding import Binding
from textual.screen import ModalScreen

from uvnav_tui.menus import MenuItem, visible_bar
from uvnav_tui.widgets.menu_bar import MenuBar, title_spans
from uvnav_tui.widgets.menu_box import MenuBox, box_width


class PulldownScreen(ModalScreen[str | None]):
    """A pulldown over the current page; the page underneath stays visible (Interrupted)."""

    CSS_PATH = "pulldown.tcss"

    BINDINGS = [
        Binding("up", "move(-1)", "Up", show=False),
        Binding("down", "move(1)", "Down", show=False),
        Binding("left", "left", "Left", show=False),
        Binding("right", "right", "Right", show=False),
        Binding("enter", "choose", "Select", show=False, priority=True),
        Binding("escape", "back", "Close", show=False, priority=True),
        Binding("f10", "close", "Close menu", show=False, priority=True),
        *[Binding(letter, f"hot('{letter}')", "Pick", show=False, priority=True)
          for letter in ascii_lowercase],
        *[Binding(f"alt+{letter}", f"bar('{letter}')", "Menu", show=False, priority=True)
          for letter in ascii_lowercase],
        Binding("question_mark", "app.help", "Help", show=False, priority=True),
    ]

    BOX_TOP = 2
    """Screen row of the first box: under the menu bar and the state line."""

    def __init__(self, dev_mode: bool, menu_index: int, path: list[int] | None = None,
                 on_choose: Callable[[str], None] | None = None) -> None:
        super().__init__()
        self.on_choose = on_choose
        self.dev_mode = dev_mode
        self.menu_index = menu_index
        self.path: list[int] = list(path) if path else [0]
        self._boxes: list[MenuBox] = []

    # ------------------------------------------------------------------ model
    @property
    def bar(self) -> tuple[MenuItem, ...]:
        """The visible bar titles."""
        return visible_bar(self.dev_mode)

    def level_items(self, level: int) -> tuple[MenuItem, ...]:
        """Items of open level ``level`` (0 = the pulldown of the bar title)."""
        item = self.bar[self.menu_index]
        for i in self.path[:level]:
            item = item.shown_children(self.dev_mode)[i]
        return item.shown_children(self.dev_mode)

    @property
    def current(self) -> MenuItem:
        """The highlighted item of the deepest open level."""
        return self.level_items(len(self.path) - 1)[self.path[-1]]

    def help_topic(self) -> str:
        """F1 or ? in a menu: the highlighted item, its menu path and what it does."""
        names = [self.bar[self.menu_index].label]
        names += [self.level_items(level)[i].label for level, i in enumerate(self.path)]
        item = self.current
        what = item.help or ("opens a sub-menu (→ or Enter)" if item.children else "")
        needs = "  (needs a run: Run ▸ Start)" if item.needs_run else ""
        return (f"Menu: {' ▸ '.join(names)}\n\n{item.label}: {what}{needs}\n\n"
                "↑ ↓ move, Enter or → opens, ← closes a sub-menu, a letter picks the item with "
                "that underlined letter, Esc closes one level, F10 the whole menu.")

    # ------------------------------------------------------------------ layout
    def compose(self) -> ComposeResult:
        """The bar (active title) on line 1; boxes are mounted on mount."""
        yield MenuBar(dev_mode=self.dev_mode, active=self.menu_index, id="pulldown-bar")

    def on_mount(self) -> None:
        """Open the boxes of the initial path."""
        self._sync_boxes()

    def _sync_boxes(self) -> None:
        """Make the mounted boxes match ``self.path`` (mount/remove only what changed)."""
        bar = self.query_one(MenuBar)
        bar.active = self.menu_index
        x = title_spans(self.bar)[self.menu_index][0]
        y = self.BOX_TOP
        for level in range(len(self.path)):
            items = self.level_items(level)
            if level > 0:
                prev_items = self.level_items(level - 1)
                x += box_width(prev_items)
                y += self.path[level - 1]
            if level < len(self._boxes) and self._boxes[level].items == items:
                box = self._boxes[level]
                box.set_highlight(self.path[level])
            else:
                for old in self._boxes[level:]:
                    old.remove()
                del self._boxes[level:]
                box = MenuBox(level, items, self.path[level])
                self._boxes.append(box)
                self.mount(box)
            box.styles.offset = (x, y)
        for old in self._boxes[len(self.path):]:
            old.remove()
        del self._boxes[len(self.path):]

    # ------------------------------------------------------------------ actions
    def action_move(self, step: int) -> None:
        """Move the highlight up or down (wrapping)."""
        n = len(self.level_items(len(self.path) - 1))
        self.path[-1] = (self.path[-1] + step) % n
        self._sync_boxes()

    def _switch_menu(self, index: int) -> None:
        self.menu_index = index % len(self.bar)
        self.path = [0]
        self._sync_boxes()

    def action_left(self) -> None:
        """Close a sub-menu, or go to the previous menu on the bar."""
        if len(self.path) > 1:
            self.path.pop()
            self._sync_boxes()
        else:
            self._switch_menu(self.menu_index - 1)

    def action_right(self) -> None:
        """Open a sub-menu, or go to the next menu on the bar."""
        if self.current.children:
            self.path.append(0)
            self._sync_boxes()
        else:
            self._switch_menu(self.menu_index + 1)

    def action_choose(self) -> None:
        """Return on an item: open its sub-menu or run its action."""
        item = self.current
        if item.children:
            self.path.append(0)
            self._sync_boxes()
        else:
            self._finish(item.action)

    def _finish(self, action: str | None) -> None:
        """Close with ``action`` (run at once through ``on_choose`` if given)."""
        if self.on_choose is None or action is None:
            self.dismiss(action)
            return
        self.dismiss(None)
        self.on_choose(action)

    def action_hot(self, letter: str) -> None:
        """A hot-key letter picks the item of the open level with that key."""
        items = self.level_items(len(self.path) - 1)
        for i, item in enumerate(items):
            if item.key == letter:
                self.path[-1] = i
                self._sync_boxes()
                self.action_choose()
                return
        raise SkipAction()

    def action_bar(self, letter: str) -> None:
        """Alt+letter switches to the bar menu with that hot-key."""
        for i, item in enumerate(self.bar):
            if item.key == letter:
                self._switch_menu(i)
                return
        raise SkipAction()

    def action_back(self) -> None:
        """Esc: close the deepest level; the whole menu from the top level."""
        if len(self.path) > 1:
            self.path.pop()
            self._sync_boxes()
        else:
            self.dismiss(None)

    def action_close(self) -> None:
        """Close the menu without choosing anything."""
        self.dismiss(None)

    # ------------------------------------------------------------------ events
    def on_key(self, event: events.Key) -> None:
        """Upper-case hot-key letters pick like lower-case ones."""
        key = event.key
        if len(key) == 1 and key.isalpha() and key.isupper():
            event.stop()
            try:
                self.action_hot(key.lower())
            except SkipAction:
                pass

    @on(MenuBar.Opened)
    def _bar_clicked(self, event: MenuBar.Opened) -> None:
        event.stop()
        if event.index == self.menu_index:
            self.dismiss(None)
        else:
            self._switch_menu(event.index)

    @on(MenuBox.Picked)
    def _item_clicked(self, event: MenuBox.Picked) -> None:
        event.stop()
        del self.path[event.level + 1:]
        self.path[event.level] = event.index
        self._sync_boxes()
        self.action_choose()

    def on_click(self, event: events.Click) -> None:
        """A click outside the bar and boxes closes the menu."""
        self.dismiss(None)

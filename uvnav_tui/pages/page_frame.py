"""Frame of every page but Pg 100: the left status column and the page body beside it."""

from __future__ import annotations

from typing import TYPE_CHECKING

from textual.app import ComposeResult
from textual.containers import Horizontal
from textual.widget import Widget
from textual.widgets import ContentSwitcher

from uvnav_tui.pages.registry import make_page
from uvnav_tui.widgets.status_column import StatusColumn

if TYPE_CHECKING:
    from engine.api import CycleResult, Session


class PageFrame(Horizontal):
    """Status column + the body of the selected page (bodies are built once and kept)."""

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self.number: int | None = None
        self._bodies: dict[int, Widget] = {}

    def compose(self) -> ComposeResult:
        """Column and an (initially empty) switcher of page bodies."""
        yield StatusColumn(id="status-column")
        yield ContentSwitcher(id="page-bodies")

    def select(self, number: int) -> None:
        """Show page ``number``."""
        switcher = self.query_one("#page-bodies", ContentSwitcher)
        if number not in self._bodies:
            body = make_page(number)
            body.id = f"page-{number}"
            self._bodies[number] = body
            switcher.mount(body)
        self.number = number
        switcher.current = f"page-{number}"

    @property
    def body(self) -> Widget | None:
        """The body of the selected page (None before the first)."""
        return None if self.number is None else self._bodies.get(self.number)

    def show(self, r: CycleResult | None, session: Session | None) -> None:
        """Render the column and the visible body."""
        if session is not None:
            self.query_one(StatusColumn).show(r, session.config)
        if self.number is not None:
            body = self._bodies[self.number]
            show = getattr(body, "show", None)
            if show is not None:
                show(r, session)

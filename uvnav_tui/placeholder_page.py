"""Stand-in for a Statistics or Data page that is not built yet (labelled as such)."""

from __future__ import annotations

from textual.widgets import Static

from engine.cycle import CycleResult
from engine.session import Session


class PlaceholderPage(Static):
    """``Pg 611  GPS statistics — page not built yet``."""

    def __init__(self, number: int, title: str) -> None:
        super().__init__(
            f"Pg {number:03d}  {title}\n\n"
            "page not built yet\n\n"
            "This page belongs to the Statistics and Data pages, which are built separately.\n"
            "Its number and menu entry are final; the values will appear here.",
            classes="placeholder-page",
        )
        self.number = number

    def show(self, r: CycleResult | None, session: Session | None) -> None:
        """Nothing to render yet."""

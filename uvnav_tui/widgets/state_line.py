"""Line 2 of every page: run state word, record time, pace and note on the left, ``Pg nnn`` on
the right (THEORY §12.7, D42)."""

from __future__ import annotations

from rich.text import Text
from textual.reactive import reactive
from textual.widget import Widget


class StateLine(Widget):
    """``Working...  Time 08:35:39Z  pace real  …                      Pg 100``."""

    state_word: reactive[str] = reactive("Interrupted...")
    time_text: reactive[str] = reactive("--:--:--Z")
    pace: reactive[str] = reactive("")
    note: reactive[str] = reactive("")
    dev_mode: reactive[bool] = reactive(False)
    page: reactive[int] = reactive(100)

    def render(self) -> Text:
        """Left part cropped to fit; the page number always shows at the right edge."""
        right = f"Pg {self.page:03d}"
        left = f"{self.state_word:<16}Time {self.time_text}"
        if self.pace:
            left += f"  Pace {self.pace}"
        if self.dev_mode:
            left += "  DEV"
        if self.note:
            left += f"  {self.note}"
        width = max(self.size.width, len(right) + 1)
        room = width - len(right) - 1
        if len(left) > room:
            left = left[: max(room - 1, 0)] + "…"
        return Text(left.ljust(room) + " " + right, no_wrap=True)

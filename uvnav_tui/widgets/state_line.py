"""Line 2 of every page: run state word, record time, pace and note on the left, ``Pg nnn`` on
the right (THEORY §12.7, D42); an alarm (a live source lost) in reverse video right after the
state word, never cut."""

from __future__ import annotations

from rich.text import Text
from textual.reactive import reactive
from textual.widget import Widget

ACK_HINT = " F3 ack"
"""Shown in the alarm while it is not acknowledged (the key that acknowledges it)."""


class StateLine(Widget):
    """``Working...  Time 08:35:39Z  pace real  …                      Pg 100``; while a live
    source is lost ``Working... ▌SOURCE LOST 11 s F3 ack▐ Time …``."""

    state_word: reactive[str] = reactive("Interrupted...")
    time_text: reactive[str] = reactive("--:--:--Z")
    pace: reactive[str] = reactive("")
    note: reactive[str] = reactive("")
    dev_mode: reactive[bool] = reactive(False)
    page: reactive[int] = reactive(100)
    alarm: reactive[str] = reactive("")
    """An active alarm (``SOURCE LOST 11 s``), or ""."""
    alarm_acked: reactive[bool] = reactive(False)

    def render(self) -> Text:
        """The alarm whole, the rest cropped to fit; the page number always at the right."""
        right = f"Pg {self.page:03d}"
        alarm = ""
        if self.alarm:
            alarm = f" {self.alarm}{'' if self.alarm_acked else ACK_HINT} "
        head = f"{self.state_word:<16}" if not alarm else f"{self.state_word} "
        rest = f"Time {self.time_text}" if not alarm else f" Time {self.time_text}"
        if self.pace:
            rest += f"  Pace {self.pace}"
        if self.dev_mode:
            rest += "  DEV"
        if self.note:
            rest += f"  {self.note}"
        width = max(self.size.width, len(right) + 1)
        room = width - len(right) - 1
        if alarm:  # the alarm is never cut: the state word gives way first, then the rest
            if len(head) + len(alarm) > room:
                head = head[: max(room - len(alarm), 0)]
            room_rest = room - len(head) - len(alarm)
        else:
            room_rest = room - len(head)
        if len(rest) > room_rest:
            rest = rest[: max(room_rest - 1, 0)] + ("…" if room_rest > 0 else "")
        text = Text(no_wrap=True)
        text.append(head)
        if alarm:
            text.append(alarm[:room], style="reverse" if self.alarm_acked else "reverse blink")
        text.append(rest)
        text.append(" " * max(room - text.cell_len, 0) + " " + right)
        return text

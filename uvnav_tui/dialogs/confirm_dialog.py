"""Yes/No question (Quit, Run ▸ Start, discard an LOP): Y or N, Return on the focused button.

A question the operator did not ask for (the LOP rejection, raised by a cycle) can open between
two keys the operator is typing for something else; ``arm_s`` makes it ignore every answer for
that long after it is shown, so keys typed ahead never answer it."""

from __future__ import annotations

import time
from collections.abc import Callable

from textual import on
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Horizontal, Vertical
from textual.screen import ModalScreen
from textual.widgets import Button, Static


class ConfirmDialog(ModalScreen[bool]):
    """A question answered with Yes (True) or No (False); Esc means No."""

    CSS_PATH = "dialog.tcss"

    BINDINGS = [
        Binding("y", "answer(True)", "Yes", show=False, priority=True),
        Binding("n", "answer(False)", "No", show=False, priority=True),
        Binding("escape", "answer(False)", "No", show=False, priority=True),
        # Return presses the focused button here, not in the button, so that one typed
        # before the question is armed leaves no trace (a button pressed shows itself pressed
        # for a moment, and takes no press meanwhile).
        Binding("enter", "press_focused", "Press", show=False, priority=True),
    ]

    def __init__(self, title: str, question: str, *, default: bool = False, arm_s: float = 0.0,
                 clock: Callable[[], float] = time.monotonic, place: str = "center") -> None:
        """``arm_s``: seconds after it is shown during which no key, button or click answers
        it (``clock``: the seconds it is measured on); ``place``: ``center``, or ``top`` /
        ``bottom`` of the screen for a question about what the page shows in its middle (the
        LOP question: the LOP's rows stay visible)."""
        super().__init__(classes=f"-{place}" if place != "center" else None)
        self.title_text = title
        self.question = question
        self.default = default
        self.arm_s = arm_s
        self._clock = clock
        self._shown_s = clock()

    def compose(self) -> ComposeResult:
        """The question and the two buttons."""
        with Vertical(classes="dialog-frame confirm-frame") as frame:
            frame.border_title = self.title_text
            yield Static(self.question, id="question", markup=False)
            with Horizontal(classes="dialog-buttons"):
                yield Button("Yes", id="yes", compact=True)
                yield Button("No", id="no", compact=True)

    def on_mount(self) -> None:
        """Focus the default answer (No unless told otherwise); the arming time starts."""
        self._shown_s = self._clock()
        self.query_one("#yes" if self.default else "#no", Button).focus()

    def help_topic(self) -> str:
        """F1 here: the question and how to answer it."""
        return (f"{self.title_text}\n\n{self.question}\n\nY answers Yes, N or Esc No; Tab moves "
                "between the buttons and Enter presses the focused one.")

    @property
    def armed(self) -> bool:
        """True once ``arm_s`` has passed since the question was shown."""
        return self._clock() - self._shown_s >= self.arm_s

    def action_answer(self, yes: bool) -> None:
        """Close with the answer (not before the question is armed)."""
        if self.armed:
            self.dismiss(yes)

    def action_press_focused(self) -> None:
        """Return: press the focused button (not before the question is armed)."""
        if self.armed and isinstance(self.focused, Button):
            self.focused.press()

    @on(Button.Pressed)
    def _pressed(self, event: Button.Pressed) -> None:
        event.stop()
        if self.armed:
            self.dismiss(event.button.id == "yes")

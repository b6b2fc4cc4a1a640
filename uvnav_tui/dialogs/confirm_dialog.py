"""Yes/No question (Quit, Run ▸ Start, discard an LOP): Y or N, Return on the focused button."""

from __future__ import annotations

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
    ]

    def __init__(self, title: str, question: str, *, default: bool = False) -> None:
        super().__init__()
        self.title_text = title
        self.question = question
        self.default = default

    def compose(self) -> ComposeResult:
        """The question and the two buttons."""
        with Vertical(classes="dialog-frame confirm-frame") as frame:
            frame.border_title = self.title_text
            yield Static(self.question, id="question", markup=False)
            with Horizontal(classes="dialog-buttons"):
                yield Button("Yes", id="yes", compact=True)
                yield Button("No", id="no", compact=True)

    def on_mount(self) -> None:
        """Focus the default answer (No unless told otherwise)."""
        self.query_one("#yes" if self.default else "#no", Button).focus()

    def action_answer(self, yes: bool) -> None:
        """Close with the answer."""
        self.dismiss(yes)

    @on(Button.Pressed)
    def _pressed(self, event: Button.Pressed) -> None:
        event.stop()
        self.dismiss(event.button.id == "yes")

"""A labelled input that is checked as you type with an engine parser (thesis §7.3.3).

The typed text is never lost: a bad entry shows the parser's message (``Wrong position input
format !`` …) on the line under the field and keeps the text for correction.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from textual import on
from textual.actions import SkipAction
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Horizontal
from textual.suggester import Suggester
from textual.widget import Widget
from textual.widgets import Input, Label, Static

from engine.api import InputError

Parser = Callable[[str], Any]
Completer = Callable[[str], "str | None"]
"""The text completed (Tab), or None if nothing can be added."""


class CompletingInput(Input):
    """An input where Tab completes the text (:attr:`completer`); with nothing to complete,
    Tab moves to the next field as usual."""

    BINDINGS = [Binding("tab", "complete", "Complete", show=False)]

    def __init__(self, value: str, completer: Completer, **kwargs: Any) -> None:
        super().__init__(value, **kwargs)
        self.completer = completer

    def action_complete(self) -> None:
        """Tab: the completed text, cursor at its end (else on to the next field)."""
        completed = self.completer(self.value)
        if completed is None or completed == self.value:
            raise SkipAction()
        self.value = completed
        self.cursor_position = len(completed)


def number_text(value: float | int) -> str:
    """A number as it is typed, with every digit needed to read back the same value: Python's
    shortest round-trip form (``39939.662``, ``0.1``, ``1e-05``), without a trailing ``.0``."""
    if isinstance(value, bool) or not isinstance(value, float):
        return str(value)
    text = repr(value)
    return text[:-2] if text.endswith(".0") else text


def error_text(exc: Exception) -> str:
    """The operator-facing message of a parser error."""
    if isinstance(exc, InputError):
        return exc.message
    return str(exc) or "Wrong input !"


class ValidatedField(Widget):
    """Label, one-line input and message line; ``parsed`` holds the last valid value."""

    def __init__(
        self,
        label: str,
        value: str,
        parser: Parser,
        *,
        id: str,
        suggester: Suggester | None = None,
        hint: Callable[[str], str] | None = None,
        completer: Completer | None = None,
    ) -> None:
        super().__init__(id=id, classes="validated-field")
        self.label = label
        self.parser = parser
        self._initial = value
        self._suggester = suggester
        self._hint = hint
        self._completer = completer
        self.parsed: Any = None
        self.error: str | None = None
        self.show_errors = bool(value)

    def compose(self) -> ComposeResult:
        """Label and input side by side, the message below."""
        with Horizontal(classes="field-row"):
            yield Label(self.label, classes="field-label", markup=False)
            if self._completer is not None:
                yield CompletingInput(self._initial, self._completer, id=f"{self.id}-input",
                                      compact=True, suggester=self._suggester)
            else:
                yield Input(self._initial, id=f"{self.id}-input", compact=True,
                            suggester=self._suggester)
        yield Static("", classes="field-message", markup=False)

    def on_mount(self) -> None:
        """Check the pre-filled value."""
        self.validate()

    @property
    def input(self) -> Input:
        """The input widget."""
        return self.query_one(Input)

    @property
    def text(self) -> str:
        """What is typed."""
        return self.input.value

    @property
    def edited(self) -> bool:
        """True if the text differs from the pre-filled one."""
        return self.text != self._initial

    def value_or(self, original: Any) -> Any:
        """The parsed value if the field was edited, else ``original`` untouched (a dialog never
        changes a value nobody edited, not even by rounding it for display)."""
        return self.parsed if self.edited else original

    def focus_input(self) -> None:
        """Put the cursor in this field."""
        self.input.focus()

    def validate(self, *, show: bool = False) -> bool:
        """Parse the text and return True if valid; show the message (or hint).

        A field left blank from the start shows its message only once it has been typed in or
        ``show`` is given (when the dialog is submitted).
        """
        self.show_errors = self.show_errors or show
        text = self.text
        try:
            self.parsed = self.parser(text)
        except (InputError, ValueError) as exc:
            self.parsed = None
            self.error = error_text(exc)
        else:
            self.error = None
        message = (self.error or "") if self.show_errors else ""
        if self._hint is not None:
            extra = self._hint(text)
            message = f"{message}  {extra}".strip() if extra else message
        self.query_one(".field-message", Static).update(message)
        self.set_class(self.error is not None and self.show_errors, "-invalid")
        return self.error is None

    @on(Input.Changed)
    def _changed(self, event: Input.Changed) -> None:
        event.stop()
        if event.value != self._initial:
            self.show_errors = True
        self.validate()

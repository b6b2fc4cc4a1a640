"""Base of every console dialog ("cadre"): a framed box over the page with OK and Cancel.

Keyboard-first: Tab/Shift+Tab move between fields, Return is OK from any field (on a focused
button it presses that button), Esc cancels.  On a terminal too small for the whole box (its
buttons would be cut off) the dialog says so instead, with the size it needs; what was typed
stays, and the box comes back when the terminal is large enough. Subclasses build the body in
:meth:`Dialog.compose_body` and return the dialog's result from :meth:`Dialog.collect`, or
None when a field is invalid (the field keeps the typed text and shows its message).
"""

from __future__ import annotations

from typing import Generic, TypeVar

from textual import on
from textual.actions import SkipAction
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Horizontal, Vertical
from textual.screen import ModalScreen
from textual.widgets import Button, Static

from uvnav_tui.widgets.toggles import GlyphCheckbox, GlyphRadioButton
from uvnav_tui.widgets.validated_field import ValidatedField

T = TypeVar("T")

POSITION_HELP = (
    "latitude then longitude, degrees minutes seconds with N/S and E/W, e.g. "
    "52 50 00 N 004 30 00 E, 52 50.0 N 4 30.0 E or 52.8 N 4.5 E (spaces or commas); no signs.")
"""How a position is typed (the six thesis forms, docs/CONSOLE.md), for the dialogs' help."""
NUMBER_HELP = "Numbers are plain decimals: 12, 12.5, .5 (no sign, no exponent such as 1e3)."
"""How a number is typed in the navigation dialogs (not the parameter tables)."""


class Dialog(ModalScreen[T | None], Generic[T]):
    """A modal dialog; dismissed with the collected result, or None on Cancel/Esc."""

    CSS_PATH = "dialog.tcss"

    BINDINGS = [
        Binding("enter", "ok", "OK", priority=True, show=False),
        Binding("escape", "cancel", "Cancel", show=False, priority=True),
    ]

    TITLE = "Dialog"
    HELP = ""
    """What the dialog's fields mean and accept (F1 shows it above the general help)."""
    OK_LABEL = "OK"
    CANCEL_IF_UNCHANGED = True
    """OK with nothing edited closes like Cancel: no command is sent, so nothing changes (not
    even a value re-sent with fewer digits, a DR position reset or a filter state re-set).
    Parameter Initialization and Predict set it False (they act without edits)."""

    def compose(self) -> ComposeResult:
        """Frame: title, body, message line, buttons."""
        with Vertical(id="dialog-frame", classes="dialog-frame") as frame:
            frame.border_title = self.TITLE
            yield from self.compose_body()
            yield Static("", id="dialog-message", classes="dialog-message", markup=False)
            with Horizontal(classes="dialog-buttons"):
                yield Button(self.OK_LABEL, id="ok", compact=True)
                yield Button("Cancel", id="cancel", compact=True)
        yield Static("", id="dialog-too-small", markup=False)

    def help_topic(self) -> str:
        """F1 in this dialog: its title, the field the cursor is in, and :attr:`HELP`."""
        here = ""
        for field in self.query(ValidatedField):
            if field.has_focus_within:
                here = f"The cursor is in: {field.label}\n\n"
        keys = ("Tab / Shift+Tab move between fields, Enter is OK, Esc cancels (nothing is "
                "changed).")
        return f"{self.TITLE}\n\n{here}{self.field_help()}\n\n{keys}".replace("\n\n\n", "\n\n")

    def field_help(self) -> str:
        """:attr:`HELP` (a dialog whose fields vary overrides this)."""
        return self.HELP.strip()

    _needed: tuple[int, int] | None = None
    """Columns and rows the whole box needs (measured while it is shown)."""

    def on_resize(self) -> None:
        """Check, once laid out at the new size, that the whole box fits."""
        self.call_after_refresh(self.check_fits)

    def check_fits(self) -> bool:
        """Show the box if the terminal holds all of it (its buttons too), else the note that
        the terminal is too small; True if it fits."""
        frame = self.query_one("#dialog-frame", Vertical)
        note = self.query_one("#dialog-too-small", Static)
        if not note.display:
            rows = sum(c.outer_size.height for c in frame.children if c.display)
            self._needed = (frame.outer_size.width, rows + frame.styles.gutter.height)
        if self._needed is None:
            return True
        width, height = self.size
        need_w, need_h = self._needed
        fits = width >= need_w and height >= need_h
        if not fits:
            note.update(f"The terminal is too small for {self.TITLE}: {width}×{height}, it "
                        f"needs {need_w}×{need_h}. Enlarge the window, or press Esc to close "
                        "it (what was typed is kept while it is open).")
        # the note covers the box (a layer above it): the field with the cursor keeps it, and
        # keys typed meanwhile land there
        note.display = not fits
        return fits

    def compose_body(self) -> ComposeResult:
        """The dialog's fields (override)."""
        yield from ()

    def collect(self) -> T | None:
        """The dialog's result, or None if something is invalid (override)."""
        return None

    def set_message(self, text: str) -> None:
        """Show a dialog-wide message (e.g. a warning) above the buttons."""
        self.query_one("#dialog-message", Static).update(text)

    def first_invalid(self) -> ValidatedField | None:
        """Validate every field; focus and return the first invalid one."""
        bad = None
        for field in self.query(ValidatedField):
            if not field.validate(show=True) and bad is None:
                bad = field
        if bad is not None:
            bad.focus_input()
        return bad

    def unchanged(self) -> bool:
        """True if no field was edited and no check box or radio button changed."""
        if any(f.edited for f in self.query(ValidatedField)):
            return False
        toggles = [*self.query(GlyphCheckbox), *self.query(GlyphRadioButton)]
        return all(t.value == t.initial_value for t in toggles)

    def _ok(self) -> None:
        if self.CANCEL_IF_UNCHANGED and self.unchanged():
            self.dismiss(None)
            return
        result = self.collect()
        if result is not None:
            self.dismiss(result)

    def action_ok(self) -> None:
        """Return: collect and close if valid (a focused button gets the key instead)."""
        if isinstance(self.focused, Button):
            raise SkipAction()
        self._ok()

    def action_cancel(self) -> None:
        """Esc: close without changing anything."""
        self.dismiss(None)

    @on(Button.Pressed, "#ok")
    def _ok_pressed(self, event: Button.Pressed) -> None:
        event.stop()
        self._ok()

    @on(Button.Pressed, "#cancel")
    def _cancel_pressed(self, event: Button.Pressed) -> None:
        event.stop()
        self.dismiss(None)

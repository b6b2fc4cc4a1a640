"""Setup ▸ Params ▸ Datum: choose a new working datum from ``TO_WGS84.DAT`` (thesis L5472)."""

from __future__ import annotations

from textual import on
from textual.app import ComposeResult
from textual.suggester import SuggestFromList
from textual.widgets import OptionList

from engine.api import parse_datum_name
from uvnav_tui.dialogs.dialog import Dialog
from uvnav_tui.dialogs.init_dialog import datum_hint
from uvnav_tui.widgets.validated_field import ValidatedField


class DatumDialog(Dialog[str]):
    """Type a datum name (with completion) or pick it from the list; dismissed with the name."""

    TITLE = "Setup ▸ Params ▸ Datum"
    HELP = """
The working datum: positions are shown and typed on it. Type a name of TO_WGS84.DAT (any case; \
→ completes the suggestion) or pick one from the list with ↑ ↓.
"""

    def __init__(self, names: list[str], current: str) -> None:
        super().__init__()
        self.names = names
        self.current = current

    def compose_body(self) -> ComposeResult:
        """Name field and the datum list."""
        names = self.names
        yield ValidatedField(
            "Geodetic datum", self.current, lambda t: parse_datum_name(t, names),
            id="datum-name", suggester=SuggestFromList(names, case_sensitive=False),
            hint=datum_hint(names))
        yield OptionList(*names, id="datum-list", compact=True, markup=False)

    def on_mount(self) -> None:
        """Highlight the datum in force; the cursor goes to the name field."""
        if self.current in self.names:
            self.query_one(OptionList).highlighted = self.names.index(self.current)
        self.query_one(ValidatedField).focus_input()

    @on(OptionList.OptionHighlighted)
    def _highlighted(self, event: OptionList.OptionHighlighted) -> None:
        event.stop()
        if self.query_one(OptionList).has_focus:
            self.query_one(ValidatedField).input.value = self.names[event.option_index]

    def collect(self) -> str | None:
        """The chosen datum name."""
        if self.first_invalid() is not None:
            return None
        return str(self.query_one(ValidatedField).parsed)

"""Setup ▸ Systems ▸ Decca: on/off, chain (``DECCA.CHN``), zone + whole lane per pattern
(e.g. B20, F34, A51) and the patterns used for fixing (L5424, L5526–5531; THEORY D7)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING

from textual.app import ComposeResult
from textual.containers import Horizontal
from textual.widgets import Checkbox, Label, RadioSet

from engine import api
from engine.api import ZONE_LETTERS, DeccaConfig, InputError, parse_zone_lane
from uvnav_tui.dialogs.dialog import Dialog
from uvnav_tui.widgets.toggles import GlyphCheckbox, GlyphRadioButton
from uvnav_tui.widgets.validated_field import ValidatedField

if TYPE_CHECKING:
    from engine.api import SetDecca

PATTERNS = ("red", "green", "purple")


def zone_lane_parser(pattern: str) -> Callable[[str], str]:
    """Parser of a zone/lane entry for ``pattern``; blank means "not entered"."""

    def parse(text: str) -> str:
        if not text.strip():
            return ""
        zone, lane = parse_zone_lane(text, pattern)
        return f"{ZONE_LETTERS[zone]}{lane}"

    return parse


class DeccaDialog(Dialog["SetDecca"]):
    """Dismissed with the :class:`SetDecca` command."""

    TITLE = "Setup ▸ Systems ▸ Decca"
    HELP = """
Decca on: Space toggles. Chain: a chain of DECCA.CHN (← → choose).
Red / Green / Purple zone/lane: the zone letter and whole lane the receiver is in, e.g. B20, \
F34, A51 (lanes: Red 0-23, Green 30-47, Purple 50-79).
Use for fixing: the patterns the least-squares fix uses (Space toggles).
Changing the chain or a lane restarts the lane tracking.
"""

    def __init__(self, decca: DeccaConfig, chains: list[str]) -> None:
        super().__init__()
        self.decca = decca
        self.chains = chains

    def compose_body(self) -> ComposeResult:
        """Switch, chain, zone/lane fields and pattern selection."""
        d = self.decca
        yield GlyphCheckbox("Decca on", d.on, id="decca-on", compact=True)
        with Horizontal(classes="dialog-row"):
            yield Label("Chain", classes="row-label")
            with RadioSet(id="decca-chain", compact=True, classes="inline-radio"):
                for chain in self.chains:
                    yield GlyphRadioButton(chain, value=chain == d.chain)
        for pattern in PATTERNS:
            yield ValidatedField(f"{pattern.capitalize()} zone/lane", getattr(d, pattern),
                                 zone_lane_parser(pattern), id=f"decca-{pattern}")
        with Horizontal(classes="dialog-row"):
            yield Label("Use for fixing", classes="row-label")
            for pattern in PATTERNS:
                yield GlyphCheckbox(pattern.capitalize(), pattern in d.select,
                                    id=f"decca-use-{pattern}", compact=True)

    def on_mount(self) -> None:
        """Focus the switch."""
        self.query_one("#decca-on", Checkbox).focus()

    def collect(self) -> SetDecca | None:
        """The command, or None (with the message shown) if an entry is wrong."""
        if self.first_invalid() is not None:
            return None
        index = self.query_one("#decca-chain", RadioSet).pressed_index
        chain = self.chains[index] if index >= 0 else self.decca.chain
        zl = {p: str(self.query_one(f"#decca-{p}", ValidatedField).parsed) for p in PATTERNS}
        select = tuple(p for p in PATTERNS
                       if self.query_one(f"#decca-use-{p}", Checkbox).value)
        on = self.query_one("#decca-on", Checkbox).value
        try:
            replace(self.decca, on=on, chain=chain, select=select, **zl)
        except InputError as exc:
            self.set_message(exc.message)
            return None
        return api.SetDecca(on=on, chain=chain, red=zl["red"], green=zl["green"],
                        purple=zl["purple"], select=select)

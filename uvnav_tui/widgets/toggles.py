"""Check boxes and radio buttons that show their state with glyphs, not only by shade.

Textual's toggles draw ``▐X▌`` either way and show on/off by colour alone, which is lost on a
monochrome screen and in a text hardcopy. These show ``[x]`` / ``[ ]`` (check box) and
``(•)`` / ``( )`` (radio button). Labels are always literal text: a chain name such as
``9B [old]`` from a data file is shown as written, never read as markup.
"""

from __future__ import annotations

from textual.content import Content
from textual.widgets import Checkbox, RadioButton

CHECK_ON, CHECK_OFF = "[x]", "[ ]"
RADIO_ON, RADIO_OFF = "(•)", "( )"


def literal(text: str | Content) -> Content:
    """``text`` as literal content (a ``Content`` is passed through)."""
    return text if isinstance(text, Content) else Content(text)


class _GlyphToggle:
    """Mixin for a Textual toggle button drawn with text glyphs: ``ON`` / ``OFF`` (the state is
    readable without colour, also in text hardcopies)."""

    ON = ""
    OFF = ""

    def __init__(self, label: str | Content = "", value: bool = False, **kwargs: object) -> None:
        super().__init__(literal(label), value, **kwargs)  # type: ignore[call-arg]
        self.initial_value = value
        """The state the dialog opened with (a dialog OK'd without edits changes nothing)."""

    @property
    def _button(self) -> Content:
        """The state glyph (bold when on, so it also stands out in colour)."""
        if self.value:  # type: ignore[attr-defined]
            return Content.styled(self.ON, "bold")
        return Content(self.OFF)


class GlyphCheckbox(_GlyphToggle, Checkbox):
    """A check box drawn as ``[x] label`` / ``[ ] label``."""

    ON, OFF = CHECK_ON, CHECK_OFF


class GlyphRadioButton(_GlyphToggle, RadioButton):
    """A radio button drawn as ``(•) label`` / ``( ) label``."""

    ON, OFF = RADIO_ON, RADIO_OFF

"""The console's terminal driver: Esc and Alt typed fast, and a clean shell screen on leaving
(docs/CONSOLE.md, "Typing ahead" and "Suspend, repaint, quit").

A terminal sends Alt+O as the two bytes ``ESC o`` and Esc as ``ESC`` alone, so Esc followed by
a key is told from Alt+key only by time.  Textual 8.2's parser waits for the end of a possible
escape sequence as long as bytes keep coming less than 100 ms apart (``ESCDELAY``): keys typed
faster than that behind an Alt+letter or an Esc were read as one long unknown sequence and
reissued without the Alt (``Alt+O r ABC…`` typed at speed lost the menu), and ``Esc 1 0 0``
became ``Alt+1 0 0`` (the Esc that should close the command palette was lost).

:class:`ConsoleKeyParser` decides as soon as the byte after ``ESC`` is known: a letter is
Alt+letter (the menus' hot-keys), anything else is Esc followed by that key; only ``[``,
``O`` and the other bytes that start a terminal's escape sequences (cursor keys, function keys,
mouse, replies) wait for the rest, as before.

:class:`ConsoleDriver` also clears the alternate screen before leaving it (quitting, Ctrl+Z):
after a resize, tmux kept the rows written at the new size on the shell's screen.
"""

from __future__ import annotations

from collections.abc import Iterable

from textual import events
from textual._xterm_parser import XTermParser
from textual.driver import Driver

try:
    from textual.drivers import linux_driver
except ImportError:  # no termios (Windows): Textual's own driver
    linux_driver = None  # type: ignore[assignment]

ESC = "\x1b"
SEQUENCE_STARTS = frozenset("[O]P_^X")
"""Bytes that, after ESC, start a sequence the terminal sends (CSI, SS3, OSC, DCS, APC, PM,
SOS): the parser waits for the rest of it."""


class ConsoleKeyParser(XTermParser):
    """Textual's parser, with ``ESC x`` decided at once (module docstring)."""

    def _sequence_to_key_events(self, sequence: str, alt: bool = False) -> Iterable[events.Key]:
        if len(sequence) == 2 and sequence[0] == ESC and sequence[1] not in SEQUENCE_STARTS \
                and sequence[1] != ESC:
            char = sequence[1]
            if char.isascii() and char.isalpha():
                yield from super()._sequence_to_key_events(char, alt=True)
            else:
                yield events.Key("escape", ESC)
                yield from super()._sequence_to_key_events(char)
            return
        yield from super()._sequence_to_key_events(sequence, alt)


CLEAR_SCREEN = "\x1b[H\x1b[2J"
"""Cursor home, erase the whole screen."""


def console_driver(base: type[Driver]) -> type[Driver]:
    """:class:`ConsoleDriver` in place of Textual's Linux driver; any other driver as it is."""
    if linux_driver is None or base is not linux_driver.LinuxDriver:
        return base
    return ConsoleDriver


if linux_driver is not None:

    class ConsoleDriver(linux_driver.LinuxDriver):
        """Textual's Linux driver with :class:`ConsoleKeyParser` and a cleared screen on
        leaving."""

        def __init__(self, *args: object, **kwargs: object) -> None:
            # the input thread builds its parser from this module attribute (Textual 8.2)
            linux_driver.XTermParser = ConsoleKeyParser  # type: ignore[misc]
            super().__init__(*args, **kwargs)  # type: ignore[arg-type]

        def stop_application_mode(self) -> None:
            """Clear the alternate screen, then leave it as Textual does."""
            self.write(CLEAR_SCREEN)
            super().stop_application_mode()

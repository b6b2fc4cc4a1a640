"""The console's key help as plain data and text: the help screen's content and the key line
(footer) of each context.  No widgets here, so it can be tested without a terminal.

The keys themselves are the thesis' (cursor keys and Return move and select, L5496; the menu bar
of THEORY §12.6) plus the habits of today's text consoles: F1 help, F10 menu, Ctrl+Q quit,
Ctrl+P command palette, and "type the page number" (the navigators talk in page numbers,
THEORY §12.7).
"""

from __future__ import annotations

import re
import textwrap

from textual.binding import Binding

from uvnav_tui.menus import MENU_BAR, MenuItem
from uvnav_tui.pages.registry import DEV_PAGES_FROM, page_titles, sub_pages

HOT_KEYS = sorted({item.key for item in MENU_BAR})
"""The Alt+letter hot-keys of the bar titles (either mode)."""


def menu_key_bindings() -> list[Binding]:
    """F10 and Alt+letter open the menus (actions ``open_menu(i)`` / ``open_hot('x')`` of the
    screen).  Priority bindings: they run as the key is read, so the menu is on top before the
    next key is dispatched (a hot-key typed right after Alt+letter is never lost)."""
    return [
        Binding("f10", "open_menu(0)", "Menu", show=False, priority=True),
        *[Binding(f"alt+{key}", f"open_hot('{key}')", "Menu", show=False, priority=True)
          for key in HOT_KEYS],
    ]


KeyHint = tuple[str, str]
"""(key, what it does), e.g. ``("F1", "Help")``."""

CONSOLE_KEYS: tuple[KeyHint, ...] = (
    ("F1", "Help"),
    ("F10", "Menu"),
    ("Ctrl+Q", "Quit"),
    ("Alt+letter", "Menu"),
    ("nnn", "Go to page"),
    ("Ctrl+P", "Commands"),
    ("F2", "Messages"),
)
"""The key line over a page (more keys are added for sub-pages and scrolling).  Each list is
ordered by importance: what does not fit the width is left off from the end, so F1 and Ctrl+Q
come early (the key line shows them even at 80 columns)."""
SUB_PAGE_KEYS: KeyHint = ("PgUp/PgDn", "Sub-page")
SCROLL_KEYS: KeyHint = ("←↑↓→", "Scroll")
MENU_KEYS: tuple[KeyHint, ...] = (
    ("↑↓", "Move"),
    ("←→", "Menus"),
    ("Enter/→", "Open"),
    ("Letter", "Pick"),
    ("Esc", "Back"),
    ("F1", "Help"),
    ("Ctrl+Q", "Quit"),
)
DIALOG_KEYS: tuple[KeyHint, ...] = (
    ("Tab/Shift+Tab", "Field"),
    ("Enter", "OK"),
    ("Esc", "Cancel"),
    ("F1", "Help"),
    ("Ctrl+Q", "Quit"),
    ("Space", "Toggle"),
    ("←→", "Choose"),
)
CONFIRM_KEYS: tuple[KeyHint, ...] = (
    ("Y", "Yes"),
    ("N/Esc", "No"),
    ("Tab", "Button"),
    ("Enter", "Press"),
    ("Ctrl+Q", "Quit"),
)
TABLE_KEYS: tuple[KeyHint, ...] = (
    ("Esc/Enter", "Close"),
    ("↑↓ PgUp/PgDn", "Scroll"),
    ("F10/Alt+letter", "Menu"),
    ("F1", "Help"),
    ("Ctrl+Q", "Quit"),
)
HELP_KEYS: tuple[KeyHint, ...] = (
    ("Esc/F1/q", "Close"),
    ("↑↓ PgUp/PgDn Home/End", "Scroll"),
    ("Ctrl+Q", "Quit"),
)
PALETTE_KEYS: tuple[KeyHint, ...] = (
    ("type", "Search"),
    ("↑↓", "Choose"),
    ("Enter", "Run"),
    ("Esc", "Close"),
    ("Ctrl+Q", "Quit"),
)


def key_line(hints: tuple[KeyHint, ...] | list[KeyHint], width: int) -> str:
    """The hints as `` F1 Help  F10 Menu …`` in at most ``width`` columns: hints that do not
    fit are left off from the end (the list is ordered by importance), never cut in half."""
    text = ""
    for key, what in hints:
        part = f" {key} {what} "
        if len(text) + len(part) - 1 > width:  # the trailing blank may fall off the edge
            break
        text += part
    return text.rstrip()


def console_hints(page: int, scrollable: bool) -> list[KeyHint]:
    """The key line over page ``page`` (sub-page keys if it has sub-pages, scroll keys if its
    body is larger than the screen)."""
    hints = list(CONSOLE_KEYS)
    if len(sub_pages(page)) > 1:
        hints.insert(3, SUB_PAGE_KEYS)
    if scrollable:
        hints.insert(3, SCROLL_KEYS)
    return hints


# --------------------------------------------------------------------------- help text
def _menu_lines(items: tuple[MenuItem, ...], depth: int) -> list[str]:
    """The menu tree, hot-key letters in brackets; items of one mode only are marked."""
    out = []
    for item in items:
        if depth == 0:
            head = f"Alt+{item.key.upper()}  {item.label}"
        else:
            head = "  " * depth + f"[{item.key.upper()}] {item.label}"
        mark = {True: "  (developer mode)", False: "  (navigator mode)", None: ""}[item.dev]
        what = f"  {item.help}" if item.help and not item.children else ""
        out.append(((head + mark).ljust(36) + what).rstrip())
        if item.children:
            out.extend(_menu_lines(item.children, depth + 1))
    return out


def _page_paths() -> dict[int, str]:
    """Page number → the menu path that shows it (``Statistics ▸ LSE``)."""
    found: dict[int, str] = {}

    def walk(items: tuple[MenuItem, ...], path: tuple[str, ...]) -> None:
        for item in items:
            here = (*path, item.label)
            if item.action and item.action.startswith("page:"):
                found.setdefault(int(item.action.split(":", 1)[1]), " ▸ ".join(here))
            walk(item.children, here)

    walk(MENU_BAR, ())
    return found


def page_map_lines() -> list[str]:
    """Every page: number, title and how to reach it (menu path, or PgDn from its group)."""
    paths = _page_paths()
    out = []
    for number, title in page_titles().items():
        how = paths.get(number)
        if how is None:
            first = sub_pages(number)[0]
            how = f"PgDn from Pg {first}"
        dev = "  (developer)" if number >= DEV_PAGES_FROM else ""
        out.append(f"Pg {number}  {title.ljust(40)} {how}{dev}")
    return out


def _hint_lines(hints: tuple[KeyHint, ...] | list[KeyHint]) -> list[str]:
    return [f"  {key.ljust(24)} {what}" for key, what in hints]


TOPICS: tuple[tuple[str, str], ...] = (
    ("MPP", "Most Probable Position: the console's best position. With Kalman filtering on it "
     "is the filter's estimate (fix and dead reckoning combined); without a filter state it is "
     "the LSE or the dead reckoning. The MPP box's lower edge names the source (KF, LSE, DR); "
     "a / b are the semi-axes of its error ellipse at the ConfRegion level (Demo ▸ Page), Az "
     "the azimuth of a, RMS the root mean square of the two."),
    ("LSE", "Least-Squares Estimate: the fix computed from this cycle's lines of position "
     "alone (GPS Lat/Lon, the Decca patterns in use, Obs-menu observations), tested with "
     "Baarda's w-test; an LOP that fails may be discarded (LOPReject). Pg 631 lists the LOPs, "
     "Pg 633 the tests."),
    ("999.99", "A statistic that was not computed this cycle: with as many LOPs as unknowns "
     "there is no redundancy, so no w-test, τ or σ of a residual; an ellipse that does not "
     "exist prints 999.99 too. '---' is a value that is missing (a sensor off, no fix)."),
    ("Opening an NMEA log or a live source", "Run ▸ Start (or the start-up dialog), field Run "
     "file: type a .RUN name, or the path of an NMEA 0183 log (nmea/trip.nmea, ~/logs/a.log, "
     "/data/b.nmea), or a live source's URL (udp://0.0.0.0:10110, tcp://HOST:10110, "
     "serial:///dev/ttyUSB0?baud=4800). Tab completes a path, Ctrl+O opens a file picker. From "
     "the shell: uvnav --live URL, or uvnav replay LOG for a run without the console."),
    ("Where files go", "Each run writes a .OUT log (every cycle, every operator action) beside "
     "its run file when that folder is writable, otherwise in the current directory; the "
     "bundled demo's always in the current directory; uvnav --out-dir DIR chooses. A name in "
     "use is never overwritten (NAME_1.OUT …). A live run writes live-<UTC time>.OUT and the "
     "raw log beside it. Edit ▸ Hardcopy writes UVNAV_<run>_<time>_Pg<nnn>.svg and .txt "
     "(the page's whole text) in ./hardcopy (uvnav --hardcopy-dir DIR). The message line "
     "names each file written; the configuration in use is named at start."),
)
"""The help screen's topics: (title, text)."""


def help_text() -> str:
    """The whole help screen (F1 or ``?``) as plain text."""
    lines = [
        "UVNAV console help",
        "",
        "Keys over a page",
        *_hint_lines([
            ("F1 or ?", "This help (Esc closes it)"),
            ("F10, Enter or Space", "Open the menu bar (first menu)"),
            ("Alt+letter", "Open the menu with that underlined letter"),
            ("nnn (three digits)", "Go to page nnn, e.g. 6 4 2 for the position plot"),
            ("PgUp / PgDn", "Previous / next sub-page (641 → 642 → 643)"),
            ("← ↑ ↓ →  Home / End", "Scroll a page larger than the screen"),
            ("Ctrl+P", "Command palette: every menu item and every page by title"),
            ("F2", "The message log (Statistics ▸ Messages); Esc closes it"),
            ("F3", "Acknowledge an alarm (a live source lost): the bell stops"),
            ("Ctrl+Q or Ctrl+C", "Quit (asks for confirmation)"),
            ("Ctrl+Z", "Suspend to the shell (fg brings the console back)"),
            ("Ctrl+L", "Draw the whole screen again"),
        ]),
        "",
        "Keys in a menu",
        *_hint_lines([
            ("↑ / ↓", "Move the highlight"),
            ("← / →", "Previous / next menu on the bar; → opens a sub-menu (▸)"),
            ("Enter", "Choose the item or open its sub-menu"),
            ("letter", "Choose the item with that underlined letter"),
            ("Esc", "Close one level; F10 closes the whole menu"),
        ]),
        "",
        "Keys in a dialog",
        *_hint_lines([
            ("Tab / Shift+Tab", "Next / previous field"),
            ("Enter", "OK from any field (on a focused button: press it)"),
            ("Esc", "Cancel: nothing is changed"),
            ("Space", "Toggle a check box; ← / → choose a radio button"),
            ("Y / N", "Answer a Yes/No question"),
            ("F1", "Help on this dialog's fields (? types a ? in a field)"),
        ]),
        "",
        "Keys in a table (Kalman ▸ Predict., Kalman ▸ Smoothing)",
        *_hint_lines([
            ("↑ ↓ PgUp PgDn", "Scroll the rows"),
            ("Esc or Enter", "Close the table"),
            ("F10, Alt+letter", "Menus (Alt+E ▸ Hardcopy saves the table)"),
        ]),
        "",
        "Topics",
        *[line for title, text in TOPICS for line in ("", f"  {title}", f"    {text}")],
        "",
        "Menus and hot-keys (underlined letters)",
        *["  " + line for line in _menu_lines(MENU_BAR, 0)],
        "",
        "Page map",
        *["  " + line for line in page_map_lines()],
        "",
        "The run: Working... (cycles advance), Interrupted... (a menu or dialog is open; the",
        "run resumes when it closes), Suspended... (Run ▸ Suspend; Run ▸ Continue resumes).",
    ]
    return "\n".join(lines) + "\n"


def wrap_help(text: str, width: int) -> str:
    """``text`` with every line longer than ``width`` columns wrapped, its continuation lines
    indented under the line's description (the column after the last run of two or more
    blanks in the left half, e.g. a key's meaning) or, if none, two columns deeper than the
    line: the help reads without horizontal scrolling at 80 columns."""
    width = max(width, 20)
    out: list[str] = []
    for line in text.split("\n"):
        if len(line) <= width:
            out.append(line)
            continue
        lead = len(line) - len(line.lstrip(" "))
        columns = [lead + gap.end() - 1 for gap in re.finditer(r"\S( {2,})(?=\S)", line[lead:])]
        columns = [c + 1 for c in columns if c + 1 <= width // 2]
        hang = columns[-1] if columns else lead + 2
        out.extend(textwrap.wrap(line, width, subsequent_indent=" " * hang,
                                 break_on_hyphens=False) or [""])
    return "\n".join(out)

"""Edit ▸ Hardcopy: the current screen as an SVG screenshot plus a plain-text dump (A23).

Files are named ``UVNAV_<run>_<time>_Pg<nnn>.svg`` / ``.txt`` after the run name, the record time
of the last cycle (``HHMMSS``, not the wall clock) and the page number, or after the table shown
(``…_Predict``, ``…_Smoothing``); a second hardcopy of the same cycle and page gets ``_2``,
``_3`` … appended. Nothing is ever overwritten. The text file of a table (a screen with a
``full_text()``: Predict, Smoothing) is the whole table, and that of a page other than Pg 100
the page's whole text with a heading and the status column, not the part the terminal shows.
"""

from __future__ import annotations

import io
import os
from pathlib import Path

from rich.console import Console
from textual.app import App


def hardcopy_stem(run_name: str, time_hhmmss: str, page: int | str) -> str:
    """``UVNAV_<run>_<time>_Pg<nnn>`` for a page number, ``UVNAV_<run>_<time>_<what>`` for a
    named screen (``Predict``)."""
    what = f"Pg{page:03d}" if isinstance(page, int) else page
    return f"UVNAV_{run_name}_{time_hhmmss}_{what}"


def free_stem(directory: Path, stem: str) -> str:
    """``stem`` or ``stem_N`` such that neither the .svg nor the .txt exists yet (any directory
    entry counts, a dangling symbolic link too: writing through one would create a file
    wherever it points)."""
    candidate = stem
    n = 1
    while (os.path.lexists(directory / f"{candidate}.svg")
           or os.path.lexists(directory / f"{candidate}.txt")):
        n += 1
        candidate = f"{stem}_{n}"
    return candidate


def screen_text(app: App[object]) -> str:
    """The visible screen as plain text (one line per terminal row, trailing blanks removed).

    Renders the screen's compositor output into a recording console, as
    :meth:`textual.app.App.export_screenshot` does for the SVG (Textual is pinned).
    """
    width, height = app.size
    console = Console(width=width, height=height, file=io.StringIO(), force_terminal=True,
                      color_system=None, record=True, legacy_windows=False, safe_box=False)
    screen = app.screen
    update = screen._compositor.render_update(  # noqa: SLF001 - no public text export
        full=True, screen_stack=app._background_screens, simplify=True)  # noqa: SLF001
    console.print(update)
    text = console.export_text(styles=False)
    return "\n".join(line.rstrip() for line in text.splitlines()).rstrip("\n") + "\n"


def write_hardcopy(app: App[object], directory: Path, run_name: str, time_hhmmss: str,
                   page: int | str) -> tuple[Path, Path]:
    """Write the SVG and text hardcopies of the current screen; returns their paths."""
    directory.mkdir(parents=True, exist_ok=True)
    stem = free_stem(directory, hardcopy_stem(run_name, time_hhmmss, page))
    svg = directory / f"{stem}.svg"
    txt = directory / f"{stem}.txt"
    full_text = getattr(app.screen, "full_text", None)
    text = full_text() if callable(full_text) else None
    txt.write_text(text if text is not None else screen_text(app), encoding="utf-8")
    app.save_screenshot(filename=svg.name, path=str(directory))
    return svg, txt

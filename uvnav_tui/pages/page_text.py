"""Shared pieces of the numbered text pages (Statistics 6xx and Data 8xx, THEORY §12.8–12.10).

Pure text helpers (numbers, matrices, ellipse blocks) used by the ``p6nn_*``/``p8nn_*`` modules,
and :class:`TextPage`, the monochrome page body they all use: a scrolling text block whose text
comes from the page module's pure ``render(r, session)``.  Every number printed comes from the
engine; these helpers only lay it out, with the :mod:`engine.io.formatting` rules (no ``-0.00``,
``999.99`` for a statistic that was not computed).
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Sequence

import numpy as np
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import ScrollableContainer
from textual.widgets import Static

from engine.api import (
    SLOT_LABELS,
    STATE_LABELS,
    Adjustment,
    CycleResult,
    Ellipse,
    Ellipsoid3,
    FilterState,
    PositionEstimate,
    Session,
    format_stat,
)

MISSING = "---"
"""Printed for a value that does not exist this cycle (not a statistic: those print 999.99)."""
P999 = 0.999
"""The 99.9 % level of the Ellipsoid page (THEORY §12.9, L7697)."""
SLOT_NAMES = SLOT_LABELS
"""Row names of the LS observation slots, from the systems' registry (THEORY §5.3, Pg 821/830)."""


# --------------------------------------------------------------------------- numbers
def num(x: float | None, decimals: int = 2, width: int = 0, missing: str = MISSING) -> str:
    """``x`` with ``decimals`` decimals right-aligned in ``width`` (``missing`` if None/NaN)."""
    if x is None or not math.isfinite(x):
        return missing.rjust(width)
    return format_stat(float(x), width, decimals)


def compact(x: float, width: int) -> str:
    """``x`` in at most ``width`` characters (for wide matrices): ``0``, ``1``, ``-.766``,
    ``4.17``, ``1.2e+03``; leading zeros dropped, fewer digits until it fits."""
    if not math.isfinite(x):
        return "nan"[:width].rjust(width)
    if x == 0.0:
        return "0".rjust(width)
    for digits in (4, 3, 2, 1):
        text = f"{x:.{digits}g}"
        if "e" not in text:
            text = text.replace("-0.", "-.") if text.startswith("-0.") else (
                text[1:] if text.startswith("0.") else text)
        if len(text) <= width:
            return text.rjust(width)
    return f"{x:.0e}"[:width].rjust(width)


def matrix_lines(m: np.ndarray, decimals: int, width: int, *, indent: str = "",
                 labels: Sequence[str] | None = None, label_width: int = 0) -> list[str]:
    """One line per row of ``m``, every entry with ``decimals`` decimals in ``width`` columns,
    after ``indent`` (or the row's label padded to ``label_width``)."""
    rows = np.atleast_2d(np.asarray(m, dtype=float))
    out = []
    for i, row in enumerate(rows):
        head = labels[i].ljust(label_width) if labels is not None else indent
        out.append((head + "".join(num(float(v), decimals, width) for v in row)).rstrip())
    return out


def labelled_matrix(label: str, m: np.ndarray, decimals: int, width: int) -> list[str]:
    """A matrix whose first row follows ``label`` and whose other rows line up under it."""
    rows = matrix_lines(m, decimals, width)
    pad = " " * len(label)
    return [(label if i == 0 else pad) + row for i, row in enumerate(rows)]


def short_label(label: str, width: int) -> str:
    """A column label in ``width`` characters (``fix_e`` → ``fixe``)."""
    return (label if len(label) <= width else label.replace("_", ""))[:width]


def corr_text(x: float, width: int) -> str:
    """A correlation with two decimals and no leading zero (``.70``, ``-.70``, ``1.00``, ``0``)
    in ``width`` characters."""
    if not math.isfinite(x):
        return MISSING[:width].rjust(width)
    text = f"{x:.2f}"
    if float(text) == 0.0:
        return "0".rjust(width)
    return text.replace("0.", ".", 1).rjust(width) if abs(x) < 1.0 else text.rjust(width)


def compact_matrix_lines(m: np.ndarray, width: int, labels: Sequence[str], label_width: int,
                         max_width: int = 80,
                         fmt: Callable[[float, int], str] = compact, *,
                         col_labels: Sequence[str] | None = None) -> list[str]:
    """A wide matrix in ``fmt`` entries (default :func:`compact`) of ``width`` columns each
    (one space between),
    with a header row of the column labels (``col_labels``, else ``labels``: a square matrix);
    split into blocks of columns (separated by a blank line) if it would be wider than
    ``max_width``."""
    rows = np.atleast_2d(np.asarray(m, dtype=float))
    heads = labels if col_labels is None else col_labels
    per_block = max(1, (max_width - label_width) // width)
    out: list[str] = []
    for start in range(0, rows.shape[1], per_block):
        cols = range(start, min(start + per_block, rows.shape[1]))
        if start:
            out.append("")
        out.append((" " * label_width
                    + "".join(short_label(heads[j], width - 1).rjust(width) for j in cols))
                   .rstrip())
        for i, row in enumerate(rows):
            out.append((labels[i][:label_width - 1].ljust(label_width)
                        + "".join(fmt(float(row[j]), width - 1).rjust(width) for j in cols))
                       .rstrip())
    return out


def correlation(P: np.ndarray) -> np.ndarray:
    """The correlation matrix of a covariance matrix (NaN where a variance is not positive)."""
    cov = np.asarray(P, dtype=float)
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    with np.errstate(divide="ignore", invalid="ignore"):
        out = cov / np.outer(sd, sd)
    out[~np.isfinite(out)] = np.nan
    return out


def up_cov3(P: np.ndarray) -> np.ndarray:
    """The 3×3 (x East, y North, z Up) VCV of a filter's (x, y, depth) block (depth is down)."""
    c = np.array(np.asarray(P, dtype=float)[:3, :3])
    c[:2, 2] = -c[:2, 2]
    c[2, :2] = -c[2, :2]
    return c


def conf_level(session: Session | None) -> float:
    """The ``ConfRegion`` level of the run (0.95 by default)."""
    return 0.95 if session is None else session.config.lsq.conf_region_pct / 100.0


def pct(level: float) -> str:
    """``95.0%`` (the thesis' label of a confidence level)."""
    return f"{100.0 * level:.1f}%"


def conf_axes(est: PositionEstimate | None, level: float) -> tuple[float, float] | None:
    """(a, b) of an estimate's ellipse at ``level`` (None without a finite one)."""
    if est is None or est.ellipse is None:
        return None
    a, b = est.ellipse.scaled(level)
    return (a, b) if math.isfinite(a) and math.isfinite(b) else None


def adjustment_of(r: CycleResult) -> Adjustment | None:
    """The LS adjustment of cycle ``r`` (None without one: no LOPs, or no fix)."""
    fix = r.fix
    return None if fix is None or fix.tested is None else fix.tested.adjustment


def no_adjustment_text(r: CycleResult) -> str:
    """Why cycle ``r`` has no LS adjustment (for the Data pages)."""
    reason = "no LOPs" if r.fix is None else (r.fix.reason or "no adjustment")
    return f"No LS adjustment this cycle: {reason}."


# --------------------------------------------------------------------------- ellipses
def ellipse_block(label: str, e: Ellipse | Ellipsoid3, level: float) -> list[str]:
    """An ellipse (2-D) or ellipsoid (3-D) as on Pg 840: eigenvalue and row of E per axis, the
    azimuth/elevation of the major axis, the rotation angles ρ θ φ (°), and beside them the
    standard, ``level`` and 99.9 % semi-axes a b c (m)."""
    if isinstance(e, Ellipse):
        lam: tuple[float, ...] = e.eigenvalues
        rows = np.asarray(e.eigenvectors)
        az, elev = e.az_deg, 0.0
        rho, theta, phi = 0.0, 0.0, e.phi_deg  # 2-D: rotation about z only (eq. 5.28)
        levels = [(1.0, e.a_m, e.b_m, 0.0)]
        for p in (level, P999):
            a, b = e.scaled(p)
            levels.append((p, a, b, 0.0))
    else:
        lam = e.eigenvalues
        rows = np.asarray(e.E)
        az, elev = e.az_deg, e.elev_deg
        rho, theta, phi = e.rho_deg, e.theta_deg, e.phi_deg
        levels = [(1.0, *e.axes)]
        for p in (level, P999):
            levels.append((p, *e.scaled(p)))
    left = [num(lam[i], 2, 9) + "".join(num(float(v), 5, 9) for v in rows[i])
            for i in range(len(lam))]
    left.append(num(az, 2, 9) + num(elev, 2, 9))
    left.append(num(rho, 2, 9) + num(theta, 2, 9) + num(phi, 2, 9))
    right = ["        " + "a".rjust(8) + "b".rjust(8) + "c".rjust(8)]
    for p, a, b, c in levels:
        name = "Standard" if p == 1.0 else pct(p)
        right.append(name.ljust(8) + num(a, 2, 8) + num(b, 2, 8) + num(c, 2, 8))
    width = 36
    out = []
    for i in range(max(len(left), len(right))):
        head = f"{label} :" if i == 0 else ""
        body = left[i] if i < len(left) else ""
        side = right[i] if i < len(right) else ""
        out.append((head.ljust(6) + body.ljust(width) + "  " + side).rstrip())
    return out


# --------------------------------------------------------------------------- widget
class TextPage(ScrollableContainer, can_focus=True, inherit_bindings=False):
    """A numbered page body: a monochrome text block rebuilt by :meth:`page_text` (the module's
    pure ``render``) when the cycle or the run context changes, in a container that scrolls
    if the text is taller or wider than the page area (80×24: Pg 620, 631, 650, 8xx).  It takes
    the focus when its page is shown, so ← ↑ ↓ → Home End scroll it; PgUp/PgDn are left to the
    console (sub-pages).  The scroll bars are one cell wide and sit beside the text, never on
    it.  Subclasses set :attr:`NUMBER` and :attr:`TITLE`; their module defines
    ``render(r, session)``."""

    BINDINGS = [
        Binding("up", "scroll_up", "Scroll up", show=False),
        Binding("down", "scroll_down", "Scroll down", show=False),
        Binding("left", "scroll_left", "Scroll left", show=False),
        Binding("right", "scroll_right", "Scroll right", show=False),
        Binding("home", "scroll_home", "Top", show=False),
        Binding("end", "scroll_end", "Bottom", show=False),
        Binding("ctrl+pageup", "page_left", "Page left", show=False),
        Binding("ctrl+pagedown", "page_right", "Page right", show=False),
    ]

    DEFAULT_CSS = """
    TextPage {
        width: 1fr;
        height: 1fr;
        scrollbar-size: 1 1;
        scrollbar-background: $background;
        scrollbar-background-hover: $background;
        scrollbar-background-active: $background;
        scrollbar-color: $foreground 50%;
        scrollbar-color-hover: $foreground;
        scrollbar-color-active: $foreground;
        scrollbar-corner-color: $background;
    }
    TextPage:focus {
        background-tint: $foreground 0%;
    }
    TextPage > .page-text {
        width: auto;
        height: auto;
        text-wrap: nowrap;
    }
    """

    NUMBER = 0
    TITLE = ""

    H_STEP = 8
    """Columns scrolled by one press of ← or → (a text page is read in columns of numbers)."""

    def action_scroll_left(self) -> None:
        """←: :attr:`H_STEP` columns left, at once (no animation)."""
        self.scroll_to(x=max(self.scroll_target_x - self.H_STEP, 0), animate=False)

    def action_scroll_right(self) -> None:
        """→: :attr:`H_STEP` columns right, at once (no animation)."""
        self.scroll_to(x=min(self.scroll_target_x + self.H_STEP, self.max_scroll_x),
                       animate=False)

    def action_scroll_up(self) -> None:
        """↑: one line up, at once."""
        self.scroll_to(y=max(self.scroll_target_y - 1, 0), animate=False)

    def action_scroll_down(self) -> None:
        """↓: one line down, at once."""
        self.scroll_to(y=min(self.scroll_target_y + 1, self.max_scroll_y), animate=False)

    def __init__(self) -> None:
        super().__init__()
        self._shown: tuple[object, ...] | None = None
        self.text = self.empty_text()
        """The text shown (for tests and hardcopies)."""

    def compose(self) -> ComposeResult:
        """The text block."""
        yield Static(self.text, markup=False, classes="page-text")

    def empty_text(self) -> str:
        """What the page shows before the first cycle."""
        return f"{self.TITLE}\n\nno cycle yet"

    def page_text(self, r: CycleResult, session: Session) -> str:
        """The page for cycle ``r`` of ``session``: the ``render(r, session)`` function of the
        module that defines the page class (looked up at call time)."""
        render: Callable[[CycleResult, Session], str] = sys.modules[type(self).__module__].render
        return render(r, session)

    def show(self, r: CycleResult | None, session: Session | None) -> None:
        """Render cycle ``r`` of ``session`` (None before the first cycle)."""
        context = None if session is None else session.context
        shown = self._shown
        if shown is not None and shown[0] is r and shown[1] is session and shown[2] is context:
            return
        self._shown = (r, session, context)
        text = (self.empty_text() if r is None or session is None
                else self.page_text(r, session))
        if text != self.text:
            self.text = text
            self._sync()

    def on_mount(self) -> None:
        """Show the latest text (``show`` may have run while the block was being mounted)."""
        self._sync()

    def _sync(self) -> None:
        for block in self.query(".page-text").results(Static):
            block.update(self.text)


def state_labels(fs: FilterState) -> list[str]:
    """Labels of every state: the 11 navigation states, then the fix-error states."""
    return list(STATE_LABELS) + list(fs.fix_states)

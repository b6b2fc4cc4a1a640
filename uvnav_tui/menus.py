"""The console's action registry: the menu tree (THEORY §12.6, D36–D37) as plain data, no widgets.

The thesis' ``UVNAV.MNU`` layout file is lost (A8.3), so the tree is built in here. Each leaf
carries everything the console needs to know about one action: its label and hot-key letter,
its action id (the handler: the method of that name of :class:`uvnav_tui.actions.MenuActions`,
or ``page:nnn`` to show a page), whether it needs a run, its help text, and the
navigator/developer partition: ``dev=True`` items show only in developer mode, ``dev=False``
items only in navigator mode, ``dev=None`` items always (A4).  The pulldowns, the command
palette, the help screen and the needs-a-run check all read this one tree.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

from uvnav_tui.pages.registry import DEV_PAGES_FROM, page_titles


@dataclass(frozen=True)
class MenuItem:
    """One menu entry: a leaf with an ``action`` id, or a sub-menu with ``children``."""

    label: str
    action: str | None = None
    children: tuple[MenuItem, ...] = ()
    hotkey: str = ""
    dev: bool | None = None
    help: str = ""
    needs_run: bool = False
    """True if the action acts on the run (refused with ``No run: …`` before the first one)."""

    @property
    def key(self) -> str:
        """The hot-key letter (lower case): ``hotkey`` or the first letter of the label."""
        return (self.hotkey or self.label[:1]).lower()

    def visible(self, dev_mode: bool) -> bool:
        """True if the item shows in the given mode (navigator or developer)."""
        return self.dev is None or self.dev == dev_mode

    def shown_children(self, dev_mode: bool) -> tuple[MenuItem, ...]:
        """The sub-items visible in the given mode."""
        return tuple(c for c in self.children if c.visible(dev_mode))


def _leaf(label: str, action: str, help: str, *, hotkey: str = "",
          dev: bool | None = None) -> MenuItem:
    """An item that works with or without a run."""
    return MenuItem(label, action=action, hotkey=hotkey, dev=dev, help=help)


def _run(label: str, action: str, help: str, *, hotkey: str = "",
         dev: bool | None = None) -> MenuItem:
    """An item that acts on the run (``No run: …`` before the first one)."""
    return MenuItem(label, action=action, hotkey=hotkey, dev=dev, help=help, needs_run=True)


def _page(label: str, page: int, help: str, *, hotkey: str = "") -> MenuItem:
    return MenuItem(label, action=f"page:{page}", hotkey=hotkey, help=f"Pg {page}: {help}")


MENU_BAR: tuple[MenuItem, ...] = (
    MenuItem("Quit", children=(
        _leaf("Quit", "quit", "Leave the program (asks for confirmation)"),
    )),
    MenuItem("Edit", children=(
        _leaf("Hardcopy", "hardcopy", "Save the current page as SVG and plain text"),
    )),
    MenuItem("Setup", children=(
        MenuItem("Params", children=(
            _run("Datum", "datum", "Choose a new working datum"),
            _run("DR Pos", "dr_pos", "Enter a new dead-reckoning position", hotkey="p"),
            _run("Current", "current", "Change the current set and speed"),
            _leaf("Develop", "develop", "Switch to the developer menus", hotkey="v", dev=False),
            _leaf("Reset", "reset", "Return to the navigator menus", dev=True),
        )),
        MenuItem("Systems", hotkey="y", children=(
            _run("GPS", "gps", "GPS on/off and receiver type"),
            _run("Decca", "decca", "Decca on/off, chain, zone/lane and patterns"),
            _leaf("SINS", "sins", "SINS (not connected)"),
            _leaf("Omega", "omega", "Omega (not connected)"),
            _leaf("Loran-C", "loran", "Loran-C (not connected)"),
        )),
        _run("Sensors", "sensors", "Switch the bounded sensors on/off", hotkey="e"),
    )),
    MenuItem("Obs", children=(
        _run("Bearing", "obs_bearing", "A bearing to a charted station"),
        _run("Distance", "obs_distance", "A radar distance to a charted station"),
        _run("Radar", "obs_radar", "Radar bearing and distance to one station"),
    )),
    MenuItem("Kalman", children=(
        _run("Filtering", "filtering", "Kalman filter on/off"),
        _run("Predict.", "predict", "Predict position and ellipse over a time interval"),
        _run("Smoothing", "smoothing", "Smoothed positions of the run so far"),
    )),
    MenuItem("Statistics", hotkey="t", children=(
        MenuItem("Systems", children=(
            _page("GPS", 611, "GPS statistics"),
            _page("Decca", 615, "Decca statistics"),
        )),
        _page("Sensors", 620, "sensor statistics", hotkey="e"),
        _page("LSE", 631, "LOP table and LS tests"),
        _page("KF", 650, "Kalman filter state and tests"),
        MenuItem("Position", children=(
            _page("Positions", 641, "LSE, KF and MPP positions"),
            _page("Plot", 642, "position plot", hotkey="l"),
            _page("History", 643, "track history"),
        )),
        _page("MainPage", 100, "main page"),
        _leaf("Messages", "messages", "The message log: every message with its time (F2)",
              hotkey="g"),
    )),
    MenuItem("Demo", children=(
        _page("Page", 710, "the demo parameters in force", hotkey="g"),
        _run("Parameters", "demo_params", "Sample interval, pace, plot, specific weight"),
        _run("Corrections", "demo_corrections", "Observation corrections (C-O)", dev=True),
        _run("LS params", "demo_lsq", "Least-squares and testing parameters", hotkey="l",
             dev=True),
        _run("Filter params", "demo_filter", "Kalman filter parameters", hotkey="f", dev=True),
    )),
    MenuItem("Data", hotkey="a", dev=True, children=(
        _page("Decca", 810, "Decca chain data"),
        _page("A-prio", 821, "design matrix and a-priori VCV"),
        _page("Weights", 830, "LS weight matrix"),
        _page("Ellipsoid", 840, "error ellipses and ellipsoids"),
        _page("Kalman", 850, "Kalman matrices and vectors"),
    )),
    MenuItem("Run", children=(
        _run("Continue", "run_continue", "Leave the suspended state"),
        _run("Suspend", "run_suspend", "Freeze the display after the last cycle"),
        _leaf("Start", "run_start", "New run: back to Parameter Initialization (confirm)",
              hotkey="t"),
    )),
)
"""The bar ``Quit Edit Setup Obs Kalman Statistics Demo Data Run`` and its pulldowns."""

def visible_bar(dev_mode: bool) -> tuple[MenuItem, ...]:
    """The bar titles shown in the given mode (the Data title is developer-only, A4)."""
    return tuple(m for m in MENU_BAR if m.visible(dev_mode))


def iter_leaves(dev_mode: bool,
                items: tuple[MenuItem, ...] | None = None,
                path: tuple[str, ...] = ()) -> Iterator[tuple[tuple[str, ...], MenuItem]]:
    """Every visible leaf with its label path, in menu order (for the command palette)."""
    for item in visible_bar(dev_mode) if items is None else items:
        if not item.visible(dev_mode):
            continue
        here = (*path, item.label)
        if item.children:
            yield from iter_leaves(dev_mode, item.children, here)
        else:
            yield here, item


def _all_leaves(items: tuple[MenuItem, ...]) -> Iterator[MenuItem]:
    for item in items:
        yield from _all_leaves(item.children) if item.children else (item,)


ACTIONS: dict[str, MenuItem] = {
    item.action: item for item in _all_leaves(MENU_BAR) if item.action is not None
}
"""Every leaf of either mode by its action id."""


def palette_entries(dev_mode: bool) -> Iterator[tuple[str, str, str]]:
    """(title, help, action id) of every command-palette entry in the given mode: each visible
    menu leaf (titled by its path), then each page (``Pg nnn title``)."""
    for path, item in iter_leaves(dev_mode):
        assert item.action is not None
        yield " ▸ ".join(path), item.help, item.action
    for number, title in page_titles().items():
        if number < DEV_PAGES_FROM or dev_mode:
            yield f"Pg {number} {title}", f"Show page {number}", f"page:{number}"


def find_path(labels: list[str], dev_mode: bool) -> list[int]:
    """Indices (per level, among visible items) of a label path like ``Setup > Systems > GPS``.

    Labels match case-insensitively; raises ``KeyError`` naming the first unknown label.
    """
    indices: list[int] = []
    items = visible_bar(dev_mode)
    for depth, label in enumerate(labels):
        wanted = label.strip().lower()
        for i, item in enumerate(items):
            if item.label.lower() == wanted:
                indices.append(i)
                items = item.shown_children(dev_mode)
                break
        else:
            where = " > ".join(labels[:depth]) or "the menu bar"
            raise KeyError(f"no item {label.strip()!r} in {where}")
    return indices


def item_at(indices: list[int], dev_mode: bool) -> MenuItem:
    """The visible item reached by ``indices`` (see :func:`find_path`)."""
    items = visible_bar(dev_mode)
    item = items[indices[0]]
    for i in indices[1:]:
        item = item.shown_children(dev_mode)[i]
    return item

"""Snapshot tests (pytest-textual-snapshot) of every Statistics/Data text page widget, mounted
alone in a small test App (100 × 34, no animations): after the 2 first cycles of the sample run
data/920917_1.toml, and after the first 600 cycles of data/DEMO.toml (every sensor on,
coloured fix-error states).

The pages show only engine values of the given cycle (no wall clock), so the screenshots are
deterministic.  Update with ``pytest --snapshot-update`` after a deliberate change and review
the SVGs in tests/__snapshots__/test_pages_snapshots/.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import pytest
from textual.app import App, ComposeResult

from engine.api import CycleResult, Session, load_config
from tests.paths import DATA
from uvnav_tui.pages.page_text import TextPage
from uvnav_tui.pages.registry import make_page

SIZE = (100, 34)
TEXT_PAGE_NUMBERS = [611, 615, 620, 631, 633, 641, 650, 810, 821, 830, 840, 850, 851, 852, 853]
"""The text pages (642/643 are plots with their own tests)."""


class PageApp(App[None]):
    """One page body, shown with one cycle."""

    TITLE = "UVNAV page"

    def __init__(self, number: int, r: CycleResult, session: Session) -> None:
        super().__init__()
        self.animation_level = "none"
        self.page = make_page(number)
        assert isinstance(self.page, TextPage)
        self.cycle = r
        self.session = session

    def compose(self) -> ComposeResult:
        """Just the page."""
        yield self.page

    def on_mount(self) -> None:
        """Render the cycle."""
        self.page.show(self.cycle, self.session)  # type: ignore[attr-defined]


def run_cycles(config: str, cycles: int) -> tuple[Session, CycleResult]:
    """A session on ``config`` after ``cycles`` cycles, and its last cycle."""
    session = Session(load_config(DATA / config))
    r = None
    for _ in range(cycles):
        r = session.step()
    assert r is not None and r.n == cycles
    return session, r


@pytest.fixture(scope="module")
def sample() -> Iterator[tuple[Session, CycleResult]]:
    """Cycle 2 (08:35:39Z) of the sample run."""
    session, r = run_cycles("920917_1.toml", 2)
    yield session, r
    session.close()


@pytest.fixture(scope="module")
def demo() -> Iterator[tuple[Session, CycleResult]]:
    """Cycle 600 of the demo run."""
    session, r = run_cycles("DEMO.toml", 600)
    yield session, r
    session.close()


@pytest.mark.parametrize("number", TEXT_PAGE_NUMBERS)
def test_page_sample(snap_compare: Callable[..., bool], sample: tuple[Session, CycleResult],
                     number: int) -> None:
    """The page after two cycles of the sample run."""
    session, r = sample
    assert snap_compare(PageApp(number, r, session), terminal_size=SIZE)


@pytest.mark.parametrize("number", TEXT_PAGE_NUMBERS)
def test_page_demo(snap_compare: Callable[..., bool], demo: tuple[Session, CycleResult],
                   number: int) -> None:
    """Every text page after the first 600 cycles of the demo run."""
    session, r = demo
    assert snap_compare(PageApp(number, r, session), terminal_size=SIZE)

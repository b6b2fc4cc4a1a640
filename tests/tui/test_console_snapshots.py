"""Snapshot tests (pytest-textual-snapshot): the start-up dialog, the main page, every pulldown
and the suspended main page after the 10 sample records of data/920917_1.toml.

Everything that varies is pinned: terminal size, held cycles (no clock: the state line shows the
record time), no blinking cursors, and all workers awaited before the screenshot
(harlequin-style ``run_before``). Update with ``pytest --snapshot-update`` after a deliberate
change and review the SVGs.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from pathlib import Path

import pytest
from test_console_support import copy_data, freeze, make_app, start
from textual.pilot import Pilot

from uvnav_tui.app import UVNAVApp

SMALL = (80, 24)
LARGE = (100, 30)


@pytest.fixture
def data_dir(tmp_path: Path) -> Path:
    """A private copy of the data files."""
    return copy_data(tmp_path / "data")


def settle(action: Callable[[Pilot[None]], Awaitable[None]] | None = None
           ) -> Callable[[Pilot[None]], Awaitable[None]]:
    """``run_before``: do ``action``, then await every worker and freeze the cursors."""

    async def run_before(pilot: Pilot[None]) -> None:
        if action is not None:
            await action(pilot)
        await pilot.app.workers.wait_for_complete()
        await pilot.pause()
        assert isinstance(pilot.app, UVNAVApp)
        freeze(pilot.app)
        await pilot.pause()

    return run_before


def test_parameter_initialization(snap_compare: Callable[..., bool], data_dir: Path) -> None:
    """The start-up dialog over the empty main page, pre-filled from the configuration."""
    app = make_app(data_dir)
    assert snap_compare(app, terminal_size=SMALL, run_before=settle())


def test_main_page(snap_compare: Callable[..., bool], data_dir: Path) -> None:
    """Pg 100 after three sample cycles, working."""
    app = make_app(data_dir)

    async def action(pilot: Pilot[None]) -> None:
        await start(pilot, 3)

    assert snap_compare(app, terminal_size=LARGE, run_before=settle(action))


def test_main_page_suspended_at_end_of_sample(snap_compare: Callable[..., bool],
                                             data_dir: Path) -> None:
    """All 10 sample records replayed: suspended with "End of data file" at 08:35:47Z."""
    app = make_app(data_dir, hold=False)

    async def action(pilot: Pilot[None]) -> None:
        await start(pilot)
        await pilot.app.wait_cycles(100)
        assert pilot.app.control.eof and pilot.app.control.cycles == 10

    assert snap_compare(app, terminal_size=LARGE, run_before=settle(action))


def test_statistics_page_frame(snap_compare: Callable[..., bool], data_dir: Path) -> None:
    """A page other than 100: the left status column beside the (placeholder) page body."""
    app = make_app(data_dir)

    async def action(pilot: Pilot[None]) -> None:
        await start(pilot, 2)
        await pilot.press("alt+t", "s", "g")

    assert snap_compare(app, terminal_size=SMALL, run_before=settle(action))


PULLDOWNS = [
    ("quit", ("alt+q",), False),
    ("edit", ("alt+e",), False),
    ("setup_params", ("alt+s", "p"), False),
    ("obs", ("alt+o",), False),
    ("kalman", ("alt+k",), False),
    ("statistics_systems", ("alt+t", "s"), False),
    ("demo", ("alt+d",), False),
    ("data_dev", ("alt+a",), True),
    ("run", ("alt+r",), False),
]


@pytest.mark.parametrize(("name", "keys", "dev"), PULLDOWNS, ids=[p[0] for p in PULLDOWNS])
def test_pulldown(snap_compare: Callable[..., bool], data_dir: Path, name: str,
                  keys: tuple[str, ...], dev: bool) -> None:
    """Each pulldown open over the main page (the run shows Interrupted...)."""
    app = make_app(data_dir, dev_mode=dev)

    async def action(pilot: Pilot[None]) -> None:
        await start(pilot, 1)
        await pilot.press(*keys)

    assert snap_compare(app, terminal_size=SMALL, run_before=settle(action))

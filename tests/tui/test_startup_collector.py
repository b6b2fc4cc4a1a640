"""The console pauses the cyclic garbage collector from start-up to its first paint only
(issue 14, start-up time): once the first frame is on screen the collector is on again."""

from __future__ import annotations

import asyncio
import gc
from pathlib import Path

from test_console_support import make_app


def test_collector_back_on_after_first_paint(data_dir: Path) -> None:
    assert gc.isenabled()
    app = make_app(data_dir)
    seen: list[bool] = []

    async def run() -> None:
        async with app.run_test(size=(160, 50)) as pilot:
            await pilot.pause()
            await pilot.pause()
            seen.append(gc.isenabled())

    app.hold_collector_until_painted()
    try:
        assert not gc.isenabled()
        asyncio.run(run())
    finally:
        app.release_collector()
    assert seen == [True]
    assert gc.isenabled()


def test_collector_untouched_without_hold(data_dir: Path) -> None:
    app = make_app(data_dir)

    async def run() -> None:
        async with app.run_test(size=(160, 50)) as pilot:
            await pilot.pause()
            assert gc.isenabled()

    asyncio.run(run())
    app.release_collector()
    assert gc.isenabled()

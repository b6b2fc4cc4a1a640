"""Shared helpers of the console tests (imported by the other test_console_* modules), plus the
tests of the console's plain-data parts: the menu tree, the run controller and the page texts."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Awaitable, Callable
from pathlib import Path

import pytest
from textual.pilot import Pilot
from textual.widgets import Input

from engine.api import RunConfig, Session, load_config, pace_factor
from tests.paths import DATA, copy_data  # noqa: F401 (re-exported to the test_console_* modules)
from uvnav_tui.app import UVNAVApp
from uvnav_tui.hardcopy import free_stem, hardcopy_stem, screen_text
from uvnav_tui.menus import MENU_BAR, find_path, item_at, iter_leaves, visible_bar
from uvnav_tui.pages.main_page import decca_box_lines, position_box_lines, sensor_strip
from uvnav_tui.run_control import RunController
from uvnav_tui.widgets.key_line import KeyLine
from uvnav_tui.widgets.status_column import status_lines


def blunder_data(tmp_path: Path) -> Path:
    """A private data folder whose sample has a GPS blunder at 08:35:42 (latitude 5″ off): the
    w-test flags LOP GPS Lat there, and under LOPReject 'A' the console asks about it."""
    data_dir = copy_data(tmp_path / "data")
    run = data_dir / "920917_1.RUN"
    run.write_text(run.read_text().replace("083542\t52 50 32.509", "083542\t52 50 37.509"))
    return data_dir


def make_app(data_dir: Path, name: str = "920917_1", **kw: object) -> UVNAVApp:
    """A console on ``name``.toml of ``data_dir``: fast pace and held cycles unless told."""
    kw.setdefault("pace_override", "fast")
    kw.setdefault("hold", True)
    kw.setdefault("hardcopy_dir", data_dir / "hardcopy")
    return UVNAVApp(load_config(data_dir / f"{name}.toml"), **kw)  # type: ignore[arg-type]


async def start(pilot: object, cycles: int = 0) -> UVNAVApp:
    """Accept the Parameter Initialization dialog with Return and run ``cycles`` cycles."""
    from uvnav_tui.dialogs.init_dialog import InitDialog

    app = pilot.app  # type: ignore[attr-defined]
    await wait_for(pilot, lambda: isinstance(app.screen, InitDialog)
                   and app.screen.is_mounted, "Parameter Initialization")
    await pilot.press("enter")  # type: ignore[attr-defined]
    await wait_for(pilot, lambda: app.control is not None, "the run to start", 30.0)
    if cycles:
        await app.wait_cycles(cycles)
        await pilot.pause()  # type: ignore[attr-defined]
    return app


async def wait_for(pilot: object, condition: Callable[[], bool], what: str,
                   timeout_s: float = 60.0) -> None:
    """Let the app run until ``condition()`` holds (checked after every idle point); fail
    naming ``what`` after ``timeout_s``.  Tests wait for a condition, never for a fixed time:
    a loaded machine makes every step slower, never a wait too short."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")
        await pilot.pause(0.01)  # type: ignore[attr-defined]


def freeze(app: UVNAVApp) -> None:
    """No blinking cursors, and the key lines of every screen brought up to date now rather
    than by their 0.5-s timer (whether a page shows "Scroll" depends on its laid-out size):
    snapshots and text dumps must not depend on timing."""
    for field in app.screen.query(Input):
        field.cursor_blink = False
    for screen in app.screen_stack:
        for line in screen.query(KeyLine):
            line.sync()


def drive(app: UVNAVApp, script: Callable[[Pilot[None]], Awaitable[None]],
          size: tuple[int, int] = (100, 30)) -> None:
    """Run ``script`` against ``app`` in a headless terminal of ``size`` (columns, rows)."""

    async def main() -> None:
        async with app.run_test(size=size) as pilot:
            await script(pilot)

    asyncio.run(main())


def text_of(app: UVNAVApp) -> str:
    """The visible screen as text."""
    return screen_text(app)




# ------------------------------------------------------------------------------------------
# Plain-data parts


def test_menu_bar_is_the_thesis_bar() -> None:
    """Navigator bar hides Data; developer bar has all nine titles in the thesis order."""
    assert [m.label for m in visible_bar(True)] == [
        "Quit", "Edit", "Setup", "Obs", "Kalman", "Statistics", "Demo", "Data", "Run"]
    assert "Data" not in [m.label for m in visible_bar(False)]


def test_hotkeys_are_unique_per_menu() -> None:
    """Every level's hot-key letters are distinct in both modes."""
    def check(items: tuple, dev: bool) -> None:
        shown = [i for i in items if i.visible(dev)]
        keys = [i.key for i in shown]
        assert len(keys) == len(set(keys)), [i.label for i in shown]
        for i in shown:
            check(i.children, dev)

    for dev in (False, True):
        check(MENU_BAR, dev)


def test_develop_and_reset_partition() -> None:
    """Develop only for the navigator, Reset only for the developer (A4)."""
    nav = [" > ".join(p) for p, _ in iter_leaves(False)]
    dev = [" > ".join(p) for p, _ in iter_leaves(True)]
    assert "Setup > Params > Develop" in nav and "Setup > Params > Reset" not in nav
    assert "Setup > Params > Reset" in dev and "Setup > Params > Develop" not in dev
    assert not any(p.startswith("Data") for p in nav)
    assert "Data > Weights" in dev and "Demo > LS params" in dev


def test_find_path() -> None:
    """Menu paths resolve case-insensitively; unknown labels name the level."""
    idx = find_path(["setup", "Systems", "gps"], False)
    assert item_at(idx, False).action == "gps"
    with pytest.raises(KeyError, match="no item 'Nope' in Setup"):
        find_path(["Setup", "Nope"], False)


def test_pace_factor() -> None:
    """real = 1, fast = inf, xN = N."""
    assert pace_factor("real") == 1.0
    assert pace_factor("x20") == 20.0
    assert pace_factor("fast") == float("inf")


def test_controller_states_and_budget(data_dir: Path) -> None:
    """State words, the cycle budget and the end of the data file."""
    run = RunController(Session.from_file(data_dir / "920917_1.toml"))
    assert run.state_word == "Working..."
    run.interrupted = True
    assert run.state_word == "Interrupted..." and not run.can_run()
    run.interrupted = False
    run.budget = 0
    assert not run.can_run()
    run.grant(2)
    assert run.can_run() and run.interval_s() == 1.0
    with run.lock:
        run.step()
        run.step()
    assert run.cycles == 2 and run.budget == 0 and not run.can_run()
    run.budget = None
    with run.lock:
        while run.step() is not None:
            pass
    assert run.eof and run.state_word == "Suspended..." and run.note == "End of data file"
    run.close()


def test_page_texts_of_a_sample_cycle(data_dir: Path) -> None:
    """Pg 100 and side-column texts use the thesis labels and formats."""
    session = Session.from_file(data_dir / "920917_1.toml")
    r = session.step()
    assert r is not None
    cfg: RunConfig = session.config
    lines = position_box_lines(r.mpp, r.datum, r.fix.rms_m, 0.95)
    assert lines[0].startswith("Datum : ED50") and "Hg : 0.0 m" in lines[0]
    assert lines[1].startswith("Lat : 52°50'") and lines[1].endswith('" N')
    assert lines[2].startswith("Lon : 004°31'") and lines[2].endswith('" E')
    assert lines[3].startswith("RMS : ") and "Az : " in lines[3]
    assert lines[4].startswith("a / b : ")
    strip = sensor_strip(r, cfg)
    assert strip == "GYRO 232.4°  LOG 12.7kts  RUDR OFF  INCL N/A  PRESS OFF  ECHO N/A"
    assert decca_box_lines(r, cfg) == ["Chain 9B", "Red    B20.9 *", "Green  F34.3 *",
                                       "Purple A51.1"]
    side = status_lines(r, cfg)
    assert side[:5] == ["Time 08:35:38Z", "Systems: G...D", "LOPs : 4",
                        f"Filter : {r.filter_status}", "CM 005°00.00'E"]
    session.close()


def test_hardcopy_names(tmp_path: Path) -> None:
    """UVNAV_<run>_<time>_Pg<nnn>, never overwriting."""
    stem = hardcopy_stem("DEMO", "104959", 100)
    assert stem == "UVNAV_DEMO_104959_Pg100"
    assert free_stem(tmp_path, stem) == stem
    (tmp_path / f"{stem}.txt").write_text("x")
    assert free_stem(tmp_path, stem) == f"{stem}_2"



def test_fast_pace_runs_cycles_in_batches(data_dir: Path) -> None:
    """At pace fast the worker computes several cycles per wake-up of the display, and every
    cycle is still counted and kept; a budget stops a batch at its last cycle."""
    run = RunController(Session.from_file(data_dir / "920917_1.toml"), pace_override="fast")
    woken: list[int] = []
    ended: list[bool] = []
    run.budget = 7
    run.run_cycles(lambda: False, advanced=lambda: woken.append(run.cycles),
                   ended=lambda: ended.append(True), question=lambda r: None)
    assert run.cycles == 7 and run.budget == 0 and not ended
    assert 1 <= len(woken) < 7 and woken[-1] == 7
    run.budget = None
    run.run_cycles(lambda: False, advanced=lambda: woken.append(run.cycles),
                   ended=lambda: ended.append(True), question=lambda r: None)
    assert run.cycles == 10 and run.eof and ended == [True]
    assert [r.n for r in run.session.history] == list(range(1, 11))
    run.close()


def test_message_panel_sync_writes_as_one_write_per_entry(data_dir: Path) -> None:
    """The panel's lines after one sync of many entries are those of one write per entry."""
    from rich.text import Text

    from uvnav_tui.widgets.message_log import MessageLog
    from uvnav_tui.widgets.message_panel import MessageLogView

    app = make_app(data_dir)
    log = MessageLog()
    for i in range(40):
        log.add(f"message {i} " + "long words " * (i % 9), wall_s=0.0)

    async def run() -> tuple[list[str], list[str]]:
        async with app.run_test(size=(100, 40)) as pilot:
            await pilot.pause()
            synced, written = MessageLogView(), MessageLogView()
            await app.screen.mount(synced)
            await app.screen.mount(written)
            await pilot.pause()
            assert synced._size_known  # the batched path, not RichLog's deferred writes
            synced.sync(log)
            for e in log.since(0)[1]:
                written.write(Text(e.line()))
            await pilot.pause()
            assert synced.virtual_size == written.virtual_size
            assert synced.scroll_offset == written.scroll_offset
            return ([s.text for s in synced.lines], [s.text for s in written.lines])

    synced, written = asyncio.run(run())
    assert len(synced) > 40 and synced == written


def test_message_panel_sync_scrolls_without_a_layout(data_dir: Path) -> None:
    """Once its scrollbar shows, a sync of new entries updates the scrollbar and ends at the
    newest line without a layout of the screen (which would redraw all of it; issue 14)."""
    from uvnav_tui.widgets.message_log import MessageLog
    from uvnav_tui.widgets.message_panel import MessageLogView

    app = make_app(data_dir)
    log = MessageLog()

    async def run() -> None:
        async with app.run_test(size=(100, 40)) as pilot:
            await pilot.pause()
            view = MessageLogView()
            await app.screen.mount(view)
            await pilot.pause()
            for i in range(60):
                log.add(f"message {i}", wall_s=0.0)
            view.sync(log)
            await pilot.pause()
            assert view.show_vertical_scrollbar and view.scroll_y == view.max_scroll_y > 0
            for i in range(60, 75):
                log.add(f"message {i}", wall_s=0.0)
            screen = app.screen
            layouts: list[bool] = []
            refresh_layout = screen._refresh_layout

            def counted(*args: object, **kwargs: object) -> None:
                layouts.append(True)
                refresh_layout(*args, **kwargs)  # type: ignore[arg-type]

            screen._refresh_layout = counted  # type: ignore[method-assign]
            view.sync(log)
            await pilot.pause()
            assert layouts == []
            assert view.virtual_size.height == 75
            assert view.vertical_scrollbar.window_virtual_size == 75
            assert view.scroll_y == view.max_scroll_y
            last = view.scroll_y + view.scrollable_content_region.height - 1
            assert view.lines[last].text.endswith("message 74")

    asyncio.run(run())

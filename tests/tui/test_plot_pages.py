"""Pg 642 position plot, Pg 643 History and Pg 710 Demo parameters, rendered from a Session on
data/DEMO.toml: after 600 cycles (surfaced, GPS + Decca fixes every second) and after 3000
cycles (dived at 10:45:00Z, five minutes without an LSE).  Text tests on the pure page
functions, the redraw throttle in a tiny App, and SVG snapshots of 642/643 during the dive
(update with ``pytest --snapshot-update`` after a deliberate change and review the SVGs).
"""

from __future__ import annotations

import asyncio
import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass

import pytest
from test_console_support import wait_for
from textual.app import App, ComposeResult

from engine.api import CycleResult, RunConfig, RunContext, Session, drms, lse_estimate
from tests.paths import ROOT
from uvnav_tui.hardcopy import screen_text
from uvnav_tui.pages import throttled_page
from uvnav_tui.pages.p642_position_plot import (
    LEGEND_WIDTH,
    PositionPlotPage,
    bearing_distance,
    plot_page_lines,
    track_xy,
)
from uvnav_tui.pages.p643_history import HistoryPage, history_page_lines, history_series
from uvnav_tui.pages.p710_demo_parameters import DemoPage, demo_page_lines
from uvnav_tui.pages.registry import make_page, pages
from uvnav_tui.pages.throttled_page import ThrottledTextPage, history_upto
from uvnav_tui.widgets.canvas import format_distance, nice_length

BODY = (62, 20)
"""The page body of the 80×24 console (status column 18 wide, four lines of frame)."""
SNAP = (100, 34)


@dataclass
class Run:
    """The shared session and the two moments the tests look at."""

    session: Session
    surface: CycleResult
    surface_history: list[CycleResult]
    dive: CycleResult

    @property
    def context(self) -> RunContext:
        return self.session.context

    @property
    def history(self) -> list[CycleResult]:
        return list(self.session.history)


@pytest.fixture(scope="module")
def run() -> Run:
    """DEMO.toml stepped 600 cycles (kept) and on to 3000 (≈ 3 s)."""
    s = Session.from_file(ROOT / "data" / "DEMO.toml", history=3600)
    s.run(600)
    surface = s.last
    assert surface is not None
    surface_history = list(s.history)
    s.run(2400)
    assert s.last is not None
    return Run(s, surface, surface_history, s.last)


def with_demo(ctx: RunContext, **demo: object) -> RunContext:
    """The context with ``[demo]`` values replaced (the caches are shared)."""
    cfg: RunConfig = ctx.config
    return dataclasses.replace(ctx, config=dataclasses.replace(
        cfg, demo=dataclasses.replace(cfg.demo, **demo)))


def last_lse(history: list[CycleResult]) -> CycleResult:
    return next(c for c in reversed(history) if lse_estimate(c) is not None)


def expected_poe(run: Run) -> tuple[float, float]:
    """(R, Δt s) by hand: d_rms of the last LSE + 1800 m/h · Δt."""
    fix = last_lse(run.history)
    assert fix.fix is not None
    dt = (run.dive.time - fix.time).total_seconds()
    return drms(fix.fix.cov) + 1800.0 * dt / 3600.0, dt


def map_part(lines: list[str], width: int) -> list[str]:
    """The map columns of a page (left of the legend), without the title line."""
    return [ln[:width - LEGEND_WIDTH - 1] for ln in lines[1:]]


# ------------------------------------------------------------------------------ the data
def test_demo_run_phases(run: Run) -> None:
    """The fixture is what the tests assume: LSE at cycle 600, none at 3000, 5 min dived."""
    assert run.surface.n == 600 and run.dive.n == 3000
    assert lse_estimate(run.surface) is not None
    assert lse_estimate(run.dive) is None
    assert expected_poe(run)[1] == 300.0
    assert run.surface.cm_deg == 5.0 and run.dive.cm_deg == 4.0


def test_pages_are_registered() -> None:
    """Importing the page modules registers 642, 643 and 710 with the console's registry."""
    for number, cls in {642: PositionPlotPage, 643: HistoryPage, 710: DemoPage}.items():
        assert pages()[number].factory is cls
        assert isinstance(make_page(number), cls)


def test_history_upto_drops_newer_cycles(run: Run) -> None:
    h = history_upto(run.history, run.surface)
    assert h[-1] is run.surface and len(h) == 600


def test_track_is_reprojected_across_a_cm_change(run: Run) -> None:
    """The history spans CM 5° and CM 4°; on the current grid the track has no 67-km jump."""
    hist = run.history
    assert {c.cm_deg for c in hist} == {4.0, 5.0}
    x, y = track_xy(hist, run.context, run.dive.cm_deg)
    steps = [math.hypot(x[i + 1] - x[i], y[i + 1] - y[i]) for i in range(len(hist) - 1)]
    assert max(steps) < 50.0
    assert x[-1] == run.dive.mpp.x_m and y[-1] == run.dive.mpp.y_m


# ------------------------------------------------------------------------------ Pg 642
def test_surface_plot(run: Run) -> None:
    """Surfaced: title with the cycle's time and scale, M and L markers, the used LOPs, no POE,
    and a 1000 m scale bar for the default ±2000 m."""
    lines = plot_page_lines(run.surface, run.surface_history, run.context, *BODY)
    text = "\n".join(lines)
    assert len(lines) == BODY[1] and all(len(ln) <= BODY[0] for ln in lines)
    assert lines[0].startswith("Position plot  10:09:59Z  ±2000 m  N up  CM 005°00.00'E")
    assert any("M" in ln for ln in map_part(lines, BODY[0]))
    fix = run.surface.fix
    assert fix is not None
    assert f"LOPs {sum(lop.used for lop in fix.lops)} used" in text
    assert "L LSE  RMS" in text
    assert "POE" not in text
    assert "1000 m" in lines[-1]


def test_dive_plot_shows_the_poe_beside_the_filter_ellipse(run: Run) -> None:
    """Dived: no LSE; the POE radius R = a + ε·Δt by hand (Δt = 300 s → a + 150 m), the
    filter's 95 % a and their ratio."""
    lines = plot_page_lines(run.dive, run.history, run.context, *BODY)
    text = "\n".join(lines)
    r_poe, _ = expected_poe(run)
    a95 = run.dive.mpp.ellipse.scaled(0.95)[0]  # type: ignore[union-attr]
    assert lines[0].startswith("Position plot  10:49:59Z")
    assert "L no LSE" in text
    assert f"POE R {r_poe:.2f} m" in text
    assert "ε 1800 m/h" in text and "Δt 5.0 min" in text
    assert f"a {a95:.2f} b" in text
    assert f"MPP a = {a95 / r_poe:.2f} R" in text
    assert "zoom ±" in text
    assert "LOPs" not in text


def _ring_hits(lines: list[str], width: int, radius_cells: float) -> int:
    """How many of 16 directions from the M marker have a drawn cell at ``radius_cells``
    (cell widths; rows are two cell widths high), within one cell."""
    rows = map_part(lines, width)
    r0, c0 = next((i, ln.index("M")) for i, ln in enumerate(rows) if "M" in ln)
    hits = 0
    for k in range(16):
        t = 2.0 * math.pi * k / 16.0
        c = c0 + radius_cells * math.sin(t)
        r = r0 - radius_cells * math.cos(t) / 2.0
        found = False
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                rr, cc = round(r) + dr, round(c) + dc
                if 0 <= rr < len(rows) and 0 <= cc < len(rows[rr]) and rows[rr][cc] != " ":
                    found = True
        hits += found
    return hits


def test_poe_circle_drawn_only_without_lse(run: Run) -> None:
    """At ±400 m the dived map has a ring of radius R about the MPP; the surfaced map, with the
    same scale, does not (and says nothing about a POE)."""
    width, height = SNAP
    scale = 400.0
    r_poe, _ = expected_poe(run)
    cells = (width - LEGEND_WIDTH - 1)
    radius_cells = r_poe / (2.0 * scale / cells)
    ctx = with_demo(run.context, plot_scale_m=scale)
    dive = plot_page_lines(run.dive, run.history, ctx, width, height)
    surface = plot_page_lines(run.surface, run.surface_history, ctx, width, height)
    assert _ring_hits(dive, width, radius_cells) >= 14
    assert _ring_hits(surface, width, radius_cells) <= 10
    assert "POE R" in "\n".join(dive) and "POE" not in "\n".join(surface)


@pytest.mark.parametrize(("scale", "title", "bar"), [
    (500.0, "±500 m", "200 m"),
    (2000.0, "±2000 m", "1000 m"),
    (30_000.0, "±30 km", "10 km"),
])
def test_scale_bar_label_matches_the_plot_scale(run: Run, scale: float, title: str,
                                                bar: str) -> None:
    """The title shows the half-width, the bar the largest 1/2/5 length ≤ half of it, and the
    bar's drawn length (cells before its label) matches that length at the map's scale."""
    ctx = with_demo(run.context, plot_scale_m=scale)
    lines = plot_page_lines(run.dive, run.history, ctx, *BODY)
    assert f"  {title}  N up" in lines[0]
    assert format_distance(nice_length(scale / 2.0)) == bar
    last = lines[-1]
    assert bar in last
    cells = BODY[0] - LEGEND_WIDTH - 1
    expected_cells = nice_length(scale / 2.0) / (2.0 * scale / cells)
    assert last.index(bar) == pytest.approx(1 + expected_cells + 2, abs=1.5)


def test_stations_in_view_and_off_the_map(run: Run) -> None:
    """At ±60 km the Decca Green slave (31 km SSE) is drawn with its name; the master and the
    Red and Purple slaves are listed with grid bearing and distance."""
    ctx = with_demo(run.context, plot_scale_m=60_000.0)
    lines = plot_page_lines(run.surface, run.surface_history, ctx, *SNAP)
    text = "\n".join(lines)
    assert any("GGreen 9B" in ln or "G Green 9B" in ln for ln in map_part(lines, SNAP[0]))
    assert "off the map" in text
    listed = [ln[SNAP[0] - LEGEND_WIDTH:].strip() for ln in lines]
    assert any(s.startswith("M 076°") for s in listed)
    assert any(s.startswith("R 047°") for s in listed)
    assert not any(s.startswith("G 1") for s in listed)


def test_bearing_distance() -> None:
    assert bearing_distance(1000.0, 1000.0) == "045° 1414 m"
    assert bearing_distance(0.0, -20_000.0) == "180° 20.0 km"


def test_plot_size_shrinks_the_map(run: Run) -> None:
    """plot_size 0.5: the map takes half the width and height of its area."""
    ctx = with_demo(run.context, plot_size=0.5, plot_scale_m=500.0)
    lines = plot_page_lines(run.dive, run.history, ctx, *SNAP)
    area_w = SNAP[0] - LEGEND_WIDTH - 1
    rows = map_part(lines, SNAP[0])
    drawn = [i for ln in rows for i, ch in enumerate(ln) if ch != " "]
    assert max(drawn) < round(area_w * 0.5)
    assert all(ln[:area_w].strip() == "" for ln in rows[round((SNAP[1] - 1) * 0.5):])


def test_plot_without_a_cycle() -> None:
    assert plot_page_lines(None, [], None, *BODY) == ["Position plot", "", "no cycle yet"]


# ------------------------------------------------------------------------------ Pg 643
def test_history_series(run: Run) -> None:
    """POE only at cycles without an LSE, growing linearly from the last LSE's d_rms; LSE − MPP
    only with an LSE, a few tens of metres at most."""
    hist = run.history
    s = history_series(hist, run.dive, run.session.config)
    assert len(s.t_min) == 3000 and s.t_min[-1] == 0.0 and s.t_min[0] == pytest.approx(-49.983,
                                                                                      abs=1e-3)
    lse = [lse_estimate(c) is not None for c in hist]
    assert all(math.isnan(p) == has for p, has in zip(s.poe_m, lse, strict=True))
    assert all(math.isnan(n) != has for n, has in zip(s.north_m, lse, strict=True))
    first = lse.index(False)
    a = drms(hist[first - 1].fix.cov)  # type: ignore[union-attr]
    assert s.poe_m[first] == pytest.approx(a + 0.5)  # 1 s at 1800 m/h = 0.5 m/s
    assert s.poe_m[-1] == pytest.approx(expected_poe(run)[0])
    dive = s.poe_m[first:]
    assert all(b > c for b, c in zip(dive[1:], dive, strict=False))
    offsets = [math.hypot(n, e) for n, e in zip(s.north_m, s.east_m, strict=True)
               if math.isfinite(n)]
    assert max(offsets) < 150.0
    assert all(math.isfinite(v) for v in s.mpp_a_m)


def test_history_cache_gives_the_same_series(run: Run) -> None:
    cache: dict = {}
    a = history_series(run.history, run.dive, run.session.config, cache)
    b = history_series(run.history, run.dive, run.session.config, cache)
    plain = history_series(run.history, run.dive, run.session.config)
    assert len(cache) == 3000
    assert a.t_min == b.t_min == plain.t_min
    assert a.mpp_a_m == b.mpp_a_m == plain.mpp_a_m
    assert [x for x in a.poe_m if x == x] == [x for x in plain.poe_m if x == x]


def test_history_page_surface(run: Run) -> None:
    """Surfaced, 10 minutes: offsets now, no POE yet, time axis to 0."""
    lines = history_page_lines(run.surface, run.surface_history, run.session.config, *BODY)
    text = "\n".join(lines)
    assert len(lines) == BODY[1] and all(len(ln) <= BODY[0] for ln in lines)
    assert lines[0].startswith("History  10:09:59Z  last 10.0 min")
    assert "LSE − MPP grid north (m)   now " in text and "now ---" not in text
    assert "POE R ⠉ (no-LSE cycles, ε 1800 m/h)" in text
    assert lines[-1].split()[-1] == "0" and "-8" in lines[-1].split()
    assert lines[-2].lstrip().startswith("└")


def test_history_page_dive(run: Run) -> None:
    """Dived: no offsets now; the POE radius beside the MPP's 95 % a; axes in m and minutes."""
    lines = history_page_lines(run.dive, run.history, run.session.config, *BODY)
    text = "\n".join(lines)
    a95 = run.dive.mpp.ellipse.scaled(0.95)[0]  # type: ignore[union-attr]
    assert lines[0].startswith("History  10:49:59Z  last 50.0 min")
    assert text.count("now ---") == 2
    assert f"MPP 95 % a (m) ⠤ {a95:.2f}   POE R ⠉ {expected_poe(run)[0]:.2f}" in text
    assert lines[-1].split() == ["-40", "-30", "-20", "-10", "0"]
    assert any(ln.startswith("    200┤") for ln in lines)


def test_history_page_without_a_cycle() -> None:
    assert history_page_lines(None, [], None, *BODY)[2] == "no cycle yet"


# ------------------------------------------------------------------------------ Pg 710
def test_demo_page_navigator_and_developer(run: Run) -> None:
    """The navigator sees the [demo] values; developer mode adds corrections, LS and filter
    parameters, compacted when the page is short."""
    cfg = run.session.config
    nav = demo_page_lines(cfg, False, 100)
    text = "\n".join(nav)
    assert "  Plot scale     2000 m" in text
    assert "  POE rate ε     1800 m/h" in text
    assert "  Press. ref.    39939.662 Hz" in text
    assert "Decca.CF" not in text
    dev = "\n".join(demo_page_lines(cfg, True, 100))
    for label, value in (("ScaleVCV", "off"), ("LOPReject", "A"), ("ConfRegion", "95 %"),
                         ("Decca.CF", "64"), ("GPS.SE_SF", "0.49"), ("Q scale", "1"),
                         ("Decca Red", "0 lanes"), ("epsilon", "1 m"), ("ReliabInterval", "5 %")):
        assert f"  {label:<15}{value}" in dev
    short = demo_page_lines(cfg, True, 62, 20)
    assert len(short) <= 20 and "Developer: corrections, LS and filter" in short
    assert any("Decca.CF       64" in ln for ln in short)
    changed = dataclasses.replace(cfg, demo=dataclasses.replace(cfg.demo, plot_scale_m=500.0))
    assert "  Plot scale     500 m" in "\n".join(demo_page_lines(changed, False, 100))


# ------------------------------------------------------------------------------ widgets
class PageApp(App[None]):
    """A bare app showing one page body."""

    def __init__(self, page: ThrottledTextPage, r: CycleResult | None,
                 session: Session | None) -> None:
        super().__init__()
        self.page = page
        self.r = r
        self.session_ = session

    def compose(self) -> ComposeResult:
        yield self.page

    def on_mount(self) -> None:
        self.page.show(self.r, self.session_, force=True)


class FakeClock:
    """``time.monotonic`` of the page module, set by the test (the throttle must not depend on
    how fast a loaded machine runs the test)."""

    def __init__(self) -> None:
        self.now = 1000.0

    def monotonic(self) -> float:
        """The time set by the test (s)."""
        return self.now


def test_redraw_is_throttled(run: Run, monkeypatch: pytest.MonkeyPatch) -> None:
    """A second cycle within 0.25 s is not drawn at once but by the trailing redraw; the drawn
    time is the cycle's record time; ``force`` redraws at once.  The page's clock is a fake
    one: "0.1 s after the last redraw" is certain, not hoped for."""
    clock = FakeClock()
    monkeypatch.setattr(throttled_page, "time", clock)

    async def main() -> None:
        page = PositionPlotPage()
        app = PageApp(page, run.surface, run.session)
        async with app.run_test(size=SNAP) as pilot:
            await pilot.pause()
            assert "10:09:59Z" in screen_text(app)
            n = page.redraws
            clock.now += 0.1
            page.show(run.dive, run.session)
            await pilot.pause()
            assert page.redraws == n and "10:09:59Z" in screen_text(app)
            await wait_for(pilot, lambda: page.redraws == n + 1, "the trailing redraw")
            await pilot.pause()
            assert "10:49:59Z" in screen_text(app)
            page.show(run.surface, run.session, force=True)
            await pilot.pause()
            assert page.redraws == n + 2 and "10:09:59Z" in screen_text(app)
            page.show(None, None, force=True)
            await pilot.pause()
            assert "no cycle yet" in screen_text(app)

    asyncio.run(main())


def test_demo_page_follows_dev_mode(run: Run) -> None:
    """Pg 710 reads the console's dev_mode (absent in a bare app: navigator rows only)."""

    async def main() -> None:
        page = DemoPage()
        app = PageApp(page, run.dive, run.session)
        async with app.run_test(size=(100, 30)) as pilot:
            await pilot.pause()
            assert "Plot scale" in screen_text(app) and "Decca.CF" not in screen_text(app)
            app.dev_mode = True  # type: ignore[attr-defined]
            page.show(run.dive, run.session, force=True)
            await pilot.pause()
            assert "Decca.CF" in screen_text(app)

    asyncio.run(main())


def test_snapshot_pg642_dived(snap_compare: Callable[..., bool], run: Run) -> None:
    """Pg 642 five minutes into the dive at ±2000 m."""
    assert snap_compare(PageApp(PositionPlotPage(), run.dive, run.session), terminal_size=SNAP)


def test_snapshot_pg643_dived(snap_compare: Callable[..., bool], run: Run) -> None:
    """Pg 643 over the 50 minutes up to five minutes into the dive."""
    assert snap_compare(PageApp(HistoryPage(), run.dive, run.session), terminal_size=SNAP)


@pytest.mark.parametrize("page_cls", [PositionPlotPage, HistoryPage, DemoPage],
                         ids=["642", "643", "710"])
def test_snapshot_after_600_cycles(snap_compare: Callable[..., bool], run: Run,
                                   page_cls: type[ThrottledTextPage]) -> None:
    """642, 643 and 710 after the first 600 cycles of the demo (surfaced, GPS + Decca)."""
    assert snap_compare(PageApp(page_cls(), run.surface, run.session), terminal_size=SNAP)

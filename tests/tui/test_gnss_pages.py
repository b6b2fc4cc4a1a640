"""The receiver weights and the COG/SOG stand-in on the pages (issue 13, docs/GNSS_WEIGHTS.md):
Pg 611 (fix quality, HDOP, satellites, σ and its origin), Pg 620 (COG*/SOG* rows with their σ
and the note) and Pg 100 (sensor strip and GPS box). The cycles come from a synthetic stream of
records with the NMEA fields (built directly; the NMEA reader is another module's), through the
engine's own cycle on a session's context. A 1993 run's pages are the snapshots of
tests/tui/test_pages_snapshots.py, unchanged."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import replace
from datetime import UTC, datetime, timedelta

import pytest

from engine.api import CycleResult, Session
from engine.io.runfile import RunRecord
from engine.run.config import parse_config_text
from engine.run.cycle import initial_state, step
from tests.paths import DATA
from tests.tui.test_pages_snapshots import SIZE, PageApp
from uvnav_tui.pages import p611_gps_statistics, p620_sensor_statistics
from uvnav_tui.pages.main_page import gps_box_lines, sensor_strip

CONFIG = """
datum = "WGS84"
dr_position = "52 50 00 N 004 30 00 E"
run_gps_datum = "WGS84"
[gps]
on = true
[sensors]
cog_sog = "standin"
"""
T0 = datetime(2026, 7, 1, 10, 0, 0, tzinfo=UTC)


@pytest.fixture(scope="module")
def yacht() -> Iterator[tuple[Session, CycleResult]]:
    """Cycle 30 of a yacht's log: DGPS fixes at HDOP 1.2 with 9 satellites, COG 030° and SOG
    6.0 kn, no gyro and no log (the stand-in on)."""
    cfg = replace(parse_config_text(CONFIG, base_dir=DATA), run_file=str(DATA / "920917_1.RUN"))
    session = Session(cfg)
    ctx = session.context
    grid = ctx.grid(5.0)
    x0, y0 = grid.forward(52 + 50 / 60, 4.5)
    v = 6.0 * 1852.0 / 3600.0
    nav = initial_state(cfg)
    r = None
    for k in range(30):
        lat, lon = grid.inverse(x0 + v * k * math.sin(math.radians(30.0)),
                                y0 + v * k * math.cos(math.radians(30.0)))
        rec = RunRecord(k + 1, T0 + timedelta(seconds=k), lat, lon, (None, None, None), None,
                        None, None, gps_hdop=1.2, gps_quality=2, gps_sats=9, cog_deg=30.0,
                        sog_kn=6.0)
        nav, r = step(ctx, nav, rec)
    assert r is not None
    yield session, r
    session.close()


def test_611_shows_the_receiver_figures_and_the_sigma(yacht: tuple[Session, CycleResult]) -> None:
    """σ = 1.2 × 1.5 / √2 = 1.2728 m (hand: 1.8/1.41421 = 1.27279)."""
    session, r = yacht
    text = p611_gps_statistics.render(r, session)
    assert "fix : DGPS   HDOP 1.2   satellites 9" in text
    assert "weight per axis : σ 1.27 m = HDOP 1.2 × UERE 1.5 m (DGPS) / √2   [receiver]" in text
    assert "1.620" in text  # the a priori VCV diagonal, 1.2728² = 1.620 m²


def test_620_marks_the_standin(yacht: tuple[Session, CycleResult]) -> None:
    session, r = yacht
    text = p620_sensor_statistics.render(r, session)
    cog = next(ln for ln in text.splitlines() if ln.startswith("COG*"))
    sog = next(ln for ln in text.splitlines() if ln.startswith("SOG*"))
    assert "30.0°" in cog and "3.00°" in cog  # the COG σ floor at 6 kn
    # SOG σ = max(0.1, 0.03 × 3.0867 m/s) = 0.1 m/s.
    assert "3.087 m/s" in sog and "0.100 m/s" in sog
    assert "* COG/SOG stand in for the missing gyro/log" in text
    assert not any(ln.startswith(("Gyro", "Log ")) for ln in text.splitlines())


def test_main_page_strip_and_gps_box(yacht: tuple[Session, CycleResult]) -> None:
    session, r = yacht
    strip = sensor_strip(r, session.config)
    assert strip.startswith("GYRO COG 30.0°  LOG SOG 6.0kts  RUDR OFF")
    assert gps_box_lines(r, session.config)[2].endswith("DGPS HDOP 1.2")


@pytest.mark.parametrize("number", [611, 620])
def test_page_yacht_snapshot(snap_compare: Callable[..., bool],
                             yacht: tuple[Session, CycleResult], number: int) -> None:
    """New snapshots (issue 13): Pg 611 with the receiver weight, Pg 620 with the stand-in."""
    session, r = yacht
    assert snap_compare(PageApp(number, r, session), terminal_size=SIZE)


def test_611_names_the_sps_weight_of_a_fix_without_hdop() -> None:
    """A fix without an HDOP dated after SA was switched off: Pg 611 says where its σ comes
    from (the SPS Performance Standard 2008's worst site), not the 1993 C/A figure."""
    from engine.systems.gps import GPS_SIGMA_CA_SPS_M, GpsWeight

    w = GpsWeight("sps", GPS_SIGMA_CA_SPS_M)
    lines = p611_gps_statistics.weight_lines(w)
    assert len(lines) == 2 and "σ 6.95 m = SPS PS 2008 worst site 17 m 95 %" in lines[1]
    assert "[no HDOP, SA off]" in lines[1]
    assert "SPS PS 2008" in p611_gps_statistics.input_line(w, "WGS84", "C/A")

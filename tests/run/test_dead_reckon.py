"""Session.dead_reckon: the MPP carried on the wall clock while a live source is lost (the
filter's prediction without a measurement; docs/CONSOLE.md, "Live source lost")."""

from __future__ import annotations

import math

import pytest

from engine.filter.state import IEPS, IPSI, IV, IVCX, IVCY, IX, IY
from engine.run.config import load_config
from engine.run.session import Session
from tests.paths import DATA

SAMPLE = DATA / "920917_1.toml"


def test_dead_reckon_carries_heading_speed_and_grows_the_ellipse() -> None:
    s = Session(load_config(SAMPLE))
    results = []
    while (r := s.step()) is not None:
        results.append(r)
    last = results[-1] if results else None
    assert last is not None and last.mpp.source == "KF"
    fs = s.nav.filter
    assert fs is not None
    x = fs.x
    dr60 = s.dead_reckon(60.0)
    dr600 = s.dead_reckon(600.0)
    assert dr60 is not None and dr600 is not None
    assert dr60.source == "DR"
    # The motion model (thesis eq. 6.30) for 60 s: v cos ε (sin ψ, cos ψ) t + current t, from
    # the filter's last state (exact for constant v, ψ, ε, current: steps add up).
    vc = x[IV] * math.cos(x[IEPS])
    east = x[IX] + (vc * math.sin(x[IPSI]) + x[IVCX]) * 60.0
    north = x[IY] + (vc * math.cos(x[IPSI]) + x[IVCY]) * 60.0
    assert (dr60.x_m, dr60.y_m) == pytest.approx((east, north), abs=1e-6)
    # The sample ship logs 12.7 kn (test_cycle): 60 s ≈ 392 m, on the course over ground of
    # its filtered track (cycles 2 … 10, on the same grid).
    d = math.hypot(dr60.x_m - x[IX], dr60.y_m - x[IY])
    assert d == pytest.approx(60 * 12.7 * 1852 / 3600, abs=40.0)
    az = math.degrees(math.atan2(dr60.x_m - x[IX], dr60.y_m - x[IY])) % 360
    first = results[1].mpp
    cog = math.degrees(math.atan2(last.mpp.x_m - first.x_m, last.mpp.y_m - first.y_m)) % 360
    assert az == pytest.approx(cog, abs=10.0)
    # The ellipse grows with the time dead-reckoned; the session is unchanged.
    a_kf = last.mpp.ellipse.scaled(0.95)[0]
    a60 = dr60.ellipse.scaled(0.95)[0]
    a600 = dr600.ellipse.scaled(0.95)[0]
    assert a_kf < a60 < a600
    assert s.nav.filter is fs
    assert s.dead_reckon(0.0) is None
    s.close()

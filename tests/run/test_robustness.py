"""A run never crashes on a record that passes the .RUN grammar (issue 7: "a record with a bad
field is skipped with its reason recorded; the run goes on"; brief: "a run never crashes on a
bad record").

Hypothesis writes runs of valid records — any mix of present and missing sensors, positions
anywhere on the globe or near the chain, Decca fractions, gyro, log, inclinometer, crystal
frequencies from 1 Hz to 1 MHz, gaps from 1 s to 1 h — and each run must end with every record
either a cycle or a reported bad record, every position finite or absent, and no exception.
"""

from __future__ import annotations

import math
from datetime import UTC, datetime, timedelta
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from engine.io.runfile import RunRecord, format_run_record
from engine.run.config import RunConfig, load_config
from engine.run.session import Session
from tests.paths import DATA

CONFIGS = {name: load_config(DATA / name) for name in ("920917_1.toml", "DEMO.toml")}


@st.composite
def runs(draw: st.DrawFn) -> list[str]:
    """The lines of a short run of valid records."""
    n = draw(st.integers(1, 12))
    t = datetime(1992, 9, 17, 8, 35, 38, tzinfo=UTC)
    wide = draw(st.booleans())
    lines = []
    for i in range(n):
        t += timedelta(seconds=draw(st.sampled_from([1, 1, 1, 2, 60, 3600])))
        if wide:
            lat = draw(st.none() | st.floats(-90, 90))
            lon = draw(st.none() | st.floats(-180, 180))
        else:
            lat = draw(st.none() | st.floats(52.0, 53.5))
            lon = draw(st.none() | st.floats(3.5, 6.0))
        if (lat is None) != (lon is None):
            lat = lon = None
        frac = st.none() | st.floats(0, 1, exclude_max=True)
        lines.append(format_run_record(RunRecord(
            i + 1, t, lat, lon, (draw(frac), draw(frac), draw(frac)),
            draw(st.none() | st.floats(0, 360, exclude_max=True)),
            draw(st.none() | st.floats(0, 60)), draw(st.none() | st.floats(-90, 90)),
            draw(st.none() | st.floats(-90, 90)), draw(st.none() | st.floats(1, 1e6)),
            draw(st.none() | st.floats(0, 11000)))))
    return lines


def replay(cfg: RunConfig, lines: list[str], tmp: Path) -> None:
    run = tmp / "P.RUN"
    run.write_text("\n".join(lines) + "\n")
    s = Session(cfg.replace(run_file=str(run)))
    cycles = []
    while (r := s.step()) is not None:
        cycles.append(r)
        for est in (r.mpp, r.kf, r.kf_pred):
            if est is not None and est.source != "DR":
                assert math.isfinite(est.x_m) and math.isfinite(est.y_m), (r.n, est)
                assert -90.0 <= est.lat_deg <= 90.0
        if r.filter_state is not None:
            assert np.all(np.isfinite(r.filter_state.x)), r.n
    assert len(cycles) + s.skipped_records == len(lines)


@pytest.mark.parametrize("name", list(CONFIGS))
@settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck))
@given(lines=runs())
def test_valid_records_never_crash_the_run(tmp_path_factory: pytest.TempPathFactory, name: str,
                                           lines: list[str]) -> None:
    replay(CONFIGS[name], lines, tmp_path_factory.mktemp("run"))


@pytest.mark.parametrize(("name", "lines"), [
    # A Decca-only blunder moved the speed state to 75 m/s, a GPS fix at 0°N 0°E 5800 km
    # from the DR position was taken in whole, and an hour of dead reckoning overflowed the grid.
    ("920917_1.toml", ["920917 083539 - - - - - .0 .0 -", "920917 083544 - - - .000 - - - -",
                       "920917 083644 00 00 00.000 N 000 00 00.000 E - - - - - -",
                       "920917 093644 - - - - - - - -"]),
    # A crystal frequency giving −268 km of depth.
    ("DEMO.toml", ["920917 083539 - - - - - 19.0 50.0 - - 499980.000",
                   "920917 083540 - - - - - - - - - 1.000", "920917 083643 - - - - - - - -",
                   "920917 083644 - - - - - - - - .00"]),
])
def test_records_found_by_the_property_test(tmp_path: Path, name: str, lines: list[str]) -> None:
    replay(CONFIGS[name], lines, tmp_path)


def test_a_gps_position_far_from_the_grid_is_not_taken(tmp_path: Path) -> None:
    """A GPS position 87° of longitude from the DR's central meridian (found by the property
    test above: the TM series diverged and the LSE came out at x = −6.7·10⁸ m, latitude NaN) is
    left out of the fix with a message; one 1.5° away is taken (GRID_MAX_DLON_DEG = 6°)."""
    cfg = CONFIGS["920917_1.toml"]
    far = ["920917 083539 - - - - - - - -",
           "920917 083540 00 00 00.000 N 082 00 00.000 W - - - - - -"]
    run = tmp_path / "FAR.RUN"
    run.write_text("\n".join(far) + "\n")
    s = Session(cfg.replace(run_file=str(run)))
    s.step()
    r = s.step()
    assert r is not None and (r.fix is None or not r.fix.ok)
    assert any("from the grid's central meridian: not taken" in m for m in r.messages)
    replay(cfg, far, tmp_path)  # and every estimate stays finite
    near = ["920917 083540 52 50 00.000 N 006 00 00.000 E - - - - - -"]
    run.write_text("\n".join(near) + "\n")
    r = Session(cfg.replace(run_file=str(run))).step()
    assert r is not None and r.fix is not None and r.fix.ok
    assert not any("central meridian" in m for m in r.messages)

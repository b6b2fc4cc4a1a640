"""The Statistics (6xx) and Data (8xx) pages as text: the thesis worked example (A8.5, THEORY §14.2)
where the engine reproduces it, engine-consistency of every printed number, and robustness.

Three cycle results are rendered:

* ``sample``: cycle 2 (08:35:39Z) of data/920917_1.toml as the engine runs it (the .RUN GPS
  record, read as ED50; filter on);
* ``thesis``: the screen's inputs (THEORY §14.2 "Inputs actually used"): a Session on the sample
  configuration with the screen's WGS84 GPS fix in the .RUN records and the filter off (the
  screens show "Filter : N/A", MPP = LSE), whose cycle-2 fix is replaced by the direct
  ``compute_fix`` of the worked example from the DR start (as in test_fix_worked_example.py),
  with the Decca VCV of the engine's A4 model;
* ``printed``: the same with the Decca VCV the screens print (THEORY D10: "exact LSE regression
  tests use the printed C_Decca"), which makes C_x̂, the ellipse and W exact.

Values the engine does not reproduce exactly are listed in :data:`NOT_EXACT` with the reason, and
checked there against the documented tolerance instead.
"""

from __future__ import annotations

import dataclasses
import importlib
import math
import re
from collections.abc import Iterator
from types import ModuleType

import numpy as np
import pytest

import engine.systems.decca as engine_decca
from engine.api import (
    STATE_LABELS,
    CycleResult,
    FixResult,
    Session,
    format_stat,
    load_config,
    lse_estimate,
)
from engine.lsq.fix import DeccaReading, GpsFix, LsqSettings, compute_fix
from tests.paths import DATA
from uvnav_tui.pages.page_text import TextPage, compact, corr_text, num
from uvnav_tui.pages.registry import make_page, page_titles, pages

TEXT_PAGES = (611, 615, 620, 631, 633, 641, 650, 810, 821, 830, 840, 850, 851, 852, 853)
"""The text pages (642/643 are plots, tested elsewhere)."""


def mod(number: int) -> ModuleType:
    """The module of page ``number`` (imported here, not at collection: see ``registry``)."""
    factory = pages()[number].factory
    assert factory is not None
    return importlib.import_module(factory.__module__)


PRINTED_DECCA_VCV = np.array([[916.877, 18.050, 0.0], [18.050, 83.585, 0.0], [0.0, 0.0, 1.0]])
"""C_Decca as printed on Pg 615/821 (the Purple entries are irrelevant: Purple is deselected)."""

# The two records of the sample run with the screen's GPS fix (THEORY §14.2: WGS84 52°50'30.000"N
# 004°31'46.200"E); time, Decca fractions, gyro, log and rudder as in 920917_1.RUN.
SCREEN_RUN = (
    "920917 083538 52 50 30.000 N 004 31 46.200 E .862 .325 .109 232.4 12.7 -.2\n"
    "920917 083539 52 50 30.000 N 004 31 46.200 E .862 .337 .111 232.3 12.7 -.2\n"
)


# --------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def sample() -> Iterator[tuple[Session, CycleResult]]:
    """Cycle 2 of the sample run as the engine runs it."""
    session = Session(load_config(DATA / "920917_1.toml"))
    session.step()
    r = session.step()
    assert r is not None and r.n == 2
    yield session, r
    session.close()


@pytest.fixture(scope="module")
def screen(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Session, CycleResult]]:
    """Cycle 2 of the sample configuration on the screen's GPS input, filter off."""
    run = tmp_path_factory.mktemp("screen") / "SCREEN.RUN"
    run.write_text(SCREEN_RUN, encoding="utf-8")
    cfg = load_config(DATA / "920917_1.toml")
    cfg = cfg.replace(run_gps_datum="WGS84", run_file=str(run),
                      filter=dataclasses.replace(cfg.filter, on=False))
    session = Session(cfg)
    session.step()
    r = session.step()
    assert r is not None and r.n == 2
    yield session, r
    session.close()


def worked_fix(session: Session, r: CycleResult) -> FixResult:
    """The worked example's LSE from the DR start (THEORY §14.2, test_fix_worked_example.py)."""
    ctx = session.context
    grid = ctx.grid(5.0)
    g = r.gps
    assert g is not None
    gps = GpsFix(g.lat_deg, g.lon_deg, g.x_m, g.y_m, 2500.0)
    placed = ctx.placed_chain(5.0)
    assert placed is not None
    decca = DeccaReading(placed, (0.862, 0.337, 0.111), ((1, 20), (5, 34), (0, 51)),
                         (True, True, False), (-0.05, -0.05, -0.05), 64.0)
    dr = grid.forward(52 + 50 / 60, 4.5)
    return compute_fix(grid, ctx.geodesic, dr, gps=gps, decca=decca,
                       settings=LsqSettings(lop_reject="Y"))


def with_fix(r: CycleResult, fix: FixResult) -> CycleResult:
    """``r`` with ``fix`` as its LSE and MPP (the filter is off: MPP = LSE)."""
    mpp = lse_estimate(dataclasses.replace(r, fix=fix))
    assert mpp is not None
    return dataclasses.replace(r, fix=fix, mpp=mpp)


@pytest.fixture(scope="module")
def thesis(screen: tuple[Session, CycleResult]) -> tuple[Session, CycleResult]:
    """The worked example with the engine's Decca VCV (A4 model)."""
    session, r = screen
    return session, with_fix(r, worked_fix(session, r))


@pytest.fixture(scope="module")
def printed(screen: tuple[Session, CycleResult]) -> Iterator[tuple[Session, CycleResult]]:
    """The worked example with the printed Decca VCV of Pg 615/821."""
    session, r = screen
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(engine_decca, "decca_vcv_m2", lambda geom, cf: PRINTED_DECCA_VCV.copy())
        fix = worked_fix(session, r)
    yield session, with_fix(r, fix)


def text_of(number: int, case: tuple[Session, CycleResult]) -> str:
    session, r = case
    return mod(number).render(r, session)


# --------------------------------------------------------------------------- the thesis screens
REPRODUCED: list[tuple[int, str, tuple[str, ...]]] = [
    (611, "thesis", ("GPS statistical data :", "WGS84", "52°50'30.000\" N",
                          "004°31'46.200\" E", "39.5", "ED50", "52°50'32.777\" N",
                          "004°31'51.052\" E", "0.00", "x : -31613.554 / ",
                          "y : 5857312.625 / ", "a priori VCV matrix :", "2500.000")),
    (615, "thesis", ("Decca statistical data :", "Chain : 9B", "44.86", "274.34", "1.11",
                          "-0.05", "44.81", "274.29", "1.01", "3.98609", "1.58335", "61.3",
                          "295.0", "257.6", "a priori VCV matrix (SD) :")),
    (615, "printed", ("916.877", "18.050", "83.585", "1.000")),
    (631, "thesis", ("52°50.55'N", "004°31.85'E", "52°50.54'N", "-12.5", "90.0", "180.0",
                          "61.3", "295.0", "257.6", "1.6", "-0.3", "44.86", "274.34", "1.11",
                          "-0.05", "44.81", "274.29", "1.01",
                          "Datum : ED50  Proj.: TM  CM : 005°00'00.000\" E",
                          "004°31'50.958\" E", "Az/elev. : 112.0° 0.0°")),
    (631, "printed", ("a/b/c : 74.87m 21.37m 0.00m",)),
    (633, "thesis", ("52.09", "0.26", "1.04", "4.84", "999.99", "-0.09", "0.17", "1.22",
                          "1.68", "44.25", "S² : 0.034", "(4)")),
    (633, "printed", ("60.90", "50.89")),
    (641, "thesis", ("Datum : ED50   Projection : TM   CM : 005°00'00.000\" E",
                          "004°31'50.958\" E", "-31615.40", "Azimuth : 112.0",
                          "Elevation : 0.0", "21.37")),
    (641, "printed", ("814.936", "-298.408", "Standard : 30.59  8.73  0.00",
                           "95.0% : 74.87  21.37  0.00")),
    (810, "thesis", ("Datum : ED50", "Chain : 9B", "44.862", "274.337", "1.111",
                          "-31615.40", "140333.462", "5899445.769", "1.32392", "227344.07",
                          "0.81675", "3.98609", "1.07034", "30962.69", "173435.71", "2.69107",
                          "1.58335", "5.14909", "321036.13", "144712.47", "1.38371",
                          "4.49540")),
    (821, "thesis", ("-0.47409  0.88046", "-0.42885", "-0.90336", "0.00000  1.00000",
                          "1.00000  0.00000", "2500.000")),
    (821, "printed", ("916.877", "18.050", "83.585", "1.000")),
    (830, "thesis", ("0.00040", "-0.00024")),
    (830, "printed", ("0.00110", "-0.00024", "0.00040")),
    (840, "printed", ("935.48", "0.92721", "0.37455", "76.21", "-0.37455", "112.00",
                           "-22.00", "30.59", "8.73", "74.87", "21.37", "113.68", "32.45")),
    (840, "thesis", ("112.0", "0.92721", "21.37", "8.73")),
]


@pytest.mark.parametrize(("number", "case", "strings"), REPRODUCED,
                         ids=[f"{n}-{c}-{i}" for i, (n, c, _s) in enumerate(REPRODUCED)])
def test_thesis_strings(number: int, case: str, strings: tuple[str, ...],
                        request: pytest.FixtureRequest) -> None:
    text = text_of(number, request.getfixturevalue(case))
    missing = [s for s in strings if s not in text]
    assert not missing, f"missing {missing} in\n{text}"


NOT_EXACT: list[tuple[int, str, str, str, float, str]] = [
    # (page, case, thesis string, engine string, tolerance on the printed values, reason)
    (615, "thesis", "916.877", "917.982", 0.005 * 916.877,
     "Decca VCV from the A4 model is 0.1–0.4 % off the screen (THEORY D10)"),
    (615, "thesis", "83.585", "83.632", 0.005 * 83.585, "Decca VCV, THEORY D10"),
    (615, "thesis", "33.45517", "33.45515", 5e-5,
     "Purple LEF at our LSE, 3 mm from the screen's (THEORY §14.3)"),
    (611, "thesis", "-31615.400", "-31615.404", 0.005,
     "calc = our LSE, 3–4 mm from the screen's (THEORY §14.3: grid 5 mm)"),
    (611, "thesis", "5857300.165", "5857300.166", 0.005, "LSE grid, THEORY §14.3"),
    (631, "thesis", "-1.8", "-1.9", 0.1,
     "v Lon −1.850 against the screen's −1.846: b of a linearisation 2 mm away (THEORY §14.2)"),
    (631, "thesis", "52°50'32.373\" N", "52°50'32.374\" N", 0.0,
     "LSE latitude to 0.001\" (THEORY §14.3 recomputes .374\")"),
    (631, "thesis", "74.87m", "74.90m", 0.001 * 74.87,
     "a95 with the A4 Decca VCV (0.1 % of C_x̂, THEORY D10); exact with the printed VCV"),
    (633, "thesis", "0.04", "0.05", 0.01,
     "w Lon = 0.0451 sits on the rounding point (screen 0.04 from b 2 mm away)"),
    (633, "thesis", "0.021 (4)", "0.029 (4)", math.inf,
     "cumulative σ² needs the thesis' cycle-1 GPS input, which is not listed; with the same GPS "
     "as cycle 2 it is 0.029, as THEORY D19 predicts"),
    (641, "thesis", "5857300.16", "5857300.17", 0.01,
     "LSE northing 5857300.165/.166 rounds up; the screen shows .16 (Pg 611 shows .165)"),
    (641, "printed", "196.755", "196.756", 0.002,
     "σy² from the printed C_l rounded to 3 dp (THEORY §14.3 recomputes 196.756)"),
    (641, "thesis", "-33709.65", "-31611.68", math.inf,
     "KF = the filter's prediction; the engine restarts the DR from each LSE (filter off) or "
     "updates from the first cycle (THEORY D21–D22), not pure DR from the start position"),
    (641, "thesis", "814.936", "815.581", 0.002 * 814.936, "C_x̂ with the A4 Decca VCV"),
    (810, "thesis", "177026.82", "177026.83", 0.011,
     "D_m at our LSE, 3 mm from the screen's (THEORY §14.3: D to 0.01 m)"),
    (810, "thesis", "365220.90", "365220.91", 0.011, "D_Red at our LSE, as above"),
    (821, "thesis", "12.45880", "12.41331", 0.06,
     "b = O − C at the last linearisation point, 0.06 m from x̂ here, 2 mm on the screen"),
    (830, "thesis", "0.00110", "0.00109", 1.5e-5, "W of the A4 Decca VCV (THEORY D10)"),
    (830, "printed", "0.01202", "0.01201", 1e-5,
     "W_GG = 0.0120149 sits 5e-8 below the rounding point (test_adjustment.py)"),
    (840, "thesis", "935.48", "936.21", 0.002 * 935.48, "λ1 with the A4 Decca VCV"),
    (840, "printed", "(empty", "KF :", math.inf,
     "the KF block is filled: the engine predicts from the first cycle on (A6)"),
]


@pytest.mark.parametrize(("number", "case", "thesis_s", "engine_s", "tol", "reason"), NOT_EXACT,
                         ids=[f"{n}-{t}" for n, _c, t, _e, _t, _r in NOT_EXACT])
def test_not_exact(number: int, case: str, thesis_s: str, engine_s: str, tol: float,
                   reason: str, request: pytest.FixtureRequest) -> None:
    """The engine's value is on the page, the thesis' is not, and they agree within ``tol``."""
    assert reason
    text = text_of(number, request.getfixturevalue(case))
    assert engine_s in text, f"{engine_s!r} not in\n{text}"
    assert thesis_s not in text
    a, b = _number(thesis_s), _number(engine_s)
    if math.isfinite(tol) and a is not None and b is not None:
        assert abs(a - b) <= tol + 1e-9


def _number(s: str) -> float | None:
    m = re.search(r"-?\d+\.\d+", s)
    return float(m.group()) if m and "°" not in s else None


# --------------------------------------------------------------------------- engine consistency
def test_633_rows_come_from_the_fix(sample: tuple[Session, CycleResult]) -> None:
    session, r = sample
    text = mod(633).render(r, session)
    assert r.fix is not None
    for lop in r.fix.lops:
        line = next(ln for ln in text.splitlines() if ln.startswith(
            f"{lop.system[:5]:<6}{lop.pattern}"))
        if lop.used:
            for value in (lop.sigma_d, lop.w, lop.tau, lop.vf):
                assert format_stat(value, 0, 2) in line
            assert "*" in line and lop.verdict in line
        else:
            assert line.split()[2:] == ["0.0", "999.99", "999.99", "999.99", "999.99"]
    assert f"σ² : {r.cumulative.sigma2:.3f} ({r.cumulative.R})" in text
    assert "0.95!" in text  # Green VF = 0.948 > 0.9: marked unreliable


def test_650_state_tests_and_mpp(sample: tuple[Session, CycleResult]) -> None:
    session, r = sample
    text = mod(650).render(r, session)
    fs, u = r.filter_state, r.filter_update
    assert fs is not None and u is not None and r.kf is not None
    lines = text.splitlines()
    rows = [ln.split()[0] for ln in lines if ln.split() and ln.split()[0] in STATE_LABELS]
    assert rows == list(STATE_LABELS)
    psi = next(ln for ln in lines if ln.startswith("psi"))
    assert f"{math.degrees(fs.x[4]) % 360.0:.3f}°" in psi
    assert f"{math.degrees(math.sqrt(fs.P[4, 4])):.3f}°" in psi
    v = next(ln for ln in lines if ln.startswith("v "))
    assert f"{fs.x[3]:.3f} m/s" in v and f"{fs.x[3] / (1852 / 3600):.2f} kn" in v
    assert f"T = {u.lom.t:.3f}" in text and f"{u.lom.upper:.3f}" in text
    assert u.lom.verdict in text
    for label, t in zip(u.labels, u.ls.t, strict=True):
        assert re.search(rf"{label}\s+t =\s+{t:.2f}", text)
    a, b = r.kf.ellipse.scaled(0.95)  # type: ignore[union-attr]
    assert f"a {a:.2f} m  b {b:.2f} m" in text and "95.0% ellipsoid" in text
    su = r.sensor_update  # the gyro/log update of this record (README "Sensor timing")
    assert su is not None
    tail = text.split("Sensor update", 1)[1]
    assert f"T = {su.lom.t:.3f}" in tail
    for label, t in zip(su.labels, su.ls.t, strict=True):
        assert re.search(rf"{label}\s+t =\s+{num(float(t), 2)}", tail)


def test_641_positions(sample: tuple[Session, CycleResult]) -> None:
    session, r = sample
    text = mod(641).render(r, session)
    assert r.kf_pred is not None
    assert f"{r.kf_pred.x_m:.2f}" in next(ln for ln in text.splitlines() if ln.startswith("KF"))
    mpp_line = next(ln for ln in text.splitlines() if ln.startswith("MPP :"))
    assert f"{r.mpp.x_m:.2f}" in mpp_line and "filtered (KF)" in text
    assert f"{r.mpp.cov[0, 1]:.3f}" in text


def test_620_sensors(sample: tuple[Session, CycleResult]) -> None:
    session, r = sample
    text = mod(620).render(r, session)
    fs = r.filter_state
    assert fs is not None
    gyro = next(ln for ln in text.splitlines() if ln.startswith("Gyro"))
    assert "232.3°" in gyro and "232.7° grid" in gyro and "0.65°" in gyro
    assert f"{math.degrees(fs.x[9]):.3f}°" in gyro
    log = next(ln for ln in text.splitlines() if ln.startswith("Log"))
    assert "12.7kts" in log and "6.533 m/s" in log and f"{fs.x[8]:.3f} m/s" in log
    for name in ("Rudder  off", "Incl.   n/a", "Press.  off", "Echo    n/a"):
        assert name in text


@pytest.fixture(scope="module")
def demo() -> Iterator[tuple[Session, CycleResult]]:
    """Cycle 600 of the demo run: every sensor on, coloured fix-error states."""
    session = Session(load_config(DATA / "DEMO.toml"))
    r = None
    for _ in range(600):
        r = session.step()
    assert r is not None and r.n == 600
    yield session, r
    session.close()


def test_620_and_650_demo(demo: tuple[Session, CycleResult]) -> None:
    session, r = demo
    text = mod(620).render(r, session)
    press = next(ln for ln in text.splitlines() if ln.startswith("Press."))
    assert " Hz " in press and f"{r.sensors.depth_m:.2f} m depth" in press and "1.45 m" in press
    incl = next(ln for ln in text.splitlines() if ln.startswith("Incl."))
    assert "Δε" in incl and "0.50°" in incl
    text = mod(650).render(r, session)
    assert "13 states (coloured fix errors)" in text
    assert "fix_e" in text and "fix_n" in text and "z_p" in text
    text = mod(851).render(r, session)
    assert "fixe" in text.splitlines()[2]  # column labels fit five characters
    assert max(len(ln) for ln in mod(852).render(r, session).splitlines()) <= 80


def test_data_kalman_pages(sample: tuple[Session, CycleResult]) -> None:
    session, r = sample
    u, fs = r.filter_update, r.filter_state
    assert u is not None and fs is not None and r.smoother_link is not None
    text = mod(850).render(r, session)
    assert f"{fs.x[1]:.5f}" in text and f"{u.innovation[0]:.5f}" in text
    assert f"{u.S[0, 1]:.3f}" in text and "851 P" in text
    text = mod(851).render(r, session)
    assert "1.00" in text and "σ = √diag P" in text
    text = mod(852).render(r, session)
    phi = r.smoother_link[2]
    assert compact(float(phi[0, 4]), 6).strip() in text
    text = mod(853).render(r, session)
    assert f"{u.K[0, 0]:.5f}" in text and "H (rows: measurement rows" in text


def test_810_stations_and_readings(sample: tuple[Session, CycleResult]) -> None:
    session, r = sample
    text = mod(810).render(r, session)
    for name in ("Finsterwolde", "Hoyer", "Heiloo", "Zeven", "Frisian Islands"):
        assert name in text
    assert "    44.862   274.337     1.111" in text


# --------------------------------------------------------------------------- robustness
def _degraded(r: CycleResult) -> list[CycleResult]:
    """The cycle without a fix, without a filter, and with a failed fix."""
    failed = dataclasses.replace(r.fix, ok=False, reason="Not enough LOPs for a fix ! (1)",
                                 lops=(), tested=None, decca_geometry=None)  # type: ignore[arg-type]
    return [
        dataclasses.replace(r, fix=None),
        dataclasses.replace(r, filter_state=None, filter_update=None, kf=None, kf_pred=None,
                            smoother_link=None, filter_status="OFF"),
        dataclasses.replace(r, fix=failed),
    ]


@pytest.mark.parametrize("number", TEXT_PAGES)
def test_pages_render_without_fix_or_filter(number: int,
                                            sample: tuple[Session, CycleResult]) -> None:
    session, r = sample
    for case in _degraded(r):
        text = mod(number).render(case, session)
        assert text.startswith(mod(number).TITLE)
        assert "nan" not in text.lower().replace("n/a", "")


@pytest.mark.parametrize("number", TEXT_PAGES)
def test_pages_fit_the_page_width(number: int, sample: tuple[Session, CycleResult]) -> None:
    session, r = sample
    text = mod(number).render(r, session)
    assert max(len(ln) for ln in text.splitlines()) <= 80  # 100 columns less the status column


def test_611_a_long_datum_name_widens_its_column(sample: tuple[Session, CycleResult]) -> None:
    """A datum named as TO_WGS84.DAT may name it ("ED50 [DMA]", 10 characters) ran into the
    latitude on Pg 611; the latitudes of both rows now start in the same column, after a
    space."""
    session, r = sample
    text = mod(611).render(dataclasses.replace(r, datum="ED50 [DMA]"), session)
    head, wgs, work = next(text.splitlines()[i:i + 3] for i, ln in enumerate(text.splitlines())
                           if ln.startswith("datum"))
    assert work.startswith("ED50 [DMA] 52°")
    assert head.index("lat") == wgs.index("52°") == work.index("52°") == len("ED50 [DMA] ")
    plain = mod(611).render(r, session).splitlines()
    assert next(ln for ln in plain if ln.startswith("datum")).index("lat") == 9  # as before


def test_systems_off(sample: tuple[Session, CycleResult]) -> None:
    session, r = sample
    cfg = session.config
    off = cfg.replace(gps=dataclasses.replace(cfg.gps, on=False),
                      decca=dataclasses.replace(cfg.decca, on=False))
    session.context.config = off
    try:
        assert "GPS is off" in mod(611).render(r, session)
        assert "Decca is off" in mod(615).render(r, session)
        assert "Decca is off" in mod(810).render(r, session)
    finally:
        session.context.config = cfg


# --------------------------------------------------------------------------- registry, widget
def test_every_page_is_registered() -> None:
    """Every page but Pg 100 has a module ``pNNN_…`` that registers it with a title."""
    numbers = set(page_titles()) - {100}
    assert numbers == {*TEXT_PAGES, 642, 643, 710}
    for number in numbers:
        factory = pages()[number].factory
        assert factory is not None
        assert factory.__module__.split(".")[-1].startswith(f"p{number}_")
    for number in TEXT_PAGES:
        page = make_page(number)
        assert isinstance(page, TextPage) and page.NUMBER == number == mod(number).PAGE_NUMBER
    with pytest.raises(KeyError):
        make_page(632)


def test_widget_show_renders_once_per_cycle(sample: tuple[Session, CycleResult],
                                            monkeypatch: pytest.MonkeyPatch) -> None:
    session, r = sample
    page = make_page(633)
    assert isinstance(page, TextPage)
    assert "no cycle yet" in page.text
    calls: list[int] = []
    original = mod(633).render

    def counting(rr: CycleResult, ss: Session) -> str:
        calls.append(rr.n)
        return original(rr, ss)

    monkeypatch.setattr(mod(633), "render", counting)
    page.show(r, session)
    page.show(r, session)
    assert calls == [2] and page.text == original(r, session)
    page.show(None, None)
    assert "no cycle yet" in page.text


def test_helpers() -> None:
    assert num(-0.0001, 2) == "0.00" and num(float("nan"), 2, 5) == "  ---"
    assert num(None, 2, 7, "999.99") == " 999.99"
    assert compact(0.0, 5) == "    0" and compact(-0.7954, 6) == "-.7954"
    assert compact(4.1912, 6) == " 4.191" and compact(1.0, 4) == "   1"
    assert corr_text(-0.704, 5) == " -.70" and corr_text(1.0, 5) == " 1.00"
    assert corr_text(0.001, 5) == "    0"


def test_decca_page_shows_the_cf_the_sun_chose(tmp_path: pytest.TempPathFactory) -> None:
    """Pg 615 under ``lsq.decca_cf = "auto"``: the cycle's condition and CF, not the key's
    "auto" (the sample's first records moved to 22:35 UTC, a summer night: CF 1, THEORY §3.5)."""
    lines = (DATA / "920917_1.RUN").read_text(encoding="ascii").splitlines(keepends=True)
    run = tmp_path / "night.RUN"  # type: ignore[operator]
    run.write_text("".join([lines[0]] + [ln.replace("\t08", "\t22", 1) for ln in lines[1:4]]),
                   encoding="ascii")
    cfg = load_config(DATA / "920917_1.toml")
    cfg = cfg.replace(run_file=str(run), lsq=dataclasses.replace(cfg.lsq, decca_cf="auto"))
    session = Session(cfg)
    r = session.step()
    assert r is not None
    text = mod(615).render(r, session)
    assert "a priori VCV matrix (SN) :" in text
    assert "Decca.CF 1 (auto: by the sun)" in text

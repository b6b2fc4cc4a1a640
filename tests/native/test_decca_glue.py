"""The systems' stage glue of issue 14 (night): the compiled calls that replace Python around
the Decca kernel give the same values, bit for bit, as the Python they stand for.

* ``decca.geometry_new``: ``decca_geometry``'s :class:`DeccaGeometry` made in one call, each
  array the numbers of the reference ``decca_geometry`` (same dtype, shape, bits);
* ``decca.linearise_at``: ``DeccaObservations.linearise`` at a :class:`Point` without its
  latitude/longitude yet: the rows, misclosures and VCV block of the reference
  ``DeccaObservations.linearise``, and the point's ``latlon`` set to what ``TMGrid.inverse``
  gives (as ``Point.latlon`` sets it);
  another grid is declined and the Python runs;
* ``runparse.make``: ``SystemReading`` and ``CycleInputs`` (slots dataclasses) equal to the
  instances their ``__init__`` makes; ``runparse.make_attrs`` the same for a plain frozen
  dataclass with an instance dict.
"""

from __future__ import annotations

import math
from dataclasses import FrozenInstanceError, dataclass, fields
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import engine.systems.decca as decca
from engine import native
from engine.fast import decca as fast_decca
from engine.fast import make as fast_make
from engine.fast.decca import FAST_DECCA, FastDeccaObservations
from engine.geodesy.tmgrid import TMGrid
from engine.systems import base
from engine.systems.base import CycleInputs, Point, SystemReading
from tests.native.test_decca import (
    FAST,
    GRID,
    MX,
    MY,
    PLACED,
    PURE,
    far_from_stations,
    hexes,
    outcome,
)

K = native.kernel("decca")
pytestmark = pytest.mark.skipif(K is None, reason=f"decca kernel: {native.status('decca')}")

_OFFSET = st.floats(-3e5, 3e5, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(dx=_OFFSET, dy=_OFFSET)
def test_geometry_new_is_the_python_geometry(dx: float, dy: float) -> None:
    x, y = MX + dx, MY + dy
    assume(far_from_stations(x, y))
    lat, lon = GRID.inverse(x, y)
    try:
        g = fast_decca.decca_geometry(PLACED, x, y, FAST, (lat, lon))
    except (ValueError, ArithmeticError) as exc:
        with pytest.raises(type(exc)):
            decca.decca_geometry(PLACED, x, y, PURE, (lat, lon))
        return
    h = decca.decca_geometry(PLACED, x, y, PURE, (lat, lon))
    assert type(g) is decca.DeccaGeometry
    for name in decca.DeccaGeometry.__slots__:
        a, b = getattr(g, name), getattr(h, name)
        assert hexes(a) == hexes(b), name
        if isinstance(b, np.ndarray):
            assert a.flags.writeable == b.flags.writeable and a.flags.c_contiguous
    assert g.baseline_m is PLACED.baseline_m


def _rows(obs: decca.DeccaObservations, p: Point, slot0: int, pure: bool) -> object:
    n = slot0 + 3
    A, b, Cl = [0.25] * (2 * n), [0.5] * n, np.full((n, n), 0.75)
    if pure:
        r = outcome(decca.DeccaObservations.linearise, obs, p, slot0, A, b, Cl)
    else:
        r = outcome(obs.linearise, p, slot0, A, b, Cl)
    return r, hexes(A), hexes(b), hexes(Cl)


@settings(max_examples=200, deadline=None)
@given(dx=_OFFSET, dy=_OFFSET, cf=st.sampled_from([64.0, 4.0, 1.0, 1 / 2.25]),
       slot0=st.integers(0, 3), have=st.tuples(st.booleans(), st.booleans(), st.booleans()),
       obs=st.floats(-1e3, 1e3))
def test_linearise_at_a_point_without_latlon(dx: float, dy: float, cf: float, slot0: int,
                                             have: tuple[bool, bool, bool],
                                             obs: float) -> None:
    x, y = MX + dx, MY + dy
    assume(far_from_stations(x, y))
    reading = decca.DeccaReading(PLACED, (0.1, 0.2, 0.3), (None, None, None), (True,) * 3,
                                 cf=cf)
    observed = [obs + i if h else math.nan for i, h in enumerate(have)]
    o = FastDeccaObservations(reading, observed, [None] * 3, list(have), [])
    p_fast = Point(GRID, FAST, x, y)
    p_pure = Point(GRID, PURE, x, y)
    assert _rows(o, p_fast, slot0, False) == _rows(o, p_pure, slot0, True)
    assert p_fast._latlon is not None
    assert hexes(p_fast._latlon) == hexes(TMGrid(GRID.ellipsoid, GRID.cm_deg)._inverse(x, y))
    assert hexes(p_fast.latlon) == hexes(p_pure.latlon)


def test_linearise_at_declines_another_grid() -> None:
    """A point on another grid object: the kernel declines, the Python inverts on the chain's
    grid and leaves the point's latlon alone (as before)."""
    other = TMGrid(GRID.ellipsoid, GRID.cm_deg)
    reading = decca.DeccaReading(PLACED, (0.1, 0.2, 0.3), (None, None, None), (True,) * 3)
    o = FastDeccaObservations(reading, [1.0, 2.0, 3.0], [None] * 3, [True] * 3, [])
    args = (PLACED._scalars, FAST.native(), native.kernel("tmgrid").inverse, GRID._packed, GRID,
            Point(other, FAST, MX + 1e4, MY + 2e4), o.observed, 0, [0.0] * 6, [0.0] * 3,
            np.eye(3), 64.0)
    assert K.linearise_at(*args) is NotImplemented
    p = Point(other, FAST, MX + 1e4, MY + 2e4)
    fast = _rows(o, p, 0, False)
    assert p._latlon is None
    assert fast == _rows(o, Point(other, PURE, MX + 1e4, MY + 2e4), 0, True)


@dataclass(frozen=True)
class _PlainInputs:
    """A plain frozen dataclass (an instance dict) with CycleInputs' fields, for make_attrs."""

    config: object
    context: object
    nav: object
    record: object
    grid: object
    cm_deg: object
    x_start: object
    prior: object
    earlier: object


def test_readings_made_in_one_call_are_the_dataclass_instances() -> None:
    value = object()
    for args in ((value, ("a", "b"), None, True), (None, (), 3.5, False)):
        r = fast_decca.maker(SystemReading)(*args)
        q = SystemReading(*args)
        assert type(r) is SystemReading and r == q == SystemReading(*args)
        for f in fields(SystemReading):
            assert getattr(r, f.name) is getattr(q, f.name)
        assert not hasattr(r, "__dict__")
        with pytest.raises(FrozenInstanceError):
            r.value = 1  # type: ignore[misc]
    make = fast_make.slots_maker(CycleInputs)
    plain = fast_make.attrs_maker(_PlainInputs)
    if native.kernel("runparse") is None:
        assert make is CycleInputs and plain is None
        return
    assert make is not CycleInputs and plain is not None
    vals = [object() for _ in fields(CycleInputs)]
    c = make(*vals)
    assert c == CycleInputs(*vals) and not hasattr(c, "__dict__")
    for f, v in zip(fields(CycleInputs), vals, strict=True):
        assert getattr(c, f.name) is v
    with pytest.raises(TypeError):
        make(*vals[:-1])
    d = plain(*vals)
    assert d == _PlainInputs(*vals) and set(vars(d)) == {f.name for f in fields(_PlainInputs)}
    with pytest.raises(TypeError):
        plain(*vals[:-1])


def test_pure_path_makes_readings_in_python(monkeypatch: pytest.MonkeyPatch) -> None:
    """Without the runparse kernel (UVNAV_PURE=1) the makers are the Python ones."""
    monkeypatch.setattr(native, "kernel", lambda name: None)
    assert fast_make.attrs_maker(_PlainInputs) is None
    assert fast_make.slots_maker(SystemReading) is SystemReading
    assert fast_decca.maker(SystemReading) is SystemReading


_M = st.floats(-1e7, 1e7, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(x=_M, y=_M, cn=st.floats(-50, 50), ce=st.floats(-50, 50), px=_M, py=_M,
       var=st.floats(0.01, 1e4), slot0=st.integers(0, 3))
def test_gps_rows_are_the_python_rows(x: float, y: float, cn: float, ce: float, px: float,
                                      py: float, var: float, slot0: int) -> None:
    """``decca.gps_rows`` writes the GPS coordinate rows of ``_GpsObservations.linearise``:
    the same A, b and C_l bits as its Python (run with the kernel's function switched off)."""
    from engine.fast.gps import FastGpsObservations
    from engine.systems import gps

    fix = gps.GpsFix(52.0, 5.0, x, y, var, cn, ce)
    p = Point(GRID, FAST, px, py)
    out = []
    for obs in (FastGpsObservations(fix), gps._GpsObservations(fix)):
        n = slot0 + 2
        A, b, Cl = [0.25] * (2 * n), [0.5] * n, np.full((n, n), 0.75)
        obs.linearise(p, slot0, A, b, Cl)
        out.append((hexes(A), hexes(b), hexes(Cl)))
    assert out[0] == out[1]


def test_gps_rows_decline_what_they_do_not_write() -> None:
    """A read-only or too small C_l, or arguments of another kind: NotImplemented, nothing
    written (the Python then writes, or raises, as before)."""
    A, b = [0.25] * 4, [0.5] * 2
    ro = np.eye(2)
    ro.setflags(write=False)
    for cl, slot0, north in ((ro, 0, 1.0), (np.eye(2), 1, 1.0), (np.eye(2).tolist(), 0, 1.0),
                             (np.eye(2), 0, 1)):
        assert K.gps_rows(A, b, cl, slot0, north, 2.0, 3.0, 4.0, 5.0) is NotImplemented
        assert A == [0.25] * 4 and b == [0.5] * 2
    assert K.gps_rows(A, b, np.eye(2), 0, 1.0, 2.0, 3.0, 4.0, 5.0) is None
    assert A == [0.0, 1.0, 1.0, 0.0] and b == [1.0 - 4.0, 2.0 - 3.0]


# ------------------------------------------------- page and nearest (readings, nearest station)

def _page_both(obs: decca.DeccaObservations, p: Point) -> tuple[object, object]:
    """``readings`` (the kernel's page) and the Python's rows at ``p``, as comparable values."""
    fast = obs.readings(p)
    pure = decca.DeccaObservations.readings(obs, p)
    assert type(fast) is list and all(type(r) is base.LopReading for r in fast)
    return [[_cell(getattr(r, f.name)) for f in fields(r)] for r in fast], \
        [[_cell(getattr(r, f.name)) for f in fields(r)] for r in pure]


def _cell(v: object) -> object:
    """A field compared by type and bits (a float by its hex)."""
    return type(v).__name__, float.hex(v) if isinstance(v, float) else v


def test_page_and_nearest_on_the_replay() -> None:
    """Every Decca fix of 120 demo epochs: the kernel's page rows and nearest station are the
    Python's, bit for bit (and the kernel is what ran)."""
    from tests.native.replay import replay_patched

    # the fix calls nearest_station_m(p_hat, used[start:stop]) and readings(p_hat) of each set at
    # its estimate (in Python, or from the lsq kernel's tail/estimate through the methods)
    seen: list[tuple[decca.DeccaObservations, Point, object]] = []
    orig = FastDeccaObservations.nearest_station_m

    def spy(self, p_hat, used):  # type: ignore[no-untyped-def]
        seen.append((self, p_hat, list(used)))
        return orig(self, p_hat, used)

    replay_patched([(FastDeccaObservations, "nearest_station_m", spy)], 120)
    assert len(seen) > 100
    for obs, p, used in seen:
        fast, pure = _page_both(obs, p)
        assert fast == pure
        geom = obs.geometry_at(p)
        for u in (used, [True] * 3, [False, True, False]):
            assert K.nearest(geom.d_master_m, geom.d_slave_m, u) is not NotImplemented
            assert hexes(obs.nearest_station_m(p, u)) == hexes(
                decca.DeccaObservations.nearest_station_m(obs, p, u))


_RAW = st.one_of(st.none(), st.floats(-1e4, 1e4))


@settings(max_examples=200, deadline=None)
@given(dx=_OFFSET, dy=_OFFSET, raw=st.tuples(_RAW, _RAW, _RAW),
       corr=st.tuples(st.floats(-5, 5), st.floats(-5, 5), st.floats(-5, 5)))
def test_page_anywhere(dx: float, dy: float, raw: tuple[float | None, ...],
                       corr: tuple[float, float, float]) -> None:
    reading = decca.DeccaReading(PLACED, (0.1, 0.2, 0.3), (None, None, None), (True,) * 3,
                                 corrections_lanes=corr)
    obs = FastDeccaObservations(reading, [math.nan] * 3, list(raw), [True] * 3, [])
    p = Point(GRID, FAST, MX + dx, MY + dy)
    try:
        obs.geometry_at(p)
    except (ValueError, ArithmeticError):
        return
    fast, pure = _page_both(obs, p)
    assert fast == pure


_ANY = st.floats(allow_nan=True, allow_infinity=True)


@settings(max_examples=300, deadline=None)
@given(az=st.tuples(_ANY, _ANY, _ANY))
def test_page_degrees_are_math_degrees(az: tuple[float, float, float]) -> None:
    """The kernel's math.degrees (x · 180/π, CPython's own constant) on any double."""
    rows = K.page(np.zeros(3), np.array(az), (1.0, None, 2.0), (0.0, 0.0, 0.0),
                  decca.DECCA_PATTERN_NAMES, "Decca", base.LopReading)
    assert [hexes(r.az_deg) for r in rows] == [hexes(math.degrees(az[0])),
                                               hexes(math.degrees(az[2]))]
    assert [r.index for r in rows] == [0, 2]


@settings(max_examples=300, deadline=None)
@given(dm=_ANY, ds=st.tuples(_ANY, _ANY, _ANY),
       used=st.tuples(st.booleans(), st.booleans(), st.booleans()))
def test_nearest_anywhere(dm: float, ds: tuple[float, float, float],
                          used: tuple[bool, bool, bool]) -> None:
    """min's own order, NaN and infinities included."""
    geom = SimpleNamespace(d_master_m=dm, d_slave_m=np.array(ds))
    reading = decca.DeccaReading(PLACED, (0.1, 0.2, 0.3), (None, None, None), (True,) * 3)
    ref = decca.DeccaObservations(reading, [math.nan] * 3, [None] * 3, [True] * 3, [])
    p = Point(GRID, PURE, MX, MY)
    ref._at = (p, geom)  # type: ignore[assignment]
    want = ref.nearest_station_m(p, list(used))
    for u in (list(used), used):
        assert hexes(K.nearest(dm, geom.d_slave_m, u)) == hexes(want)


def test_page_and_nearest_decline_what_they_do_not_read() -> None:
    names = decca.DECCA_PATTERN_NAMES
    good = (np.zeros(3), np.zeros(3), (1.0, 2.0, 3.0), (0.0, 0.0, 0.0), names, "Decca",
            base.LopReading)
    assert len(K.page(*good)) == 3
    for i, bad in ((0, np.zeros(3, dtype=np.float32)), (1, np.zeros(4)), (2, [1.0, 2.0, 3.0]),
                   (3, (0.0, 0.0)), (4, list(names)), (1, np.zeros((3, 1)))):
        args = list(good)
        args[i] = bad
        assert K.page(*args) is NotImplemented
    assert K.page(*good[:-1]) is NotImplemented
    d = np.ones(3)
    assert K.nearest(2.0, d, [True] * 3) == 1.0
    for args in ((np.float64(2.0), d, [True] * 3), (2.0, d[:2], [True] * 3),
                 (2.0, d, np.ones(3, bool)), (2.0, d, [True])):
        assert K.nearest(*args) is NotImplemented


def test_pure_path_has_no_page_kernel(monkeypatch: pytest.MonkeyPatch) -> None:
    """Without the kernel (UVNAV_PURE=1) readings and nearest_station_m are the Python's."""
    monkeypatch.setattr(fast_decca, "KERNEL", None)
    reading = decca.DeccaReading(PLACED, (0.1, 0.2, 0.3), (None, None, None), (True,) * 3)
    obs = FastDeccaObservations(reading, [math.nan] * 3, [1.0, None, 3.0], [True] * 3, [])
    p = Point(GRID, FAST, MX + 1e3, MY - 2e3)
    fast, pure = _page_both(obs, p)
    assert fast == pure and len(fast) == 2
    assert obs.nearest_station_m(p, [True] * 3) == decca.DeccaObservations.nearest_station_m(
        obs, p, [True] * 3)


# ------------------------------------------------------- observed (tracked totals' lists)

def _observations_both(value: decca.DeccaReading, monkeypatch: pytest.MonkeyPatch
                       ) -> tuple[object, object]:
    """DeccaSystem.observations of ``value`` with the kernel's lists and with the Python loop,
    as comparable values (lists by type and bits, the raw tuple, messages)."""
    p0 = Point(GRID, FAST, MX, MY)

    def parts(o: decca.DeccaObservations) -> object:
        return ([_cell(v) for v in o.observed], [_cell(v) for v in o.raw],
                [_cell(v) for v in o._available], o.messages, o.reading is value, o._at)

    fast = FAST_DECCA.observations(value, p0)
    pure = decca.DECCA.observations(value, p0)
    assert fast is not None and pure is not None
    return parts(fast), parts(pure)


def test_observed_on_the_replay(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every Decca reading of 120 demo epochs: the kernel's lists are the Python loop's."""
    from tests.native.replay import replay

    seen: list[decca.DeccaReading] = []
    orig = fast_decca.FastDeccaSystem.observations

    def spy(self, value, p0):  # type: ignore[no-untyped-def]
        if value is not None:
            seen.append(value)
        return orig(self, value, p0)

    monkeypatch.setattr(fast_decca.FastDeccaSystem, "observations", spy)
    replay(120)
    monkeypatch.setattr(fast_decca.FastDeccaSystem, "observations", orig)
    assert len(seen) > 100
    for value in seen:
        assert value.totals is not None
        args = (value.totals, value.fractions, value.corrections_lanes, value.selected,
                math.nan)
        assert K.observed(*args) is not NotImplemented
        fast, pure = _observations_both(value, monkeypatch)
        assert fast == pure


_TOTAL = st.one_of(st.none(), st.floats(allow_nan=True, allow_infinity=True))


@settings(max_examples=200, deadline=None)
@given(totals=st.tuples(_TOTAL, _TOTAL, _TOTAL),
       fr=st.tuples(*[st.one_of(st.none(), st.floats(0.0, 0.999))] * 3),
       corr=st.tuples(*[st.floats(allow_nan=True, allow_infinity=True)] * 3),
       sel=st.tuples(st.booleans(), st.booleans(), st.booleans()))
def test_observed_anywhere(totals: tuple[float | None, ...], fr: tuple[float | None, ...],
                           corr: tuple[float, float, float], sel: tuple[bool, bool, bool]
                           ) -> None:
    value = decca.DeccaReading(PLACED, fr, (None, None, None), sel, corr, 64.0, totals)
    with pytest.MonkeyPatch.context() as mp:
        fast, pure = _observations_both(value, mp)
    assert fast == pure


def test_observed_declines_what_it_does_not_read() -> None:
    good = ((1.0, None, 2.0), (0.1, 0.2, None), (0.0, 0.5, 0.25), (True, False, True), math.nan)
    obs, raw, av = K.observed(*good)
    assert raw == [1.0, None, None] and av == [True, False, False]
    assert obs[0] == 1.0 and obs[1] is math.nan and obs[2] is math.nan
    for i, bad in ((0, [1.0, None, 2.0]), (0, (1, None, 2.0)), (2, (0, 0.5, 0.25)),
                   (1, (0.1, 0.2)), (3, [True, False, True])):
        args = list(good)
        args[i] = bad
        assert K.observed(*args) is NotImplemented
    assert K.observed(*good[:-1]) is NotImplemented

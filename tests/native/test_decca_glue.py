"""The systems' stage glue of issue 14 (night): the compiled calls that replace Python around
the Decca kernel give the same values, bit for bit, as the Python they stand for.

* ``decca.geometry_new``: ``decca_geometry``'s :class:`DeccaGeometry` made in one call, each
  array the numbers of the pure ``_decca_geometry_py`` (same dtype, shape, bits);
* ``decca.linearise_at``: ``DeccaObservations.linearise`` at a :class:`Point` without its
  latitude/longitude yet: the rows, misclosures and VCV block of ``_linearise_py``, and the
  point's ``latlon`` set to what ``TMGrid.inverse`` gives (as ``Point.latlon`` sets it);
  another grid is declined and the Python runs;
* ``runparse.make``: ``SystemReading`` and ``CycleInputs`` (slots dataclasses) equal to the
  instances their ``__init__`` makes; ``runparse.make_attrs`` the same for a plain frozen
  dataclass with an instance dict.
"""

from __future__ import annotations

import math
from dataclasses import FrozenInstanceError, dataclass, fields

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import engine.systems.decca as decca
from engine import native
from engine.geodesy.tmgrid import TMGrid
from engine.systems import base
from engine.systems.base import CycleInputs, Point, SystemReading
from tests.native.test_decca import FAST, GRID, MX, MY, PLACED, PURE, _Pure, hexes, outcome

K = native.kernel("decca")
pytestmark = pytest.mark.skipif(K is None, reason=f"decca kernel: {native.status('decca')}")

_OFFSET = st.floats(-3e5, 3e5, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(dx=_OFFSET, dy=_OFFSET)
def test_geometry_new_is_the_python_geometry(dx: float, dy: float) -> None:
    x, y = MX + dx, MY + dy
    lat, lon = GRID.inverse(x, y)
    try:
        g = decca.decca_geometry(PLACED, x, y, FAST, (lat, lon))
    except (ValueError, ArithmeticError) as exc:
        with _Pure(), pytest.raises(type(exc)):
            decca._decca_geometry_py(PLACED, x, y, PURE, (lat, lon))
        return
    with _Pure():
        h = decca._decca_geometry_py(PLACED, x, y, PURE, (lat, lon))
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
        with _Pure():
            r = outcome(obs._linearise_py, p, slot0, A, b, Cl)
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
    reading = decca.DeccaReading(PLACED, (0.1, 0.2, 0.3), (None, None, None), (True,) * 3,
                                 cf=cf)
    observed = [obs + i if h else math.nan for i, h in enumerate(have)]
    o = decca.DeccaObservations(reading, observed, [None] * 3, list(have), [])
    p_fast = Point(GRID, FAST, x, y)
    p_pure = Point(GRID, PURE, x, y)
    assert _rows(o, p_fast, slot0, False) == _rows(o, p_pure, slot0, True)
    assert p_fast._latlon is not None
    assert hexes(p_fast._latlon) == hexes(GRID._inverse_py(x, y))
    assert hexes(p_fast.latlon) == hexes(p_pure.latlon)


def test_linearise_at_declines_another_grid() -> None:
    """A point on another grid object: the kernel declines, the Python inverts on the chain's
    grid and leaves the point's latlon alone (as before)."""
    other = TMGrid(GRID.ellipsoid, GRID.cm_deg)
    reading = decca.DeccaReading(PLACED, (0.1, 0.2, 0.3), (None, None, None), (True,) * 3)
    o = decca.DeccaObservations(reading, [1.0, 2.0, 3.0], [None] * 3, [True] * 3, [])
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
        r = base.new_reading(*args)
        q = base._new_reading_py(*args)
        assert type(r) is SystemReading and r == q == SystemReading(*args)
        for f in fields(SystemReading):
            assert getattr(r, f.name) is getattr(q, f.name)
        assert not hasattr(r, "__dict__")
        with pytest.raises(FrozenInstanceError):
            r.value = 1  # type: ignore[misc]
    make = base.slots_maker(CycleInputs)
    plain = base.attrs_maker(_PlainInputs)
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
    assert base.attrs_maker(_PlainInputs) is None
    assert base.slots_maker(SystemReading) is SystemReading
    assert base._reading_maker() is base._new_reading_py


_M = st.floats(-1e7, 1e7, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(x=_M, y=_M, cn=st.floats(-50, 50), ce=st.floats(-50, 50), px=_M, py=_M,
       var=st.floats(0.01, 1e4), slot0=st.integers(0, 3))
def test_gps_rows_are_the_python_rows(x: float, y: float, cn: float, ce: float, px: float,
                                      py: float, var: float, slot0: int) -> None:
    """``decca.gps_rows`` writes the GPS coordinate rows of ``_GpsObservations.linearise``:
    the same A, b and C_l bits as its Python (run with the kernel's function switched off)."""
    from engine.systems import gps

    fix = gps.GpsFix(52.0, 5.0, x, y, var, cn, ce)
    obs = gps._GpsObservations(fix)
    p = Point(GRID, FAST, px, py)
    out = []
    for rows in (gps._ROWS, None):
        n = slot0 + 2
        A, b, Cl = [0.25] * (2 * n), [0.5] * n, np.full((n, n), 0.75)
        saved = gps._ROWS
        gps._ROWS = rows
        try:
            obs.linearise(p, slot0, A, b, Cl)
        finally:
            gps._ROWS = saved
        out.append((hexes(A), hexes(b), hexes(Cl)))
    assert gps._ROWS is not None
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

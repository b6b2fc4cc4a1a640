"""The compiled datum shift (engine/native/datum.c) agrees with the reference's.

``FastDatumShift.point`` (engine.fast) is ``engine.native.datum.Shift`` where the kernel is
built: :class:`engine.geodesy.ellipsoidal.DatumShift`'s geocentric shift compiled, handing what
it does not cover to the reference's ``transform`` it was made with. Every comparison here is
to the tolerance contract (tests.tolerance: 1e-9 relative, or 1e-9° and 1e-6 m), against the
reference: on the points a short demo replay shifts, for every datum pair of
data/TO_WGS84.DAT (and WGS84) over the whole globe (poles, ±180°, heights ±10 km, hypothesis
and a fixed sweep), and on the edges (beyond the poles, wrapped longitudes, non-finite values,
points deep inside the Earth). The reference itself is checked against pyproj in
tests/geodesy/test_geodesy.py.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine import native
from engine.fast import geodesy as fast_geodesy
from engine.fast.geodesy import FastDatumShift
from engine.geodesy.ellipsoid import WGS84
from engine.geodesy.ellipsoidal import DatumShift
from engine.io.datumfile import read_datum_file
from tests.native.replay import replay_patched
from tests.paths import DATA
from tests.tolerance import ATOL_DEFAULT, ATOL_METRES, Near

KERNEL = native.kernel("datum")
needs_kernel = pytest.mark.skipif(KERNEL is None, reason="engine.native.datum not built")

_FILE = read_datum_file(DATA / "TO_WGS84.DAT")
DATUMS = {**_FILE.datums, "WGS84 (engine)": WGS84}
"""Every datum of the file, and the engine's own WGS84 (what a GPS in WGS84 is shifted from)."""

PAIRS = [(s, d) for s in DATUMS for d in DATUMS if s != d]
SHIFTS = {pair: FastDatumShift(DATUMS[pair[0]], DATUMS[pair[1]]) for pair in PAIRS}


def _near(v: tuple[float, ...]) -> Near:
    """``v`` (lat°, lon°, h m) for a comparison to the tolerance contract (tests.tolerance)."""
    assert all(type(x) is float for x in v)
    return Near(tuple(v), (ATOL_DEFAULT, ATOL_DEFAULT, ATOL_METRES))


def _ref(shift: DatumShift, lat: float, lon: float, h: float) -> Near:
    """The reference's answer (:meth:`DatumShift.transform` of the same datums)."""
    return _near(DatumShift(shift.src, shift.dst).transform(lat, lon, h))


def _point(shift: FastDatumShift, lat: float, lon: float, h: float) -> Near:
    """What the engine's calls get (``FastDatumShift.point``, as the kernels call it)."""
    return _near(shift.point(lat, lon, h))


# --------------------------------------------------------------------------- wiring
@needs_kernel
def test_every_pair_the_engine_builds_is_compiled() -> None:
    """Every datum pair of the file goes through the kernel, its fallback the reference."""
    assert len(PAIRS) >= 230
    for shift in SHIFTS.values():
        assert type(shift.point) is KERNEL.Shift
        fallback = shift.point.fallback
        assert fallback.__func__ is DatumShift.transform
        assert (fallback.__self__.src, fallback.__self__.dst) == (shift.src, shift.dst)


def test_pure_path(monkeypatch: pytest.MonkeyPatch) -> None:
    """No kernel: the reference's call itself."""
    src, dst = _FILE.datum("ED50"), WGS84
    pure = DatumShift(dst, src)
    monkeypatch.setattr(fast_geodesy, "DATUM", None)
    missing = FastDatumShift(dst, src)
    assert missing.point.__func__ is DatumShift.transform
    for q in fast_geodesy.SHIFT_PROBES + ((52.1234, 3.4567, 0.0), (-0.0, -0.0, -0.0)):
        assert missing.transform(*q) == pure.transform(*q)


@needs_kernel
def test_a_probe_mismatch_keeps_the_reference(monkeypatch: pytest.MonkeyPatch) -> None:
    """A kernel that does not agree with the reference on the probe points (here: one 2e-6 m
    off in height) is not used; one that declines a probe point (NaN) still is."""
    real = fast_geodesy.DATUM

    class Off:
        def __init__(self, *args: Any) -> None:
            self.shift = real.Shift(*args)

        def forward(self, *q: float) -> Any:
            got = self.shift.forward(*q)
            return None if got is None else (got[0], got[1], got[2] + 2e-6)

    monkeypatch.setattr(fast_geodesy, "SHIFT_PROBES", ((52.0, 3.0, 0.0), (math.nan, 0.0, 0.0)))
    shift = FastDatumShift(WGS84, _FILE.datum("ED50"))
    assert type(shift.point) is real.Shift
    monkeypatch.setattr(fast_geodesy, "DATUM", type("M", (), {"Shift": Off}))
    shift = FastDatumShift(WGS84, _FILE.datum("ED50"))
    assert shift.point.__func__ is DatumShift.transform


# --------------------------------------------------------------------------- a replay
@pytest.fixture(scope="module")
def replayed() -> list[tuple[FastDatumShift, Any, tuple[Any, ...]]]:
    """(shift, its point call, the call's arguments) of every datum shift of the first 150 demo
    epochs (the tmgrid kernel's gps_input and the Python both call ``FastDatumShift.point``)."""
    seen: list[tuple[FastDatumShift, Any, tuple[Any, ...]]] = []
    real_init = FastDatumShift.__init__

    def init(self: FastDatumShift, src: Any, dst: Any) -> None:
        real_init(self, src, dst)
        point = self.point

        def record(*args: Any) -> Any:
            seen.append((self, point, args))
            return point(*args)

        self.point = record

    replay_patched([(FastDatumShift, "__init__", init)], 150)
    return seen


@needs_kernel
def test_the_replay_s_points(replayed: list[tuple[FastDatumShift, Any, tuple[Any, ...]]]) -> None:
    """The replay's shifts: compiled, never declined, the reference's numbers."""
    assert len(replayed) >= 140
    for shift, point, args in replayed:
        assert type(point) is KERNEL.Shift
        assert len(args) == 3 and all(type(v) is float for v in args)
        got = point.forward(*args)
        assert got is not None
        assert _near(got) == _near(point(*args)) == _ref(shift, *args)


# --------------------------------------------------------------------------- the globe
_LAT = st.floats(-90.0, 90.0) | st.sampled_from([90.0, -90.0, 0.0, -0.0, 89.9999999, -89.99999])
_LON = st.floats(-180.0, 180.0) | st.sampled_from([180.0, -180.0, 0.0, -0.0, 179.9999999])
_H = st.floats(-10_000.0, 10_000.0) | st.sampled_from([0.0, -0.0, 10_000.0, -10_000.0])


@needs_kernel
@settings(deadline=None, max_examples=600)
@given(k=st.integers(0, 10_000), lat=_LAT, lon=_LON, h=_H)
def test_anywhere_on_the_globe(k: int, lat: float, lon: float, h: float) -> None:
    """Any pair, any latitude, longitude and height: the kernel computes (it declines only
    within 1° of a pole and on the antimeridian, where the reference answers) and agrees with
    the reference."""
    shift = SHIFTS[PAIRS[k % len(PAIRS)]]
    got = shift.point.forward(lat, lon, h)
    if abs(lat) < 88.9 and abs(abs(lon) - 180.0) > 1e-3:
        assert got is not None
    if got is not None:
        assert _near(got) == _ref(shift, lat, lon, h)
    assert _point(shift, lat, lon, h) == _ref(shift, lat, lon, h)


@needs_kernel
def test_every_pair_on_a_fixed_sweep() -> None:
    """Every pair on 120 points (a fixed seed, the whole globe, ±10 km) through the kernel and
    the reference."""
    rng = np.random.default_rng(14)
    lat = rng.uniform(-90.0, 90.0, 120)
    lon = rng.uniform(-180.0, 180.0, 120)
    h = rng.uniform(-10_000.0, 10_000.0, 120)
    lat[:6] = [90.0, -90.0, 0.0, 45.0, -45.0, 89.99999999]
    lon[:6] = [180.0, -180.0, 0.0, 179.99999999, -179.99999999, 33.0]
    h[:6] = [0.0, 10_000.0, -10_000.0, 0.0, 1.0, -1.0]
    for pair in PAIRS:
        shift = SHIFTS[pair]
        for i in range(lat.size):
            q = (float(lat[i]), float(lon[i]), float(h[i]))
            assert _point(shift, *q) == _ref(shift, *q), (pair, q)


# --------------------------------------------------------------------------- the edges
EDGES: list[tuple[float, float, float]] = [
    (90.0 + 5e-11, 10.0, 0.0),     # beyond the pole: declined
    (-90.0 - 5e-11, -10.0, 5.0),
    (90.0 + 1e-6, 0.0, 0.0),
    (45.0, 540.0, 0.0),            # 9.4 rad: computed, the result wrapped by atan2
    (45.0, -559.0, 100.0),
    (45.0, 600.0, 0.0),            # > 10 rad: declined
    (0.0, 180.0 + 1e-10, 0.0),
    (-0.0, -0.0, -0.0),
    (math.nan, 3.0, 0.0), (52.0, math.inf, 0.0), (52.0, 3.0, -math.inf), (52.0, 3.0, math.nan),
    (52.0, 3.0, 6.3e6),            # far above the surface
    (52.0, 3.0, -6.36e6), (0.0, 0.0, -6.378e6), (89.0, 0.0, -6.35e6),  # near the centre
    (1e-300, -1e-300, 1e-300), (5e-324, 5e-324, 0.0),
]


def _outcome(fn: Callable[..., Any], *args: Any, **kw: Any) -> Any:
    """``fn``'s answer for the tolerance contract, or its exception (type and text)."""
    try:
        out = fn(*args, **kw)
    except Exception as exc:  # noqa: BLE001 - the exception is the outcome compared
        return type(exc), str(exc)
    return _near(tuple(float(v) for v in out)) if all(map(math.isfinite, out)) else repr(out)


@needs_kernel
@pytest.mark.parametrize("pair", PAIRS[:: max(1, len(PAIRS) // 12)] + [
    ("WGS84 (engine)", "ED50"), ("ED50", "WGS84 (engine)"), ("WGS72 [DMA]", "OSGB 1936")])
def test_edges(pair: tuple[str, str]) -> None:
    """Inputs beyond the poles, wrapped longitudes, non-finite values, points far from the
    surface: the kernel's answer or (where it declines) the reference's, the reference's
    numbers (or its error)."""
    shift = SHIFTS[pair]
    ref = DatumShift(shift.src, shift.dst)
    for q in EDGES:
        assert _outcome(shift.point, *q) == _outcome(ref.transform, *q), (pair, q)
        got = shift.point.forward(*q)
        if got is not None:
            assert _near(got) == _ref(shift, *q)
        if not all(map(math.isfinite, q)) or abs(q[0]) > 90.0:
            assert got is None


@needs_kernel
def test_other_calls_go_to_the_reference() -> None:
    """Other argument kinds and counts, keywords: the reference's answer (or its error)."""
    shift = SHIFTS[("WGS84 (engine)", "ED50")]
    point, ref = shift.point, DatumShift(shift.src, shift.dst).transform
    for args in [(52, 3, 0), (52.0, 3.0), (np.float64(52.0), 3.0, 0.0), (52.0, 3.0, 0.0, 1.0),
                 ("52", 3.0, 0.0), ()]:
        assert _outcome(point, *args) == _outcome(ref, *args), args
    assert _outcome(point, 52.0, 3.0, h_m=0.0) == _outcome(ref, 52.0, 3.0, h_m=0.0)
    assert _near(shift.transform(52, 3, 0)) == _near(shift.transform(52.0, 3.0, 0.0))
    with pytest.raises(TypeError):
        KERNEL.Shift(None, 6378137.0, 298.257223563, None, 6378388.0, 297.0, None)
    with pytest.raises(ValueError):
        KERNEL.Shift(ref, -1.0, 298.257223563, None, 6378388.0, 297.0, None)
    with pytest.raises(TypeError):
        KERNEL.Shift(ref, 6378137.0, 298.257223563, (1.0, 2.0), 6378388.0, 297.0, None)


# --------------------------------------------------------------------------- other datums
_MM = st.integers(-1_000_000, 1_000_000).map(lambda v: v / 1000.0)      # ±1000 m, to 1 mm
_MAS = st.integers(-30_000, 30_000).map(lambda v: v / 1000.0)           # ±30″, to 1 mas
_PPB = st.integers(-50_000, 50_000).map(lambda v: v / 1000.0)           # ±50 ppm
_ELL = st.sampled_from([(6378388.0, 297.0), (6377563.396, 299.3249646), (6371000.0, 0.0),
                        (6378137.0, 298.257223563), (6378249.145, 293.465)])


@st.composite
def _datums(draw: Any) -> Any:
    """A datum with any Bursa-Wolf (zero or not, rotations and scale included) on an ellipsoid
    of the file's kind or a sphere."""
    from engine.geodesy.ellipsoid import Datum, Ellipsoid

    a, inv_f = draw(_ELL)
    zero = draw(st.booleans())
    p = [0.0] * 7 if zero else [draw(_MM), draw(_MM), draw(_MM), draw(_MAS), draw(_MAS),
                                draw(_MAS), draw(_PPB)]
    return Datum("X", Ellipsoid("E", a, inv_f), *p)


@needs_kernel
@settings(deadline=None, max_examples=60)
@given(src=_datums(), dst=_datums(), lat=_LAT, lon=_LON, h=_H)
def test_any_seven_parameters(src: Any, dst: Any, lat: float, lon: float, h: float) -> None:
    """Datums beyond the file's (three rotations, scale of either sign, spheres): compiled,
    and the reference's numbers."""
    shift = FastDatumShift(src, dst)
    assert type(shift.point) is KERNEL.Shift
    if abs(lat) < 88.9 and abs(abs(lon) - 180.0) > 1e-3:
        assert shift.point.forward(lat, lon, h) is not None
    assert _point(shift, lat, lon, h) == _ref(shift, lat, lon, h)

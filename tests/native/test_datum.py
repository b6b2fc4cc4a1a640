"""The compiled datum shift (engine/native/datum.c) agrees with libproj's (the reference).

``FastDatumShift._point`` (engine.fast) is ``engine.native.datum.Shift`` where the kernel is
built: the textbook formulas for :func:`helmert_pipeline`'s steps, handing what it does not
cover to the PROJ call it was made with (``_ProjPoint.point``, ``DatumShift._proj``). Every
comparison here is to the tolerance contract (tests.tolerance: 1e-9 relative, or 1e-9° and
1e-6 m), against ``_ProjPoint.point`` and pyproj's ``Transformer`` of the same pipeline: on the
points a short demo replay shifts, for every datum pair of data/TO_WGS84.DAT (and WGS84) over
the whole globe (poles, ±180°, heights ±10 km, hypothesis and a fixed sweep), and on the edges
where PROJ clamps, wraps or fails.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import engine.geodesy.ellipsoidal as ellipsoidal
from engine import native
from engine.fast import geodesy as fast_geodesy
from engine.fast.geodesy import FastDatumShift
from engine.geodesy.ellipsoid import WGS84
from engine.geodesy.ellipsoidal import PJ_FWD, DatumShift
from engine.io.datumfile import read_datum_file
from tests.native.replay import replay_patched
from tests.paths import DATA
from tests.tolerance import ATOL_DEFAULT, ATOL_METRES, Near

KERNEL = native.kernel("datum")
needs_kernel = pytest.mark.skipif(KERNEL is None, reason="engine.native.datum not built")
needs_proj = pytest.mark.skipif(ellipsoidal._proj_library() is None,
                                reason="pyproj's libproj cannot be loaded through ctypes")

_FILE = read_datum_file(DATA / "TO_WGS84.DAT")
DATUMS = {**_FILE.datums, "WGS84 (engine)": WGS84}
"""Every datum of the file, and the engine's own WGS84 (what a GPS in WGS84 is shifted from)."""


def _same_steps(a: Any, b: Any) -> bool:
    """True where PROJ drops the whole pipeline: the same ellipsoid and the same Bursa-Wolf on
    both sides (each step followed by its inverse)."""
    return (ellipsoidal._ell_args(a.ellipsoid) == ellipsoidal._ell_args(b.ellipsoid)
            and ellipsoidal._helmert_args(a) == ellipsoidal._helmert_args(b))


PAIRS = [(s, d) for s in DATUMS for d in DATUMS if s != d]
SHIFTS = {pair: FastDatumShift(DATUMS[pair[0]], DATUMS[pair[1]]) for pair in PAIRS}
COMPILED = [pair for pair in PAIRS if not _same_steps(DATUMS[pair[0]], DATUMS[pair[1]])]


def _bits(v: tuple[float, ...]) -> Near:
    """``v`` (lat°, lon°, h m) for a comparison to the tolerance contract (tests.tolerance)."""
    assert all(type(x) is float for x in v)
    return Near(tuple(v), (ATOL_DEFAULT, ATOL_DEFAULT, ATOL_METRES))


def _proj(shift: DatumShift, lat: float, lon: float, h: float) -> tuple[str, ...]:
    """libproj's answer through ``_ProjPoint.point`` (the pure path's call)."""
    return _bits(shift._proj.point(lat, lon, h, None, PJ_FWD, False, False))


def _point(shift: DatumShift, lat: float, lon: float, h: float) -> tuple[str, ...]:
    """What the engine's calls get (``DatumShift._point``, positionally as the kernels call)."""
    return _bits(shift._point(lat, lon, h, None, shift._forward, False, False))


# --------------------------------------------------------------------------- wiring
@needs_kernel
@needs_proj
def test_every_pair_the_engine_builds_is_compiled() -> None:
    """Every datum pair of the file goes through the kernel, except those whose pipeline PROJ
    reduces to a no-op (ED50 and ED50 [DMA]: the same ellipsoid and parameters), which keep the
    PROJ call (the kernel covers the pipeline as written, not PROJ's simplification of it)."""
    kinds = {pair: type(shift._point) is KERNEL.Shift for pair, shift in SHIFTS.items()}
    assert [pair for pair, compiled in kinds.items() if compiled] == COMPILED
    assert len(COMPILED) >= 230
    for pair in set(PAIRS) - set(COMPILED):
        shift = SHIFTS[pair]
        assert shift._point == shift._proj.point
        assert shift._proj.definition() == "proj=noop ellps=GRS80"
    for pair in COMPILED:
        shift = SHIFTS[pair]
        assert shift._point.fallback == shift._proj.point
        assert shift._proj.definition() == " ".join(
            w.lstrip("+") for w in shift.pipeline.split())


@needs_proj
def test_pure_path(monkeypatch: pytest.MonkeyPatch) -> None:
    """The reference, or no kernel: the PROJ call itself."""
    src, dst = _FILE.datum("ED50"), WGS84
    compiled = FastDatumShift(dst, src)
    pure = DatumShift(dst, src)
    assert pure._point == pure._proj.point
    monkeypatch.setattr(fast_geodesy, "DATUM", None)
    missing = FastDatumShift(dst, src)
    assert missing._point == missing._proj.point
    for q in fast_geodesy.SHIFT_PROBES + ((52.1234, 3.4567, 0.0), (-0.0, -0.0, -0.0)):
        assert _point(pure, *q) == _point(missing, *q) == _point(compiled, *q)
        assert _bits(pure.transform(*q)) == _bits(compiled.transform(*q))


@needs_kernel
@needs_proj
def test_a_probe_mismatch_keeps_proj(monkeypatch: pytest.MonkeyPatch) -> None:
    """A kernel that does not agree with libproj on the probe points (here: one 2e-6 m off in
    height) is not used; one that declines a probe point (NaN) still is."""
    real = fast_geodesy.DATUM

    class Off:
        def __init__(self, *args: Any) -> None:
            self.shift = real.Shift(*args)

        def forward(self, *q: float) -> Any:
            got = self.shift.forward(*q)
            return None if got is None else (got[0], got[1], got[2] + 2e-6)

    monkeypatch.setattr(fast_geodesy, "SHIFT_PROBES", ((52.0, 3.0, 0.0), (math.nan, 0.0, 0.0)))
    shift = FastDatumShift(WGS84, _FILE.datum("ED50"))
    assert type(shift._point) is real.Shift
    monkeypatch.setattr(fast_geodesy, "DATUM", type("M", (), {"Shift": Off}))
    shift = FastDatumShift(WGS84, _FILE.datum("ED50"))
    assert shift._point == shift._proj.point


# --------------------------------------------------------------------------- a replay
@pytest.fixture(scope="module")
def replayed() -> list[tuple[DatumShift, Any, tuple[Any, ...]]]:
    """(shift, its point call, the call's arguments) of every datum shift of the first 150 demo
    epochs (the tmgrid kernel's gps_input and the Python both call ``DatumShift._point``)."""
    seen: list[tuple[DatumShift, Any, tuple[Any, ...]]] = []
    real_init = FastDatumShift.__init__

    def init(self: DatumShift, src: Any, dst: Any) -> None:
        real_init(self, src, dst)
        point = self._point

        def record(*args: Any) -> Any:
            seen.append((self, point, args))
            return point(*args)

        self._point = record

    replay_patched([(FastDatumShift, "__init__", init)], 150)
    return seen


@needs_kernel
@needs_proj
def test_the_replay_s_points(replayed: list[tuple[DatumShift, Any, tuple[Any, ...]]]) -> None:
    """The replay's shifts: compiled, never declined, libproj's bits."""
    assert len(replayed) >= 140
    for shift, point, args in replayed:
        assert type(point) is KERNEL.Shift
        assert len(args) == 7 and args[3:] == (None, PJ_FWD, False, False)
        lat, lon, h = args[:3]
        assert type(lat) is float and type(lon) is float and type(h) is float
        got = point.forward(lat, lon, h)
        assert got is not None
        assert _bits(got) == _bits(point(*args)) == _proj(shift, lat, lon, h)


# --------------------------------------------------------------------------- the globe
_LAT = st.floats(-90.0, 90.0) | st.sampled_from([90.0, -90.0, 0.0, -0.0, 89.9999999, -89.99999])
_LON = st.floats(-180.0, 180.0) | st.sampled_from([180.0, -180.0, 0.0, -0.0, 179.9999999])
_H = st.floats(-10_000.0, 10_000.0) | st.sampled_from([0.0, -0.0, 10_000.0, -10_000.0])


@needs_kernel
@needs_proj
@settings(deadline=None, max_examples=600)
@given(k=st.integers(0, 10_000), lat=_LAT, lon=_LON, h=_H)
def test_anywhere_on_the_globe(k: int, lat: float, lon: float, h: float) -> None:
    """Any compiled pair, any latitude, longitude and height: the kernel computes (it declines
    only within 1° of a pole and on the antimeridian, where PROJ answers) and agrees with
    libproj."""
    shift = SHIFTS[COMPILED[k % len(COMPILED)]]
    got = shift._point.forward(lat, lon, h)
    if abs(lat) < 88.9 and abs(abs(lon) - 180.0) > 1e-3:
        assert got is not None
    if got is not None:
        assert _bits(got) == _proj(shift, lat, lon, h)
    assert _point(shift, lat, lon, h) == _proj(shift, lat, lon, h)


@needs_kernel
@needs_proj
def test_every_pair_on_a_fixed_sweep() -> None:
    """Every compiled pair on 120 points (a fixed seed, the whole globe, ±10 km) through the
    kernel, through ``_ProjPoint`` and through pyproj's Transformer (arrays: its proj_trans per
    point)."""
    rng = np.random.default_rng(14)
    lat = rng.uniform(-90.0, 90.0, 120)
    lon = rng.uniform(-180.0, 180.0, 120)
    h = rng.uniform(-10_000.0, 10_000.0, 120)
    lat[:6] = [90.0, -90.0, 0.0, 45.0, -45.0, 89.99999999]
    lon[:6] = [180.0, -180.0, 0.0, 179.99999999, -179.99999999, 33.0]
    h[:6] = [0.0, 10_000.0, -10_000.0, 0.0, 1.0, -1.0]
    for pair in COMPILED:
        shift = SHIFTS[pair]
        tlat, tlon, th = shift._tr.transform(lat, lon, h)
        for i in range(lat.size):
            q = (float(lat[i]), float(lon[i]), float(h[i]))
            want = _bits((float(tlat[i]), float(tlon[i]), float(th[i])))
            assert _point(shift, *q) == _proj(shift, *q) == want, (pair, q)


# --------------------------------------------------------------------------- the edges
EDGES: list[tuple[float, float, float]] = [
    (90.0 + 5e-11, 10.0, 0.0),     # beyond the pole by < PJ_EPS_LAT rad: clamped to 90°
    (-90.0 - 5e-11, -10.0, 5.0),
    (90.0 + 1e-6, 0.0, 0.0),       # beyond by more: PROJ's error (HUGE_VAL)
    (45.0, 540.0, 0.0),            # 9.4 rad: adjlon
    (45.0, -559.0, 100.0),
    (45.0, 600.0, 0.0),            # > 10 rad: PROJ's error
    (0.0, 180.0 + 1e-10, 0.0),
    (-0.0, -0.0, -0.0),
    (math.nan, 3.0, 0.0), (52.0, math.inf, 0.0), (52.0, 3.0, -math.inf), (52.0, 3.0, math.nan),
    (52.0, 3.0, 6.3e6),            # far below the surface: near the centre of the Earth
    (52.0, 3.0, -6.36e6), (0.0, 0.0, -6.378e6), (89.0, 0.0, -6.35e6),
    (1e-300, -1e-300, 1e-300), (5e-324, 5e-324, 0.0),
]


@needs_kernel
@needs_proj
@pytest.mark.parametrize("pair", COMPILED[:: max(1, len(COMPILED) // 12)] + [
    ("WGS84 (engine)", "ED50"), ("ED50", "WGS84 (engine)"), ("WGS72 [DMA]", "OSGB 1936")])
def test_edges(pair: tuple[str, str]) -> None:
    """Clamped and wrapped inputs, PROJ's errors, non-finite values, points deep inside the
    Earth: the kernel's answer or (where it declines) the PROJ call's, libproj's bits."""
    shift = SHIFTS[pair]
    for q in EDGES:
        assert _point(shift, *q) == _proj(shift, *q), (pair, q)
        got = shift._point.forward(*q)
        if got is not None:
            assert _bits(got) == _proj(shift, *q)
        if not all(map(math.isfinite, q)):
            assert got is None


@needs_kernel
@needs_proj
def test_other_calls_go_to_proj() -> None:
    """Other directions and argument kinds, keywords: the PROJ call's answer (or its error)."""
    shift = SHIFTS[("WGS84 (engine)", "ED50")]
    point, proj = shift._point, shift._proj.point

    def outcome(fn: Callable[..., Any], *args: Any, **kw: Any) -> Any:
        try:
            return _bits(fn(*args, **kw))
        except Exception as exc:  # noqa: BLE001 - the exception is the outcome compared
            return type(exc), str(exc)

    for args in [(52.0, 3.0, 0.0, None, -1, False, False),  # PJ_INV
                 (52.0, 3.0, 0.0, None, 0, False, False),   # PJ_IDENT
                 (52, 3, 0, None, 1, False, False),         # ints
                 (52.0, 3.0, 0.0, 2000.0, 1, False, False),
                 (52.0, 3.0, 0.0, None, 1, True, False),
                 (52.0, 3.0, 0.0, None, 1 << 70, False, False),
                 (52.0, 3.0, 0.0, None, 1.0, False, False),
                 (52.0, 3.0, 0.0, None, 1, False),
                 ("52", 3.0, 0.0, None, 1, False, False)]:
        assert outcome(point, *args) == outcome(proj, *args), args
    assert outcome(point, 52.0, 3.0, 0.0, None, 1, False, errcheck=False) == outcome(
        proj, 52.0, 3.0, 0.0, None, 1, False, errcheck=False)
    assert _bits(shift.transform(52, 3, 0)) == _bits(shift.transform(52.0, 3.0, 0.0))
    with pytest.raises(TypeError):
        KERNEL.Shift(None, 6378137.0, 298.257223563, None, 6378388.0, 297.0, None)
    with pytest.raises(ValueError):
        KERNEL.Shift(proj, -1.0, 298.257223563, None, 6378388.0, 297.0, None)
    with pytest.raises(TypeError):
        KERNEL.Shift(proj, 6378137.0, 298.257223563, (1.0, 2.0), 6378388.0, 297.0, None)


# --------------------------------------------------------------------------- other datums
_MM = st.integers(-1_000_000, 1_000_000).map(lambda v: v / 1000.0)      # ±1000 m, to 1 mm
_MAS = st.integers(-30_000, 30_000).map(lambda v: v / 1000.0)           # ±30″, to 1 mas
_PPB = st.integers(-50_000, 50_000).map(lambda v: v / 1000.0)           # ±50 ppm
_ELL = st.sampled_from([(6378388.0, 297.0), (6377563.396, 299.3249646), (6371000.0, 0.0),
                        (6378137.0, 298.257223563), (6378249.145, 293.465)])


@st.composite
def _datums(draw: Any) -> Any:
    """A datum with any Bursa-Wolf (zero or not, rotations and scale included) on an ellipsoid
    of the file's kind or a sphere (``+b=a``)."""
    from engine.geodesy.ellipsoid import Datum, Ellipsoid

    a, inv_f = draw(_ELL)
    zero = draw(st.booleans())
    p = [0.0] * 7 if zero else [draw(_MM), draw(_MM), draw(_MM), draw(_MAS), draw(_MAS),
                                draw(_MAS), draw(_PPB)]
    return Datum("X", Ellipsoid("E", a, inv_f), *p)


@needs_kernel
@needs_proj
@settings(deadline=None, max_examples=60)
@given(src=_datums(), dst=_datums(), lat=_LAT, lon=_LON, h=_H)
def test_any_seven_parameters(src: Any, dst: Any, lat: float, lon: float, h: float) -> None:
    """Datums beyond the file's (three rotations, scale of either sign, spheres): compiled
    wherever PROJ runs the pipeline as written, and libproj's bits."""
    shift = FastDatumShift(src, dst)
    written = " ".join(w.lstrip("+") for w in shift.pipeline.split())
    assert (type(shift._point) is KERNEL.Shift) == (shift._proj.definition() == written)
    if type(shift._point) is KERNEL.Shift and abs(lat) < 88.9 and abs(abs(lon) - 180.0) > 1e-3:
        assert shift._point.forward(lat, lon, h) is not None
    assert _point(shift, lat, lon, h) == _proj(shift, lat, lon, h)

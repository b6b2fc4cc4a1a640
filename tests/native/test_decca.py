"""The compiled Decca kernel (engine/native/decca.c), as engine.fast calls it, agrees with the
reference.

The reference is engine.systems.decca (``decca_geometry``, ``DeccaObservations.linearise``,
``_LaneAt``, ``decca_totals``) and ``GeodesicSolver``'s azimuths; the
compiled path is engine.fast.decca and engine.fast.geodesy. Every float is compared to the
tolerance contract (tests.tolerance: ``hexes`` makes a ``Near``) on the values a short demo
replay really produces and on hypothesis-generated points around them, and the kernel's own
geodesic is compared with pyproj's on points all over the ellipsoid.
"""

from __future__ import annotations

import dataclasses
import math
from datetime import timedelta
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from hypothesis import assume, event, example, given, settings
from hypothesis import strategies as st

import engine.systems.decca as decca
from engine import native
from engine.fast import decca as fast_decca
from engine.fast.decca import FastDeccaObservations
from engine.fast.geodesy import FastGeodesicSolver, FastTMGrid
from engine.geodesy.ellipsoidal import GeodesicSolver
from engine.io.datumfile import read_datum_file
from engine.io.deccafile import read_chain_file
from engine.systems.base import Point
from tests.native.replay import replay_patched
from tests.paths import DATA
from tests.tolerance import Near

K = native.kernel("decca")
pytestmark = pytest.mark.skipif(K is None, reason=f"decca kernel: {native.status('decca')}")

ED50 = read_datum_file(DATA / "TO_WGS84.DAT").datum("ED50")
GRID = FastTMGrid(ED50.ellipsoid, 5.0)
PLACED = decca.place_chain(read_chain_file(DATA / "DECCA.CHN")["9B"], GRID)
SC = PLACED._scalars
MX, MY = SC.xy[0]


def solvers() -> tuple[GeodesicSolver, GeodesicSolver]:
    """(compiled, pure) solvers on the demo's ellipsoid."""
    fast = FastGeodesicSolver(ED50.ellipsoid)
    pure = GeodesicSolver(ED50.ellipsoid)
    assert fast.native() is not None
    return fast, pure


FAST, PURE = (None, None) if K is None else solvers()


def hexes(v: Any) -> Any:
    """``v`` for a comparison to the tolerance contract (nested lists/tuples of floats, arrays,
    None; a number as a float)."""
    if isinstance(v, (list, tuple)):
        return [hexes(x) for x in v]
    if isinstance(v, np.ndarray) or v is None:
        return Near(v)
    return Near(float(v))


def far_from_stations(x: float, y: float, metres: float = 1e4) -> bool:
    """(x, y) (grid m) at least ``metres`` from every station of the chain: nearer, the
    azimuth to a station is ill-conditioned (a 1 m line's azimuth moves by 1e-8° for a last-bit
    change of its ends), so the two paths' azimuths, LEFs and VCVs differ by more than 1e-9
    relative while both are right."""
    return all(math.hypot(x - sx, y - sy) >= metres for sx, sy in SC.xy)


def directions(v: Any, unit: float = 1.0) -> Near:
    """Azimuths (``unit``: 1 for degrees, 180/π for radians) as unit vectors, for comparing
    to the contract across 0/360°."""
    return Near([(math.cos(math.radians(a * unit)), math.sin(math.radians(a * unit)))
                 for a in v])


class _Pure:
    """Context of a reference call (the reference has no kernel to switch off)."""

    def __enter__(self) -> None:
        pass

    def __exit__(self, *exc: object) -> None:
        pass


def _kernel_sigma(row: Any, cov: Any) -> Any:
    """``K.lane_sigma`` (numpy's dgemv/ddot bound), the reference where it declines."""
    r = fast_decca.lane_sigma_kernel()(row, cov)
    return decca.lane_sigma(row, cov) if r is NotImplemented else r


def outcome(f: Any, *args: Any) -> Any:
    """(the result, compared to the contract) or (exception type, message)."""
    try:
        return ("ok", hexes(f(*args)))
    except Exception as exc:  # noqa: BLE001 - both paths must raise alike
        return (type(exc).__name__, str(exc))


# --------------------------------------------------------------------------- a short replay


@pytest.fixture(scope="module")
def replay_values() -> dict[str, list[Any]]:
    """Arguments of the Decca work in the first 120 demo epochs (linearise, _LaneAt._lanes)."""
    got: dict[str, list[Any]] = {"lin": [], "lanes": [], "totals": []}
    orig_lin = FastDeccaObservations.linearise
    orig_lanes = decca._LaneAt._lanes
    orig_totals = decca.decca_totals

    def totals(*args: Any) -> Any:
        got["totals"].append(args)
        return orig_totals(*args)

    def lin(self: Any, p: Point, slot0: int, A: list[float], b: list[float], Cl: Any) -> None:
        got["lin"].append((self, p.x, p.y, p.latlon, slot0, len(A), len(b), Cl.shape))
        return orig_lin(self, p, slot0, A, b, Cl)

    def lanes(self: Any, src: Any) -> Any:
        got["lanes"].append((self.placed, src))
        return orig_lanes(self, src)

    replay_patched([(FastDeccaObservations, "linearise", lin),
                    (decca._LaneAt, "_lanes", lanes),
                    (decca, "decca_totals", totals),
                    # every record through decca_totals, recorded
                    (fast_decca, "tracked_totals", lambda *a: None)], 120)
    assert len(got["lin"]) > 100 and len(got["lanes"]) > 100
    return got


def _linearise_both(obs: decca.DeccaObservations, x: float, y: float,
                    latlon: tuple[float, float], slot0: int, na: int, nb: int,
                    shape: tuple[int, int]) -> tuple[Any, Any]:
    out = []
    for solver, pure in ((FAST, False), (PURE, True)):
        A = [0.25] * na
        b = [0.5] * nb
        Cl = np.full(shape, 0.75)
        p = Point(obs.reading.placed.grid, solver, x, y, latlon)  # type: ignore[arg-type]
        if pure:
            r = outcome(decca.DeccaObservations.linearise, obs, p, slot0, A, b, Cl)
        else:
            r = outcome(obs.linearise, p, slot0, A, b, Cl)
        out.append((r, hexes(A), hexes(b), hexes(Cl)))
    return out[0], out[1]


def test_linearise_on_the_replay(replay_values: dict[str, list[Any]]) -> None:
    for obs, x, y, latlon, slot0, na, nb, shape in replay_values["lin"]:
        fast, pure = _linearise_both(obs, x, y, latlon, slot0, na, nb, shape)
        assert fast == pure


def test_geometry_on_the_replay(replay_values: dict[str, list[Any]]) -> None:
    for obs, x, y, (lat, lon), *_ in replay_values["lin"]:
        placed = obs.reading.placed
        sc = placed._scalars
        g = fast_decca.decca_geometry(placed, x, y, FAST, (lat, lon))
        with _Pure():
            h = decca.decca_geometry(placed, x, y, PURE, (lat, lon))
        for name in decca.DeccaGeometry.__slots__:
            assert hexes(getattr(g, name)) == hexes(getattr(h, name)), name
        az = FAST.forward_azimuths_rad(lat, lon, sc.latlon)
        assert hexes(az) == hexes(PURE.forward_azimuths_rad(lat, lon, sc.latlon))


def test_lanes_on_the_replay(replay_values: dict[str, list[Any]]) -> None:
    for placed, src in replay_values["lanes"]:
        for i in range(3):
            got = decca._LaneAt(placed, FAST)(src, i)
            with _Pure():
                want = decca._LaneAt(placed, PURE)(src, i)
            assert hexes(got) == hexes(want)


def test_lane_totals_on_the_replay(replay_values: dict[str, list[Any]]) -> None:
    """decca_totals (the GPS lane check, _LaneAt, lane_sigma) as the replay called it."""
    assert len(replay_values["totals"]) > 100
    for placed, _geodesic, *rest in replay_values["totals"]:
        got = decca.decca_totals(placed, FAST, *rest)
        with _Pure():
            want = decca.decca_totals(placed, PURE, *rest)
        assert hexes(got.totals) == hexes(want.totals)
        assert (got.track, got.notes, got.slips) == (want.track, want.notes, want.slips)


def _tracked_is_python(placed: Any, zone_lane: Any, track: Any, fractions: Any, time: Any,
                       x_start: Any, position: Any, gps: Any,
                       rule: Any = decca.LANE_RULE) -> bool:
    """decca._tracked_totals (the kernel's ``tracked``) against the pure decca_totals of the
    same record: the same LaneTotals to the bit, or None. Returns whether the kernel took it."""
    fix = None
    if gps is not None:
        var = float(gps.cov[0, 0])
        assert hexes(gps.cov) == hexes(np.eye(2) * var)  # the VCV the kernel forms
        fix = SimpleNamespace(x_m=gps.x_m, y_m=gps.y_m, corr_east_m=0.0, corr_north_m=0.0,
                              var_m2=var)
    got = fast_decca.tracked_totals(placed, FAST, track, fractions, time, fix)
    with _Pure():
        try:
            want = decca.decca_totals(placed, PURE, zone_lane, track, fractions, time, x_start,
                                      position, gps, rule)
        except (ValueError, ArithmeticError):  # a NaN or infinite track: math.floor raises
            assert got is None
            return False
    if got is None:
        return False
    assert type(got) is decca.LaneTotals and not hasattr(got, "__dict__")
    for f in dataclasses.fields(decca.LaneTotals):  # every slot set (else AttributeError)
        getattr(got, f.name), getattr(want, f.name)
    assert hexes(got.totals) == hexes(want.totals)
    assert [None if t is None else (hexes(t[0]), t[1]) for t in got.track] == [
        None if t is None else (hexes(t[0]), t[1]) for t in want.track]
    assert (got.notes, got.slips, type(got.slips)) == (want.notes, want.slips, int)
    return True


def test_tracked_totals_on_the_replay(replay_values: dict[str, list[Any]]) -> None:
    """The compiled tracking takes the usual record (tracked patterns, GPS agreeing) and gives
    decca_totals' LaneTotals; the first records (zone/lane) stay with the Python."""
    taken = 0
    for placed, _geodesic, *rest in replay_values["totals"]:
        taken += _tracked_is_python(placed, *rest)
    assert taken > 100


@settings(max_examples=300, deadline=None)
@given(k=st.integers(0, 10_000), slip=st.tuples(*[st.sampled_from(
           [0.0, 0.0, 1.0, -1.0, 0.4, 0.5, -0.5, 0.6, 2.0, 1e-9, math.nan, math.inf])] * 3),
       gap=st.sampled_from([0.0, 0.0, 1.0, 29.0, 30.0, 30.5, 300.0, -5.0]),
       drop=st.tuples(st.booleans(), st.booleans(), st.booleans()),
       first=st.tuples(st.booleans(), st.booleans(), st.booleans()),
       var=st.sampled_from([None, 1.0, 1225.0, 1e4, 1e8, 0.0, -1.0, math.inf, math.nan]),
       off=st.tuples(st.floats(-3e3, 3e3), st.floats(-3e3, 3e3)))
def test_tracked_totals_anywhere(replay_values: dict[str, list[Any]], k: int,
                                 slip: tuple[float, ...], gap: float,
                                 drop: tuple[bool, ...], first: tuple[bool, ...],
                                 var: float | None, off: tuple[float, float]) -> None:
    """Around the replay's records: tracks off by lanes (slips, NaN, inf), gaps, patterns
    without a reading or without a track, other GPS variances and positions, no GPS: the
    kernel gives decca_totals' LaneTotals or declines; it declines every slip, gap and first
    reading."""
    calls = replay_values["totals"]
    call = calls[k % len(calls)]  # the rule, where the caller passed one
    placed, _g, zone_lane, track, fractions, time, x_start, position, gps = call[:9]
    rule = call[9] if len(call) > 9 else decca.LANE_RULE
    if track[0] is None:
        return
    track = tuple(None if t is None or f else (t[0] + s, t[1] - timedelta(seconds=gap))
                  for t, s, f in zip(track, slip, first, strict=True))
    fractions = tuple(None if d else f for f, d in zip(fractions, drop, strict=True))
    if var is None:
        gps = None
    elif gps is not None:
        gps = decca.LaneSource("GPS", gps.x_m + off[0], gps.y_m + off[1], np.eye(2) * var)
    took = _tracked_is_python(placed, zone_lane, track, fractions, time, x_start, position, gps,
                              rule)
    event(f"kernel took it: {took}")
    read = [f is not None for f in fractions]
    if took:
        assert not any(r and (t is None or gap > 30.0) for r, t in zip(read, track, strict=True))


# --------------------------------------------------------------------------- around them

_OFFSET = st.floats(-3e5, 3e5, allow_nan=False)


@settings(max_examples=250, deadline=None)
@given(dx=_OFFSET, dy=_OFFSET, cf=st.sampled_from([64.0, 4.0, 1.0, 1 / 2.25, 0.0]),
       slot0=st.integers(0, 3), have=st.tuples(st.booleans(), st.booleans(), st.booleans()),
       obs=st.floats(-1e3, 1e3))
def test_linearise_anywhere(dx: float, dy: float, cf: float, slot0: int,
                            have: tuple[bool, bool, bool], obs: float) -> None:
    x, y = MX + dx, MY + dy
    assume(far_from_stations(x, y))
    reading = decca.DeccaReading(PLACED, (0.1, 0.2, 0.3), (None, None, None), (True,) * 3,
                                 cf=cf)
    observed = [obs + i if h else math.nan for i, h in enumerate(have)]
    o = FastDeccaObservations(reading, observed, [None] * 3, list(have), [])
    fast, pure = _linearise_both(o, x, y, GRID.inverse(x, y), slot0, 2 * (slot0 + 3),
                                 slot0 + 3, (slot0 + 3, slot0 + 3))
    assert fast == pure


@settings(max_examples=250, deadline=None)
@given(dx=_OFFSET, dy=_OFFSET)
def test_geometry_anywhere(dx: float, dy: float) -> None:
    x, y = MX + dx, MY + dy
    lat, lon = GRID.inverse(x, y)
    g = outcome(fast_decca.decca_geometry, PLACED, x, y, FAST, (lat, lon))
    with _Pure():
        h = outcome(decca.decca_geometry, PLACED, x, y, PURE, (lat, lon))
    assert g == h


@pytest.mark.parametrize("station", range(4))
def test_at_a_station_both_raise_alike(station: int) -> None:
    """On a station the chord is 0: ZeroDivisionError from both paths (caught as None by
    _LaneAt)."""
    x, y = SC.xy[station]
    lat, lon = GRID.inverse(x, y)
    with _Pure():
        pure = outcome(decca.decca_geometry, PLACED, x, y, PURE, (lat, lon))
    assert outcome(fast_decca.decca_geometry, PLACED, x, y, FAST, (lat, lon)) == pure


def _lef_skip_holds(x: float, y: float) -> bool:
    """Where the kernel's tracked totals skip the LEF's geodesics (``_lef_certain``), the
    azimuths of master and every slave are more than 0.015 rad apart (half its margin: the LEF
    cannot raise). Returns whether it skipped."""
    lat, lon = GRID.inverse(x, y)
    certain = K._lef_certain(SC, FAST.native(), x, y, lat, lon)
    if certain:
        az = FAST.forward_azimuths_rad(lat, lon, SC.latlon)
        for s in (1, 2, 3):
            gamma = abs(az[s] - az[0]) % (2 * math.pi)
            assert min(gamma, 2 * math.pi - gamma) > 0.015
    return bool(certain)


@settings(max_examples=300, deadline=None)
@given(dx=st.floats(-6e5, 6e5), dy=st.floats(-1.2e6, 1.2e6))
def test_lanes_skip_the_lef_only_where_it_cannot_raise(dx: float, dy: float) -> None:
    _lef_skip_holds(MX + dx, MY + dy)


def test_lanes_near_the_baseline_extensions() -> None:
    """On and beside the extensions of every baseline (γ → 0, where the LEF would raise) the
    geodesics are computed; elsewhere they are skipped."""
    skipped = computed = 0
    for s in (1, 2, 3):
        (mx, my), (sx, sy) = SC.xy[0], SC.xy[s]
        for t in (-3.0, -1.5, -1.0, -0.5, -0.1, -0.01, 1.01, 1.1, 1.5, 2.0, 3.0, 0.5):
            for off in (0.0, 1.0, 100.0, 1e3, 5e3, 2e4):
                x = mx + t * (sx - mx) - off * (sy - my) / 1e5
                y = my + t * (sy - my) + off * (sx - mx) / 1e5
                if _lef_skip_holds(x, y):
                    skipped += 1
                else:
                    computed += 1
    assert skipped > 20 and computed > 20


@settings(max_examples=200, deadline=None)
@given(dm=st.floats(0.0, 1e7), ds=st.tuples(*[st.floats(0.0, 1e7)] * 3),
       cf=st.sampled_from([64.0, 4.0, 1.0, 1 / 2.25]), k=st.tuples(*[st.floats(1.0, 1e4)] * 3))
def test_vcv_anywhere(dm: float, ds: tuple[float, float, float], cf: float,
                      k: tuple[float, float, float]) -> None:
    want = decca._vcv_m2(decca._vcv_core(dm, list(ds), SC.baseline_sky, cf), k)
    assert hexes(K.vcv_m2(dm, ds, SC.baseline_sky, cf, k)) == hexes(want)


_ROW = st.floats(-1e-1, 1e-1) | st.sampled_from([0.0, -0.0, 1e-300, math.nan, math.inf])


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # numpy's FPE note on inf·0 (not C's)
@settings(max_examples=200, deadline=None)
@given(row=st.tuples(_ROW, _ROW), c=st.tuples(*[st.floats(-1e6, 1e6)] * 4),
       sym=st.booleans(), pick=st.integers(0, 2))
def test_lane_sigma_anywhere(row: tuple[float, float], c: tuple[float, ...], sym: bool,
                             pick: int) -> None:
    """numpy's matmul (dgemv, then 0.0 + ddot) called from C: the same bits, for symmetric and
    general 2×2 matrices and a row that is a view into a 3×2 array (as _LaneAt passes it)."""
    rows = np.zeros((3, 2))
    rows[pick] = row
    cov = np.array([[c[0], c[1]], [c[1] if sym else c[2], c[3]]])
    r = rows[pick]
    with _Pure():
        want = outcome(decca.lane_sigma, r, cov)
    assert outcome(_kernel_sigma, r, cov) == want
    assert fast_decca.lane_sigma_kernel() is not None


def test_lane_sigma_of_other_types_is_numpys() -> None:
    for row, cov in (([1e-3, 2e-3], [[4.0, 1.0], [1.0, 9.0]]),
                     (np.array([1e-3, 2e-3], dtype=np.float32), np.eye(2)),
                     (np.array([1e-3, 2e-3, 0.0])[::2], np.eye(2)),
                     (np.array([1e-3, 2e-3]), np.asfortranarray([[4.0, 1.0], [2.0, 9.0]]))):
        with _Pure():
            want = outcome(decca.lane_sigma, row, cov)
        assert outcome(_kernel_sigma, row, cov) == want


def test_sync_constants_are_pythons() -> None:
    assert hexes(K._sync_sq()) == hexes([decca._SYNC0_2, decca._SYNC1_2, decca._SYNC2_2])


# --------------------------------------------------------------------------- pyproj's geodesic

_LAT = st.floats(-90.0, 90.0)
_LON = st.floats(-540.0, 540.0)


@settings(max_examples=500, deadline=None)
@given(lat1=_LAT, lon1=_LON, lat2=_LAT, lon2=_LON)
@example(lat1=1.0, lon1=360.0, lat2=0.0, lon2=1.401298464324817e-45)  # -180° against 180°
def test_geod_inverse_is_pyprojs(lat1: float, lon1: float, lat2: float, lon2: float) -> None:
    g = FAST.native()
    want = FAST._geod.inv(lon1, lat1, lon2, lat2, return_back_azimuth=False)
    got = g.inverse_point(lon1, lat1, lon2, lat2)
    # Azimuths are directions: on a meridian the sign of a zero longitude difference (a
    # denormal against 360°) makes one side say -180° and the other 180°, the same direction.
    assert directions(got[:2]) == directions(want[:2])
    assert hexes(got[2]) == hexes(want[2])
    pts = [(lat2, lon2), (lat1, lon2)]
    assert directions(FAST.forward_azimuths_deg(lat1, lon1, pts)) == directions(
        PURE.forward_azimuths_deg(lat1, lon1, pts))
    assert directions(FAST.forward_azimuths_rad(lat1, lon1, pts), 180 / math.pi) == directions(
        PURE.forward_azimuths_rad(lat1, lon1, pts), 180 / math.pi)


def test_geod_on_a_grid_of_points_and_other_ellipsoids() -> None:
    rng = np.random.default_rng(14)
    spheroids = read_datum_file(DATA / "TO_WGS84.DAT").spheroids.values()
    assert len(spheroids) > 3
    for ell in spheroids:
        s = FastGeodesicSolver(ell)
        g = s.native()
        assert g is not None and (g.a, g.f) == (s._geod.a, s._geod.f)
        pts = rng.uniform([-90, -180, -90, -180], [90, 180, 90, 180], (1000, 4)).tolist()
        for lat1, lon1, lat2, lon2 in pts:
            assert hexes(g.inverse_point(lon1, lat1, lon2, lat2)) == hexes(
                s._geod.inv(lon1, lat1, lon2, lat2, return_back_azimuth=False))


def test_geod_argument_types_as_pyproj() -> None:
    g = FAST.native()
    assert hexes(g.forward_azimuths_deg(52, 4, [(53, 5)])) == hexes(
        PURE.forward_azimuths_deg(52, 4, [(53, 5)]))
    for bad in (None, object()):  # not a number (pyproj's public inv converts "52")
        with pytest.raises(TypeError):
            FAST.forward_azimuths_rad(bad, 4.0, [(53.0, 5.0)])
        with pytest.raises(TypeError):
            PURE.forward_azimuths_rad(bad, 4.0, [(53.0, 5.0)])
    assert FAST.forward_azimuths_rad("x", 4.0, []) == PURE.forward_azimuths_rad("x", 4.0, []) == []


# --------------------------------------------------------------------------- the pure path


def test_pure_env_takes_the_python(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(native.PURE_ENV, "1")
    assert native.kernel("decca") is None
    from engine.fast import geodesy

    monkeypatch.setattr(geodesy, "DECCA", None)
    s = geodesy.FastGeodesicSolver(ED50.ellipsoid)
    assert s.native() is None
    lat, lon = GRID.inverse(MX + 1e4, MY - 2e4)
    assert hexes(s.forward_azimuths_rad(lat, lon, SC.latlon)) == hexes(
        FAST.forward_azimuths_rad(lat, lon, SC.latlon))


def test_kernel_none_takes_the_python(monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[str] = []
    real = decca._lane_model
    monkeypatch.setattr(fast_decca, "KERNEL", None)
    monkeypatch.setattr(decca, "_lane_model",
                        lambda *a: calls.append("lane") or real(*a))  # type: ignore[func-returns-value]
    x, y = MX + 5e4, MY + 5e4
    g = fast_decca.decca_geometry(PLACED, x, y, FAST)
    assert calls == ["lane"] and np.isfinite(g.n_calc).all()


def test_not_the_fast_path_types_fall_back() -> None:
    """Arguments the kernel does not take (ints, numpy scalars, other containers) give
    NotImplemented, and the wrappers run the Python."""
    lat, _lon = GRID.inverse(MX, MY + 1e4)
    got = fast_decca.decca_geometry(PLACED, np.float64(MX), MY + 1e4, FAST)
    want = decca.decca_geometry(PLACED, np.float64(MX), MY + 1e4, PURE)
    for name in decca.DeccaGeometry.__slots__:
        assert hexes(getattr(got, name)) == hexes(getattr(want, name)), name


def test_a_solver_pickles_and_copies() -> None:
    """The compiled geodesic is not pickled: a copy resolves its own."""
    import copy
    import pickle

    for twin in (pickle.loads(pickle.dumps(FAST)), copy.deepcopy(FAST)):
        assert twin.ellipsoid == FAST.ellipsoid
        lat, lon = GRID.inverse(MX + 3e4, MY)
        assert hexes(twin.forward_azimuths_rad(lat, lon, SC.latlon)) == hexes(
            PURE.forward_azimuths_rad(lat, lon, SC.latlon))


def test_geodesic_probe_compares_with_the_reference(monkeypatch: pytest.MonkeyPatch) -> None:
    """The compiled geodesic is used only where its azimuths on the probe lines agree with the
    reference solver's (pyproj's public ``Geod.inv``) within the tolerance contract (1e-9
    relative: ≤ 1.8e-7° for an azimuth, ≤ 1e-3 m for the probe lines' distances): a reference
    1e-6° off in the forward azimuth, or 1 cm off in distance, turns it down. An ellipsoid
    without recorded values (Bessel 1841) is checked against the solver itself; a recorded one
    (ED50's International 1924) against :data:`GEOD_VERIFIED`."""
    from engine.fast import geodesy
    from engine.geodesy.ellipsoid import Ellipsoid

    bessel = Ellipsoid("BESSEL 1841", 6377397.155, 299.1528128)
    assert (bessel.a_m, bessel.f) not in geodesy.GEOD_VERIFIED
    key = (float(ED50.ellipsoid.a_m), float(ED50.ellipsoid.f))
    recorded = geodesy.GEOD_VERIFIED[key]
    for ell in (ED50.ellipsoid, bessel):
        assert geodesy.FastGeodesicSolver(ell).native() is not None
    real = GeodesicSolver.inverse
    for i, off in ((0, 1e-6), (2, 1e-2)):
        def shifted(self: GeodesicSolver, *q: float, i: int = i, off: float = off) -> Any:
            out = list(real(self, *q))
            out[i] += off
            return tuple(out)

        with monkeypatch.context() as m:
            m.setattr(GeodesicSolver, "inverse", shifted)
            assert geodesy.FastGeodesicSolver(bessel).native() is None
        rows = [list(r) for r in recorded]
        rows[1][i] += off
        with monkeypatch.context() as m:
            m.setitem(geodesy.GEOD_VERIFIED, key, tuple(tuple(r) for r in rows))
            assert geodesy.FastGeodesicSolver(ED50.ellipsoid).native() is None


def test_recorded_geodesics_are_the_reference() -> None:
    """GEOD_VERIFIED holds what the reference solver (pyproj's ``Geod.inv``, Karney) gives on
    the probe lines, to 1e-12 relative (or 1e-12° and 1e-9 m): a pyproj whose geodesic changed
    fails here rather than let the probe compare against stale numbers."""
    from engine.fast import geodesy
    from engine.geodesy.ellipsoid import Ellipsoid

    for (a, f), rows in geodesy.GEOD_VERIFIED.items():
        ref = GeodesicSolver(Ellipsoid("probe", a, 1.0 / f))
        for q, want in zip(geodesy.GEOD_PROBES, rows, strict=True):
            got = ref.inverse(q[1], q[0], q[3], q[2])
            for g, w, floor in zip(got, want, (1e-12, 1e-12, 1e-9), strict=True):
                assert math.isclose(g, w, rel_tol=1e-12, abs_tol=floor), (a, f, q, got, want)


def test_a_compiled_run_imports_no_pyproj() -> None:
    """A compiled replay of the thesis sample checks its parts at first use without importing
    pyproj (the geodesic's check reads recorded reference numbers; the systems' and the fix's
    checks use the checked geodesic on both sides): pyproj's import is ~50 ms of start-up."""
    import subprocess
    import sys

    from tests.paths import ROOT

    code = ("import sys; sys.argv = ['uvnav', 'replay', 'data/920917_1.RUN', '--no-out']\n"
            "from uvnav_tui.cli.main import main\n"
            "try:\n    main()\nexcept SystemExit:\n    pass\n"
            "print('PYPROJ', 'pyproj' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                          text=True, timeout=120)
    assert "PYPROJ False" in done.stdout, done.stdout + done.stderr

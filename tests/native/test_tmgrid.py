"""The compiled TM grid (engine/native/tmgrid.c) gives the pure Python's bits (issue 14).

``engine.fast.geodesy.FastTMGrid``'s ``forward``, ``forward_full`` and ``inverse`` go through
the kernel; the reference ``TMGrid``'s methods are the Python it mirrors. Every
comparison here is exact (``float.hex``, so the sign of a zero counts): on the calls a short
demo replay really makes, on hypothesis inputs over the grid's domain (both hemispheres, west
and east of the CM, the antimeridian, the poles), and on the edges where the kernel declines
and the Python decides (non-float arguments, non-finite values, math errors).
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
from collections.abc import Callable
from dataclasses import replace
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import engine.systems.gps as gps
from engine import native
from engine.fast import geodesy as fast_geodesy
from engine.fast import gps as fast_gps
from engine.fast.geodesy import FastTMGrid, fast_datum_shift
from engine.fast.gps import FAST_GPS, FastGpsSystem
from engine.geodesy.ellipsoid import WGS84 as WGS84_DATUM
from engine.geodesy.ellipsoid import WGS84_ELLIPSOID, Ellipsoid
from engine.geodesy.tmgrid import TMGrid
from engine.io.datumfile import read_datum_file
from tests.native.replay import replay_patched
from tests.paths import DATA, ROOT

KERNEL = fast_geodesy.KERNEL
needs_kernel = pytest.mark.skipif(KERNEL is None, reason="engine.native.tmgrid not built")

INTL = Ellipsoid("INTERNATIONAL", 6378388.0, 297.0)
CMS = (-179.0, -3.0, 0.0, 5.0, 180.0)
GRIDS = {(ell.name, cm): FastTMGrid(ell, cm) for ell in (INTL, WGS84_ELLIPSOID) for cm in CMS}
_REFS: dict[tuple[str, float], TMGrid] = {}


def _ref(grid: TMGrid) -> TMGrid:
    """The reference grid of ``grid``'s ellipsoid and central meridian (one per pair)."""
    key = (grid.ellipsoid.name, grid.cm_deg)
    ref = _REFS.get(key)
    if ref is None or ref.ellipsoid != grid.ellipsoid:
        ref = _REFS[key] = TMGrid(grid.ellipsoid, grid.cm_deg)
    return ref


def _bits(v: Any) -> Any:
    """A result with every float as its hex text (exact, zero signs and NaN included)."""
    if isinstance(v, tuple):
        return tuple(_bits(x) for x in v)
    return float.hex(v) if isinstance(v, float) else v


def _outcome(fn: Callable[..., Any], *args: Any) -> Any:
    """``fn(*args)`` as bits, or the type and text of the exception it raises."""
    try:
        out = fn(*args)
    except Exception as exc:  # noqa: BLE001 - the exception is the outcome compared
        return type(exc), str(exc)
    assert all(type(v) is float for v in out)
    return _bits(out)


def _check_forward(grid: TMGrid, lat: Any, lon: Any) -> None:
    ref = _ref(grid)
    assert _outcome(grid.forward, lat, lon) == _outcome(ref.forward, lat, lon)
    assert _outcome(grid.forward_full, lat, lon) == _outcome(ref.forward_full, lat, lon)


def _check_inverse(grid: TMGrid, x: Any, y: Any) -> None:
    want = _outcome(_ref(grid)._inverse, x, y)
    assert _outcome(grid._inverse, x, y) == want
    assert _outcome(grid.inverse, x, y) == want  # the kernel's memo (a miss, then a hit)
    assert _outcome(grid.inverse, x, y) == want


# --------------------------------------------------------------------------- replayed calls
@pytest.fixture(scope="module")
def replayed() -> dict[str, list[tuple[TMGrid, Any, Any]]]:
    """The grid calls of the first 200 demo epochs (grid, argument, argument), recorded."""

    calls: dict[str, list[tuple[TMGrid, Any, Any]]] = {"forward": [], "forward_full": [],
                                                        "convergence_deg": [], "inverse": []}
    originals = {name: getattr(FastTMGrid, name) for name in calls}

    def recorder(name: str) -> Callable[..., Any]:
        def record(self: TMGrid, a: Any, b: Any) -> Any:
            calls[name].append((self, a, b))
            return originals[name](self, a, b)
        return record

    # The GPS input through its Python, whose grid.forward is recorded here (the kernel's
    # gps_input does the forward itself: test_gps_input_* below).
    replay_patched([*((FastTMGrid, name, recorder(name)) for name in calls),
                    (FastGpsSystem, "gps_input", gps.GpsSystem.gps_input)], 200)
    return calls


@needs_kernel
def test_replayed_calls_give_the_pure_bits(replayed: dict[str, list[tuple]]) -> None:
    """Every forward, forward_full (the cycle's convergence_deg calls the kernel's forward_full
    itself) and inverse of 200 demo epochs: kernel == Python, and the kernel never declined (so
    the replay really runs compiled)."""
    n = {k: len(v) for k, v in replayed.items()}
    assert n["forward"] >= 150 and n["inverse"] >= 150, n
    assert n["forward_full"] + n["convergence_deg"] >= 150, n
    for grid, lat, lon in replayed["forward"]:
        assert KERNEL.forward(grid._packed, lat, lon) is not None
        assert _bits(grid.forward(lat, lon)) == _bits(_ref(grid).forward(lat, lon))
    for grid, lat, lon in replayed["forward_full"]:
        assert KERNEL.forward_full(grid._packed, lat, lon) is not None
        assert _bits(grid.forward_full(lat, lon)) == _bits(_ref(grid).forward_full(lat, lon))
    for grid, lat, lon in replayed["convergence_deg"]:
        assert KERNEL.forward_full(grid._packed, lat, lon) is not None
        assert _bits(grid.convergence_deg(lat, lon)) == _bits(
            _ref(grid).forward_full(lat, lon)[2])
    fresh: dict[float, TMGrid] = {}
    for grid, x, y in replayed["inverse"]:
        assert KERNEL.inverse(grid._packed, x, y, False) is not None
        want = _bits(_ref(grid)._inverse(x, y))
        assert _bits(grid._inverse(x, y)) == want
        # In replay order through the memo of one grid (hits and evictions as in the run).
        g = fresh.setdefault(grid.cm_deg, FastTMGrid(grid.ellipsoid, grid.cm_deg))
        assert _bits(g.inverse(x, y)) == want


# --------------------------------------------------------------------------- generated inputs
grid_keys = st.sampled_from(sorted(GRIDS))


@needs_kernel
@settings(deadline=None, max_examples=400)
@given(grid_keys, st.floats(-90.0, 90.0), st.floats(-30.0, 30.0))
def test_forward_over_the_domain(key: tuple[str, float], lat: float, dlon: float) -> None:
    """Both hemispheres, west and east of the CM (negative x), across the antimeridian."""
    grid = GRIDS[key]
    _check_forward(grid, lat, grid.cm_deg + dlon)


@needs_kernel
@settings(deadline=None, max_examples=100)
@given(grid_keys, st.floats(89.9, 271.0), st.sampled_from([-1.0, 1.0]), st.floats(-40.0, 40.0))
def test_forward_beyond_the_poles(key: tuple[str, float], lat: float, sign: float,
                                  dlon: float) -> None:
    """|φ| ≥ 90° (cos φ ≤ 0): the pole branch of forward and forward_full."""
    grid = GRIDS[key]
    _check_forward(grid, sign * lat, grid.cm_deg + dlon)


@needs_kernel
@settings(deadline=None, max_examples=400)
@given(grid_keys, st.floats(-3.5e6, 3.5e6), st.floats(-1.0e7, 1.0e7))
def test_inverse_over_the_domain(key: tuple[str, float], x: float, y: float) -> None:
    """x to ±3500 km (≈ ±30° at the equator), y over both hemispheres to the poles."""
    _check_inverse(GRIDS[key], x, y)


@needs_kernel
@settings(deadline=None, max_examples=200)
@given(grid_keys, st.floats(allow_nan=True, allow_infinity=True),
       st.floats(allow_nan=True, allow_infinity=True))
def test_any_float_gives_the_pure_outcome(key: tuple[str, float], a: float, b: float) -> None:
    """Far outside the domain too, NaN and infinities: the same result or the same
    exception (the kernel declines and the Python decides)."""
    grid = GRIDS[key]
    _check_forward(grid, a, b)
    _check_inverse(grid, a, b)


EDGES = [0.0, -0.0, 1e-300, -1e-300, 5e-324, 1.0, -1.0, 90.0, -90.0, 89.99999999, 180.0,
         -180.0, 185.0, -175.0, 360.0, 1e5, -1e5, 3.3e6, -3.3e6, 9.99e6, -9.99e6, 1.0e7,
         2.0e7, 1e9, -1e12, 1e300, math.inf, -math.inf, math.nan]


@needs_kernel
@pytest.mark.parametrize("key", sorted(GRIDS)[:5])
def test_edges(key: tuple[str, float]) -> None:
    """Zeros of both signs, poles, the antimeridian, overflowing and non-finite values."""
    grid = GRIDS[key]
    for a in EDGES:
        for b in EDGES:
            _check_forward(grid, a, b)
            _check_forward(grid, a, grid.cm_deg + b)
            _check_inverse(grid, a, b)


@needs_kernel
def test_other_argument_types() -> None:
    """ints, bools and numpy floats give the Python's bits; other types go to the Python."""
    grid = GRIDS[("INTERNATIONAL", 5.0)]
    for a, b in [(52, 4), (True, 3), (np.float64(52.5), np.float64(4.25)), (52.5, 10**400),
                 (np.float32(52.5), 4.0), ("52", 4.0), (None, 1.0)]:
        _check_forward(grid, a, b)
    for a, b in [(-20000, 5800000), (np.float64(-2.5e4), np.float64(5.8e6)), (1, True),
                 (0, 0), (10**400, 1.0), (np.float32(1e4), 5.8e6), ("1", 2.0)]:
        _check_inverse(grid, a, b)
    int_cm = FastTMGrid(INTL, 5)
    assert int_cm._packed is not None
    _check_forward(int_cm, 52.5, 4.25)
    _check_inverse(int_cm, -2.5e4, 5.8e6)


@needs_kernel
def test_memo_keeps_zero_signs_and_evicts() -> None:
    """Hits are the computed inverses through many evictions; a zero is never looked up (its
    sign reaches the latitude)."""
    grid, ref = FastTMGrid(INTL, 5.0), TMGrid(INTL, 5.0)
    pts = [(-1000.0 * i - 1.5, 5.8e6 + 7.25 * i) for i in range(12)]
    for x, y in pts + pts[::-1] + pts[:3] * 3:
        assert _bits(grid.inverse(x, y)) == _bits(ref._inverse(x, y))
    for first, second in ((0.0, -0.0), (-0.0, 0.0)):
        grid.inverse(-1000.0, first)
        assert _bits(grid.inverse(-1000.0, second)) == _bits(ref._inverse(-1000.0, second))
    assert grid._inverted == {}  # the kernel keeps its own memo
    assert grid == FastTMGrid(INTL, 5.0)


# --------------------------------------------------------------------------- the GPS input
def _gps_bits(g: Any) -> Any:
    """Every field of a GpsInput (None stays None), floats as their bits."""
    if g is None:
        return None
    assert type(g) is gps.GpsInput
    return tuple(_bits(getattr(g, f)) for f in gps.GpsInput.__slots__)


def _gps_outcome(fn: Callable[..., Any], inputs: Any) -> Any:
    try:
        return _gps_bits(fn(inputs))
    except Exception as exc:  # noqa: BLE001 - the exception is the outcome compared
        return type(exc), str(exc)


@pytest.fixture(scope="module")
def gps_inputs() -> list[Any]:
    """The CycleInputs of GPS's reading in the first 150 demo epochs."""
    seen: list[Any] = []
    real = FastGpsSystem.gps_input

    def record(self: Any, inputs: Any) -> Any:
        seen.append(inputs)
        return real(self, inputs)

    replay_patched([(FastGpsSystem, "gps_input", record)], 150)
    return seen


@needs_kernel
def test_gps_input_on_the_replay(gps_inputs: list[Any]) -> None:
    """The kernel's gps_input (datum shift, ECEF, grid, record) == the reference, and it takes
    every record of the replay."""
    assert len(gps_inputs) >= 140
    for inputs in gps_inputs:
        rec = inputs.record
        ctx = inputs.context
        assert KERNEL.gps_input(inputs.grid._packed, ctx.gps_shift.point, None,
                                rec.gps_lat_deg, rec.gps_lon_deg,
                                gps._WGS84_A, gps._WGS84_E2, fast_gps._new_input,
                                gps.gps_weight(inputs.config, rec)) is not None
        assert _gps_bits(FAST_GPS.gps_input(inputs)) == _gps_bits(gps.gps_input(inputs))


_DATUMS = read_datum_file(DATA / "TO_WGS84.DAT")
_SHIFTS = {pair: None if pair[0] == pair[1] else fast_datum_shift(
    WGS84_DATUM if pair[0] == "WGS84" else _DATUMS.datum(pair[0]),
    WGS84_DATUM if pair[1] == "WGS84" else _DATUMS.datum(pair[1]))
    for pair in (("WGS84", "ED50"), ("ED50", "WGS84"), ("ED50", "ED50"), ("WGS84", "WGS84"))}


@needs_kernel
@settings(deadline=None, max_examples=300)
@given(k=st.integers(0, 10_000), gps_datum=st.sampled_from(["WGS84", "ED50"]),
       working=st.sampled_from(["WGS84", "ED50"]), cm=st.sampled_from(CMS),
       lat=st.floats(-90.0, 90.0) | st.sampled_from([math.nan, math.inf, 90.0, -90.0, 0.0]),
       lon=st.floats(-180.0, 180.0) | st.sampled_from([math.nan, -math.inf, 180.0, -0.0]))
def test_gps_input_anywhere(gps_inputs: list[Any], k: int, gps_datum: str, working: str,
                            cm: float, lat: float, lon: float) -> None:
    """Other positions (poles, NaN, infinities), datum pairs (no shift, a shift to the working
    datum, one to WGS84 for the ECEF, both) and grids: the kernel's record or the Python's
    outcome (its exception where it raises)."""
    base = gps_inputs[k % len(gps_inputs)]
    ctx = SimpleNamespace(gps_shift=_SHIFTS[(gps_datum, working)],
                          gps_to_wgs84=_SHIFTS[(gps_datum, "WGS84")])
    rec = replace(base.record, gps_lat_deg=lat, gps_lon_deg=lon)
    inputs = replace(base, context=ctx, record=rec, grid=GRIDS[("INTERNATIONAL", cm)])
    assert _gps_outcome(FAST_GPS.gps_input, inputs) == _gps_outcome(gps.gps_input, inputs)


# --------------------------------------------------------------------------- the pure path
def test_reference_grid_has_no_compiled_state() -> None:
    """The reference grid is pure Python: its dict memo, nothing packed for a kernel."""
    grid = TMGrid(INTL, 5.0)
    assert not hasattr(grid, "_packed")
    x, y = grid.forward(52.5, 4.25)
    assert grid.inverse(x, y) == grid.inverse(x, y)  # a hit of the dict memo
    assert len(grid._inverted) == 1


def test_pure_env_leaves_the_kernel_unloaded() -> None:
    """UVNAV_PURE=1: no kernel, the run's parts are the reference's."""
    code = ("from engine.fast import geodesy as g; from engine.run.parts import REFERENCE, "
            "choose; assert g.KERNEL is None and choose() == REFERENCE; print('ok')")
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                          text=True, timeout=120, env={**os.environ, native.PURE_ENV: "1"})
    assert done.returncode == 0, done.stderr

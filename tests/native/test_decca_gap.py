"""Lane identification after a gap on the compiled path (engine/fast/lanes.py) against the
reference (engine.systems.decca: ``decca_totals``, ``_identify_gap``, ``fix_lanes``).

The compiled path writes only records where no lane is taken and declines wherever a decision
or a printed digit lies within its error bound; where it writes, the LaneTotals must be the
reference's: totals and track to the bit, notes (their printed σ, success rates and ratios)
and slips identical. ``fix_lanes`` alone: the same outcome (lanes, the note's text) and its
success rate and ratio within 1e-9 relative (docs/PERFORMANCE.md, the tolerance contract).
"""

from __future__ import annotations

import math
from datetime import timedelta
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from hypothesis import event, given, settings
from hypothesis import strategies as st

import engine.systems.decca as decca
from engine import native
from engine.fast import decca as fast_decca
from engine.fast import lanes
from tests.native.test_decca import (  # noqa: F401 - replay_values: a fixture
    FAST,
    GRID,
    MX,
    MY,
    PLACED,
    PURE,
    hexes,
    replay_values,
)

K = native.kernel("decca")
pytestmark = pytest.mark.skipif(K is None, reason=f"decca kernel: {native.status('decca')}")

_RULES = st.sampled_from([decca.LANE_RULE, decca.LaneRule(0.99, 2.0, 1.0),
                          decca.LaneRule(0.9, 3.0, 4.0), decca.LaneRule(0.999, 1.5, 64.0),
                          decca.LaneRule(0.5, 1.0, 1.0)])


T = native.kernel("tmgrid")


def _lanes_both(placed: Any, x: float, y: float) -> tuple[Any, Any]:
    """The kernel's ``lanes`` at (x, y) as _LaneAt._lanes' triple, and the reference's."""
    got = K.lanes(placed._scalars, fast_decca.geodesic_kernel(FAST), T.inverse,
                  placed.grid._packed, x, y)
    if got is not None and got is not NotImplemented:
        got = (list(got[4:7]), [[got[7], got[8]], [got[9], got[10]], [got[11], got[12]]],
               list(got[0:4]))
    ref = decca._LaneAt(placed, PURE)._lanes(decca.LaneSource("p", x, y, np.eye(2)))
    if ref is not None:
        ref = (ref[0], ref[1].tolist(), ref[2])
    return got, ref


def test_lanes_on_the_replay(replay_values: dict[str, list[Any]]) -> None:  # noqa: F811
    """The kernel's lane model at every source the replay identified lanes from is
    _LaneAt._lanes' to the bit."""
    n = 0
    for placed, src in replay_values["lanes"]:
        if getattr(placed.grid, "_packed", None) is None:
            continue  # the probe's reference grid
        got, ref = _lanes_both(placed, src.x_m, src.y_m)
        assert hexes(got) == hexes(ref)
        n += 1
    assert n > 100


@settings(max_examples=300, deadline=None)
@given(dx=st.floats(-4e5, 4e5), dy=st.floats(-4e5, 4e5))
def test_lanes_anywhere(dx: float, dy: float) -> None:
    """Anywhere around the chain (up to 400 km from the master): the reference's numbers to
    the bit, or the kernel declines (NotImplemented) where the reference has none or raises
    (a point on a baseline extension, where the LEF cannot be formed)."""
    x, y = MX + dx, MY + dy
    try:
        got, ref = _lanes_both(PLACED, x, y)
    except (ValueError, ArithmeticError):
        got = K.lanes(PLACED._scalars, fast_decca.geodesic_kernel(FAST), T.inverse,
                      GRID._packed, x, y)
        assert got is NotImplemented
        return
    if got is NotImplemented:
        assert ref is None
        event("declined")
        return
    assert hexes(got) == hexes(ref)


def test_lanes_declines_what_it_does_not_read() -> None:
    good = [PLACED._scalars, fast_decca.geodesic_kernel(FAST), T.inverse, GRID._packed,
            MX + 1e4, MY - 2e4]
    assert len(K.lanes(*good)) == 13
    for i, bad in ((0, None), (1, PURE), (4, 1), (5, "1.0")):
        args = list(good)
        args[i] = bad
        assert K.lanes(*args) is NotImplemented
    assert K.lanes(*good[:-1]) is NotImplemented
    # at the master station the LEF's angle is undefined: the reference raises or has none
    assert K.lanes(*good[:4], MX, MY) in (None, NotImplemented)


def _cov(sx: float, sy: float, rho: float) -> np.ndarray:
    """A 2×2 position VCV (m²) of 1σ ``sx``, ``sy`` and correlation ``rho``."""
    c = rho * sx * sy
    return np.array([[sx * sx, c], [c, sy * sy]])


def _gap_case(call: Any, gap: tuple[bool, ...], var: float | None, off: tuple[float, float],
              dr: tuple[float, float, float] | None, rule: decca.LaneRule) -> bool | None:
    """gap_totals against the pure decca_totals on the replay record ``call`` with the tracks
    of the ``gap`` patterns 300 s old, GPS of variance ``var`` (None: no GPS) moved by
    ``off`` (m), the DR position's VCV ``dr`` (1σ x, 1σ y, ρ; None: no filter). Returns
    whether the compiled path wrote the record (None: not a case for it)."""
    placed, _g, zone_lane, track, fractions, time, x_start, position, gps = call[:9]
    if any(t is None for t in track):
        return None
    track = tuple((t[0], t[1] - timedelta(seconds=300.0)) if g else t
                  for t, g in zip(track, gap, strict=True))
    fix = src = None
    if var is not None and gps is not None:
        x, y = gps.x_m + off[0], gps.y_m + off[1]
        src = decca.LaneSource("GPS", x, y, np.eye(2) * var)
        fix = SimpleNamespace(x_m=x, y_m=y, corr_east_m=0.0, corr_north_m=0.0, var_m2=var)
    pos = None
    if dr is not None:
        pos = decca.LaneSource("the DR position", x_start[0] - off[1], x_start[1] + off[0],
                               _cov(*dr))
    got = fast_decca.gap_totals(placed, FAST, track, fractions, time, pos, fix, src, rule)
    want = decca.decca_totals(placed, PURE, zone_lane, track, fractions, time, x_start, pos,
                              src, rule)
    if got is None:
        return False
    assert type(got) is decca.LaneTotals
    assert hexes(got.totals) == hexes(want.totals)
    assert [None if t is None else (hexes(t[0]), t[1]) for t in got.track] == [
        None if t is None else (hexes(t[0]), t[1]) for t in want.track]
    assert (got.notes, got.slips) == (want.notes, want.slips)
    assert any("lane not identified after the gap" in n for n in got.notes)
    return True


@settings(max_examples=300, deadline=None)
@given(k=st.integers(0, 10_000), gap=st.tuples(st.booleans(), st.booleans(), st.booleans()),
       var=st.sampled_from([None, 1.0, 25.0, 1225.0, 1e4, 1e5]),
       off=st.one_of(st.tuples(st.floats(-50.0, 50.0), st.floats(-50.0, 50.0)),
                     st.tuples(st.floats(-3e3, 3e3), st.floats(-3e3, 3e3))),
       dr=st.one_of(st.none(), st.tuples(st.floats(1.0, 5e3), st.floats(1.0, 5e3),
                                         st.floats(-0.99, 0.99))),
       rule=_RULES)
def test_gap_totals_are_decca_totals(replay_values: dict[str, list[Any]], k: int,  # noqa: F811
                                     gap: tuple[bool, ...], var: float | None,
                                     off: tuple[float, float],
                                     dr: tuple[float, float, float] | None,
                                     rule: decca.LaneRule) -> None:
    """Around the demo's records: patterns after a gap, GPS of other precisions and
    positions or none, DR positions of any precision, other rules: the compiled path gives
    decca_totals' LaneTotals or declines."""
    calls = replay_values["totals"]
    took = _gap_case(calls[k % len(calls)], gap, var, off, dr, rule)
    event(f"compiled path wrote it: {took}")


def test_gap_totals_write_the_usual_record(replay_values: dict[str, list[Any]]  # noqa: F811
                                           ) -> None:
    """The demo's case after its dive (Purple after the gap, Red and Green tracked, GPS and
    a DR position, the default rule) is written by the compiled path, not declined, on every
    record of the replay, and the reference's notes say why the lane stays out."""
    took = [_gap_case(call, (False, False, True), 25.0, (0.0, 0.0), (300.0, 150.0, 0.3),
                      decca.LANE_RULE) for call in replay_values["totals"]
            if getattr(call[0].grid, "_packed", None) is not None]  # not the probe's grid
    assert took.count(True) >= 100 and took.count(False) == 0


def _q(g: np.ndarray, p: np.ndarray, c: np.ndarray) -> np.ndarray:
    return g @ p @ g.T + c


@settings(max_examples=500, deadline=None)
@given(g=st.lists(st.floats(-2e-2, 2e-2), min_size=6, max_size=6),
       p=st.tuples(st.floats(0.1, 3e3), st.floats(0.1, 3e3), st.floats(-0.99, 0.99)),
       c=st.lists(st.floats(1e-5, 1e-1), min_size=3, max_size=3),
       a=st.lists(st.floats(-300.0, 300.0), min_size=3, max_size=3),
       split=st.sampled_from([([2], (0, 1)), ([0], (1, 2)), ([1], (0,)), ([2], ()),
                              ([0, 1], (2,)), ([1, 2], ()), ([0, 1, 2], ())]),
       rule=_RULES)
def test_fix_lanes_is_the_reference_or_declines(g: list[float],
                                                p: tuple[float, float, float],
                                                c: list[float], a: list[float],
                                                split: tuple[list[int], tuple[int, ...]],
                                                rule: decca.LaneRule) -> None:
    """Float ambiguities and VCVs of every precision (lane gradients up to 0.02 lane/m,
    positions 0.3 m to 3 km, Decca VCVs 0.003–0.3 lane), one to three patterns wanted, none
    to two known: where the scalar fix_lanes writes an outcome it is the reference's."""
    q = _q(np.array(g).reshape(3, 2), _cov(math.sqrt(p[0]), math.sqrt(p[1]), p[2]),
           np.diag(c))
    want, known_idx = split
    known = {i: round(a[i]) for i in known_idx}
    ref = decca.fix_lanes(np.array(a), q, want, known, rule)
    try:
        got = lanes.fix_lanes(a, q.tolist(), want, known, rule)
    except lanes.Declined:
        event("declined")
        return
    event("written")
    assert got.lanes == {} == ref.lanes
    assert got.why == ref.why
    assert math.isclose(got.success, ref.success, rel_tol=1e-9)
    assert (math.isnan(got.ratio) and math.isnan(ref.ratio)) or math.isclose(
        got.ratio, ref.ratio, rel_tol=1e-9)


def test_fix_lanes_declines_at_the_thresholds() -> None:
    """A success rate or a ratio on its threshold (rounding decides), a lane taken (the
    reference writes its total) and a near-singular variance are the reference's."""
    rule = decca.LANE_RULE
    # one pattern, σ with 2Φ(1/(2σ)) − 1 = 0.999 exactly (to rounding): σ = 0.5/Φ⁻¹(0.9995)
    from statistics import NormalDist
    s = 0.5 / NormalDist().inv_cdf(0.9995)
    q = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, s * s]]
    with pytest.raises(lanes.Declined):
        lanes.fix_lanes([0.0, 0.0, 0.3], q, [2], {}, rule)
    # a sharp one, near an integer: taken by the reference, so declined here
    q[2][2] = 0.05 ** 2
    assert decca.fix_lanes(np.array([0.0, 0.0, 0.02]), np.array(q), [2], {}, rule).lanes
    with pytest.raises(lanes.Declined):
        lanes.fix_lanes([0.0, 0.0, 0.02], q, [2], {}, rule)
    # the same between two lanes: the ratio test fails, written here as the reference does
    got = lanes.fix_lanes([0.0, 0.0, 0.45], q, [2], {}, rule)
    assert got.why == decca.fix_lanes(np.array([0.0, 0.0, 0.45]), np.array(q), [2], {},
                                      rule).why
    assert got.why is not None and got.why.startswith("ratio test")
    # ratio exactly 3: (d₂/d₁)² = 3 at d₁ = 1/(1 + √3)
    d1 = 1.0 / (1.0 + math.sqrt(3.0))
    with pytest.raises(lanes.Declined):
        lanes.fix_lanes([0.0, 0.0, d1], q, [2], {}, rule)
    # Red and Green all but collinear (1 − ρ² < 1e-4): not inverted here
    qc = [[1.0, 0.99999, 0.5], [0.99999, 1.0, 0.5], [0.5, 0.5, 1.0]]
    with pytest.raises(lanes.Declined):
        lanes.fix_lanes([0.1, 0.2, 0.3], qc, [2], {0: 0, 1: 0}, rule)


@pytest.mark.parametrize(("x", "decimals", "near"), [
    (0.5249999999999, 2, True), (0.525, 2, True), (0.5251, 2, False), (0.9965, 3, True),
    (0.99649, 3, False), (2.0, 2, False)])
def test_near_rounding(x: float, decimals: int, near: bool) -> None:
    """A value within the error bound of a printed digit's rounding boundary is near it."""
    assert lanes._near_rounding(x, decimals, 1e-9) is near

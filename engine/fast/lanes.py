"""Decca lane identification after a gap on scalars (the compiled path's part of
:func:`engine.systems.decca.decca_totals` under ``[decca] lane_rule = "bootstrap"``).

After a gap (a dive) a pattern whose lane the rule cannot settle is identified again on every
record until it is settled: the reference forms the float ambiguities and their VCV with numpy
(:func:`engine.systems.decca._floats_at`) and bootstraps them (:func:`engine.systems.decca
.fix_lanes`: conditioning on the tracked patterns, the bootstrapping order and success rate,
Teunissen 1998; the ratio test, Verhagen & Teunissen 2013; THEORY §3.3). Here the same
formulas run on Python floats with the closed-form inverse of the at most 2×2 matrices they
invert, the lane model by the compiled ``lanes`` (``engine.native.decca``, the reference's
numbers to the bit, tests/native/test_decca_gap.py), and the record's tracked patterns by the
compiled ``tracked``. The reference's own :func:`engine.systems.decca._identify_gap` writes
the notes.

Where this path could decide otherwise than the reference it declines (:class:`Declined`) and
the reference runs the whole record: whenever a lane would be taken (the reference writes the
total), more than one pattern passes the success rate, a matrix is near singular, and whenever
a decision or a printed digit lies within the error bound of the two computations of it. That
bound is :data:`TOL` of the unconditioned variance (lanes²) for a variance and 1e-9 of a lane
for a float ambiguity, the tolerance contract of docs/PERFORMANCE.md, carried through the
square root, the success factor 2Φ(1/(2σ)) − 1 and the ratio; the two computations differ by a
few units in the last place times the conditioning (≤ 4·10⁴ here), about 10⁻¹¹ of it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from engine.fast.make import slots_maker
from engine.systems import decca
from engine.systems.decca import LaneFixing, LaneRule, LaneSource

TOL = 1e-9
"""Bound of the difference between this path's and the reference's conditional variances,
relative to the unconditioned variance; and of their float ambiguities, in lanes."""

_COND_MIN = 1e-4
"""Smallest det/(q₀₀·q₁₁) = 1 − ρ² of a 2×2 variance inverted here (else decline): condition
number ≤ ~4·10⁴, so the closed-form inverse and LAPACK's LU agree to ~10⁻¹¹ relative."""

_TWO_OVER_SQRT_PI = 2.0 / math.sqrt(math.pi)
_new_fixing = slots_maker(LaneFixing)


class Declined(Exception):
    """This record is for the reference: a decision or a printed digit within the error bound,
    a lane taken, or a case this path does not write."""


class Sources:
    """The lane model's context for :func:`floats_at` (the ``at`` of ``_identify_gap``): the
    placed chain, the decca kernel, the compiled geodesic, the tmgrid kernel's ``inverse``
    and the grid's packed constants."""

    __slots__ = ("geodesic", "inverse", "kernel", "packed", "placed")

    def __init__(self, placed: decca.ChainOnGrid, kernel: Any, geodesic: Any, inverse: Any,
                 packed: Any) -> None:
        self.placed = placed
        self.kernel = kernel
        self.geodesic = geodesic
        self.inverse = inverse
        self.packed = packed


def floats_at(at: Sources, src: LaneSource, fractions: Sequence[float | None],
              cf: float) -> tuple[list[float], list[list[float]], list[float]]:
    """:func:`engine.systems.decca._floats_at` as lists: (a_i = N_calc_i − fraction_i, their
    VCV G·P·Gᵀ + C_lanes (lanes²), N_calc) at ``src`` by the compiled lane model (``lanes``:
    ``_LaneAt._lanes``' numbers to the bit). Declined where the reference gives None (the
    lane model cannot be evaluated)."""
    sc = at.placed._scalars
    try:
        (p00, p01), (p10, p11) = src.cov.tolist()
        got = at.kernel.lanes(sc, at.geodesic, at.inverse, at.packed, src.x_m, src.y_m)
    except (ValueError, ArithmeticError, TypeError, AttributeError) as exc:
        raise Declined from exc
    if got is None or got is NotImplemented:
        raise Declined
    d_master, d0, d1, d2, n0, n1, n2, gx0, gy0, gx1, gy1, gx2, gy2 = got
    n_calc = [n0, n1, n2]
    c = decca._vcv_core(d_master, (d0, d1, d2), sc.baseline_sky, cf)  # A4.1–A4.3 at this cf
    # rows of G·P, then G·P·Gᵀ + C, every element written out
    u0, v0 = gx0 * p00 + gy0 * p10, gx0 * p01 + gy0 * p11
    u1, v1 = gx1 * p00 + gy1 * p10, gx1 * p01 + gy1 * p11
    u2, v2 = gx2 * p00 + gy2 * p10, gx2 * p01 + gy2 * p11
    (c00, c01, c02), (c10, c11, c12), (c20, c21, c22) = c
    q = [[u0 * gx0 + v0 * gy0 + c00, u0 * gx1 + v0 * gy1 + c01, u0 * gx2 + v0 * gy2 + c02],
         [u1 * gx0 + v1 * gy0 + c10, u1 * gx1 + v1 * gy1 + c11, u1 * gx2 + v1 * gy2 + c12],
         [u2 * gx0 + v2 * gy0 + c20, u2 * gx1 + v2 * gy1 + c21, u2 * gx2 + v2 * gy2 + c22]]
    f0, f1, f2 = fractions
    nan = math.nan
    a = [nan if f0 is None else n0 - f0, nan if f1 is None else n1 - f1,
         nan if f2 is None else n2 - f2]
    return a, q, n_calc


def _inverse(m: list[list[float]]) -> list[list[float]]:
    """Inverse of a 1×1 or 2×2 variance ``m`` (Declined when it is not well conditioned)."""
    if len(m) == 1:
        v = m[0][0]
        if not v > 0.0:
            raise Declined
        return [[1.0 / v]]
    (m00, m01), (m10, m11) = m
    det = m00 * m11 - m01 * m10
    if not (m00 > 0.0 and m11 > 0.0 and det > _COND_MIN * m00 * m11):
        raise Declined
    return [[m11 / det, -m01 / det], [-m10 / det, m00 / det]]


def _near_rounding(x: float, decimals: int, err: float) -> bool:
    """Whether ``f"{x:.{decimals}f}"`` could print otherwise for an x within ``err``: x lies
    within ``err`` (plus a few units in the last place) of a rounding boundary."""
    scale = 10.0 ** decimals
    s = x * scale
    return abs(s - math.floor(s) - 0.5) <= (err + 1e-15 * abs(x)) * scale + 1e-12


def _success_error(sigma: float, e_sigma: float) -> float:
    """Bound of the change of 2Φ(1/(2σ)) − 1 = erf(1/(2√2σ)) over σ ± ``e_sigma``
    (|d erf(x)/dσ| = (2/√π)·e^(−x²)·x/σ), plus erf's own rounding."""
    x = 0.5 / sigma * decca._SQRT1_2
    return _TWO_OVER_SQRT_PI * math.exp(-x * x) * x / sigma * e_sigma + 1e-15


def _bootstrap_order(a: Sequence[float], q: Sequence[Sequence[float]], want: list[int],
                     t_idx: list[int], known: dict[int, int]
                     ) -> tuple[list[float], list[int], list[float], list[float]]:
    """:func:`fix_lanes`' floats of ``want`` conditioned on ``known`` (patterns ``t_idx``),
    the bootstrapping order (least conditional variance first), the conditional σ
    and each σ's error bound (Declined where the order or a σ is rounding's choice)."""
    n = len(want)
    a_s = [a[i] for i in want]
    q_ss = [[q[i][j] for j in want] for i in want]
    scale = [q_ss[m][m] for m in range(n)]  # the error bound's unit (lanes²)
    if t_idx:
        inv = _inverse([[q[i][j] for j in t_idx] for i in t_idx])
        nt = len(t_idx)
        q_st = [[q[i][j] for j in t_idx] for i in want]
        r_t = [a[i] - known[i] for i in t_idx]
        k = [[sum(q_st[m][u] * inv[u][v] for u in range(nt)) for v in range(nt)]
             for m in range(n)]  # Q_ST·Q_TT⁻¹
        a_s = [a_s[m] - sum(k[m][v] * r_t[v] for v in range(nt)) for m in range(n)]
        q_ss = [[q_ss[m][l_] - sum(k[m][v] * q_st[l_][v] for v in range(nt))
                 for l_ in range(n)] for m in range(n)]
    isfinite = math.isfinite
    if not (all(isfinite(v) for v in a_s) and all(isfinite(v) for r in q_ss for v in r)
            and all(v > 0.0 for v in scale)):
        raise Declined
    order: list[int] = []
    sigmas: list[float] = []
    errs: list[float] = []
    rest = list(range(n))
    while rest:
        cand = []
        for j in rest:
            v = q_ss[j][j]
            if order:
                inv = _inverse([[q_ss[u][w] for w in order] for u in order])
                c = [q_ss[j][u] for u in order]
                v -= sum(c[u] * inv[u][w] * c[w] for u in range(len(order))
                         for w in range(len(order)))
            cand.append((v, j))
        v, j = min(cand)
        e_v = TOL * scale[j]
        if any(w != j and vv - v <= e_v + TOL * scale[w] for vv, w in cand):
            raise Declined  # the order is rounding's choice
        if not v > 2.0 * e_v:
            raise Declined  # σ undetermined
        sg = math.sqrt(v)
        order.append(j)
        sigmas.append(sg)
        errs.append(e_v / sg)  # |Δσ| ≤ |Δv|/(2σ), doubled
        rest.remove(j)
    return a_s, order, sigmas, errs


def _not_taken(sigma: float, e_sigma: float, f: float, e_f: float,
               rule: LaneRule) -> LaneFixing:
    """The outcome when the first pattern in the bootstrapping order (1σ ``sigma``, success
    factor ``f``, their bounds) fails the success rate: its note, unless a printed digit is
    rounding's choice."""
    if _near_rounding(3.0 * sigma, 2, 3.0 * e_sigma) or _near_rounding(f, 3, e_f):
        raise Declined
    return _new_fixing({}, f, math.nan, decca.why_unsure(sigma, rule))


def _ratio_one(a_u: float, p: float, rule: LaneRule) -> LaneFixing:
    """The outcome when one pattern (float ``a_u`` after conditioning, success rate ``p``)
    passes the success rate: the ratio test of its two nearest integers, the best two of the
    reference's box search in one dimension (their q's variance cancels in the ratio); a
    pass takes the lane, which is the reference's to write (Declined)."""
    lo = math.floor(a_u)
    d1, d2 = sorted((abs(a_u - lo), abs(lo + 1 - a_u)))
    if not d1 > 1e3 * TOL:
        raise Declined  # q₁ ≈ 0: a lane the ratio test takes
    ratio = (d2 * d2) / (d1 * d1)  # q₂/q₁
    e_r = ratio * (2.0 * TOL / d1 + 2.0 * TOL / d2 + 1e-15)
    if abs(ratio - rule.ratio) <= e_r or ratio >= rule.ratio or _near_rounding(ratio, 2, e_r):
        raise Declined  # at the threshold, or a lane taken
    return _new_fixing({}, p, ratio, decca.why_ratio(ratio, rule))


def _fix_one(a: Sequence[float], q: Sequence[Sequence[float]], w: int, t0: int, t1: int,
             known: dict[int, int], rule: LaneRule) -> LaneFixing:
    """:func:`fix_lanes` for the usual case, one pattern ``w`` after a gap conditioned on
    two tracked ones ``t0``, ``t1``, written out (the same formulas)."""
    q0, q1, qw = q[t0], q[t1], q[w]
    m00, m01, m10, m11 = q0[t0], q0[t1], q1[t0], q1[t1]
    det = m00 * m11 - m01 * m10
    if not (m00 > 0.0 and m11 > 0.0 and det > _COND_MIN * m00 * m11):
        raise Declined
    s0, s1 = qw[t0], qw[t1]
    k0 = (s0 * m11 - s1 * m10) / det  # Q_ST·Q_TT⁻¹
    k1 = (s1 * m00 - s0 * m01) / det
    a_u = a[w] - (k0 * (a[t0] - known[t0]) + k1 * (a[t1] - known[t1]))
    scale = qw[w]
    v = scale - (k0 * s0 + k1 * s1)
    if not (math.isfinite(a_u) and math.isfinite(v) and scale > 0.0):
        raise Declined
    e_v = TOL * scale
    if not v > 2.0 * e_v:
        raise Declined  # σ undetermined
    sg = math.sqrt(v)
    e_sg = e_v / sg
    f = decca._success_factor(sg)
    e_f = _success_error(sg, e_sg)
    if abs(f - rule.success) <= e_f:
        raise Declined
    if f < rule.success:
        return _not_taken(sg, e_sg, f, e_f, rule)
    return _ratio_one(a_u, f, rule)


def fix_lanes(a: Sequence[float], q: Sequence[Sequence[float]], want: Sequence[int],
              known: dict[int, int], rule: LaneRule) -> LaneFixing:
    """:func:`engine.systems.decca.fix_lanes` on floats for an outcome that takes no lane (the
    only one this path writes; anything else, or any decision within the error bound:
    :class:`Declined`). The same steps: conditioning on ``known``, the bootstrapping order
    and success rate, and for a single pattern passing it the ratio test."""
    if len(want) == 1 and len(known) == 2 and want[0] not in known:
        t0, t1 = known
        return _fix_one(a, q, want[0], t0, t1, known, rule)
    want = list(want)
    t_idx = [i for i in known if i not in want]
    a_s, order, sigmas, errs = _bootstrap_order(a, q, want, t_idx, known)
    p = 1.0
    e_p = 0.0
    taken: list[int] = []
    for j, sg, e_sg in zip(order, sigmas, errs, strict=True):
        f = p * decca._success_factor(sg)
        e_f = p * _success_error(sg, e_sg) + e_p
        if abs(f - rule.success) <= e_f:
            raise Declined
        if f < rule.success:
            break
        p, e_p = f, e_f
        taken.append(j)
    if not taken:  # the loop broke at the first pattern (p = 1): f and e_f are its own
        return _not_taken(sigmas[0], errs[0], f, e_f, rule)
    if len(taken) > 1:
        raise Declined
    return _ratio_one(a_s[taken[0]], p, rule)

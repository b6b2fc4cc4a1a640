"""The filter on the compiled kernels (``engine.native.kalman_predict``, ``kalman_update``).

Each function here is the reference's of the same name (``engine.filter.predict``, ``update``,
``measurements``, ``estimate``) with its usual case in one compiled call: the time update with
the predicted state's estimate, the update of a cycle's rows (read straight from the lists of
``engine.filter.measurements.sensor_rows``, stacked with the fix's rows where there are both)
with the whole :class:`UpdateResult` and the gross-error gate's distance, the coloured LSE rows.
A kernel returns None for inputs it declines (S not positive definite or near that boundary, a
variance after the update near zero — where rounding would decide, docs/PERFORMANCE.md — a
layout it does not read, a state it does not cover): the reference then runs, and raises what
it raises.

The kernels agree with the reference to the tolerance contract of docs/PERFORMANCE.md, which
:func:`probe` checks before a run takes any of these (``engine.fast.parts``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from engine import native
from engine.fast import lsq
from engine.fast.make import slots_maker
from engine.filter import estimate as ref_estimate
from engine.filter import measurements as ref_measurements
from engine.filter import predict as ref_predict
from engine.filter import update as ref_update
from engine.filter.estimate import PositionEstimate
from engine.filter.measurements import (
    Measurement,
    SensorLayout,
    distinct_key_tuple,
    h_template,
    rows_measurement,
    stack_measurements,
)
from engine.filter.model import FixDecay, StepConstants, step_constants
from engine.filter.params import FilterParams
from engine.filter.state import IPSI, IX, IY, N_NAV, FilterState, init_state
from engine.filter.update import (
    LomTest,
    LsTest,
    UpdateResult,
    _bias_h,
    _empty_update,
    _full_width,
    _lom_limits,
    _with_bias_columns,
)
from engine.geodesy.tmgrid import TMGrid
from engine.lsq.fix import FixResult
from engine.systems.base import PositionPrior

KP: Any = native.kernel("kalman_predict")
"""``engine.native.kalman_predict`` (the time update, the estimate, the LSE rows), or None."""


def _update_kernel() -> Any:
    """``engine.native.kalman_update`` bound to the result classes it builds, or None."""
    k = native.kernel("kalman_update")
    if k is not None:
        k.bind_result(FilterState, LomTest, LsTest, UpdateResult, _lom_limits)
    return k


KU: Any = _update_kernel()
"""``engine.native.kalman_update`` (the measurement update and its tests), or None."""


def _position_kernel() -> Any:
    """:data:`KP` with its ``position`` bound to the compiled TM inverse and error ellipse that
    the compiled grid and fix use (None when any of the three kernels is not there)."""
    tm = native.kernel("tmgrid")
    fix = lsq.kernel()
    if KP is None or tm is None or fix is None or not hasattr(KP, "position"):
        return None
    KP.bind_position(tm.inverse, fix.ellipse, PositionEstimate)
    return KP


POSITION: Any = _position_kernel()
"""The kernel whose ``position(source, packed, x, P)`` makes a state's whole estimate, or None."""

# -------------------------------------------------------------------------------- time update


def _step_memos(state: FilterState, dt: float,
                params: FilterParams) -> tuple[StepConstants, FixDecay | None]:
    """The step constants for Δt s and the fix states' decay (None without fix states), their
    memos read first (every cycle)."""
    c = params._memo.get(dt)
    if c is None:
        c = step_constants(params, dt)
    fd = None
    if state.fix_states:
        fd = c.fix.get(state.fix_tau_s)
        if fd is None:
            fd = c.fix_decay(state.fix_tau_s)
    return c, fd


def predict_step(state: FilterState, dt: float,
                 params: FilterParams) -> tuple[FilterState, np.ndarray]:
    """:func:`engine.filter.predict.predict_step` in one compiled call: (state, Φ)."""
    if dt > 0.0:
        c, fd = _step_memos(state, dt, params)
        r = KP.predict(state.x, state.P, c, fd, state.fix_cov, True, state, FilterState,
                       state.t + dt)
        if r is not None:
            return r  # type: ignore[no-any-return]
    return ref_predict.predict_step(state, dt, params)


def predict_estimate(state: FilterState, dt: float, params: FilterParams, source: str,
                     grid: TMGrid) -> tuple[FilterState, np.ndarray, PositionEstimate]:
    """:func:`engine.filter.estimate.predict_estimate`: the time update and the predicted
    state's estimate in one compiled call (on a compiled grid)."""
    if dt > 0.0 and POSITION is not None:
        c, fd = _step_memos(state, dt, params)
        r = KP.predict(state.x, state.P, c, fd, state.fix_cov, True, state, FilterState,
                       state.t + dt, source, getattr(grid, "_packed", None))
        if r is not None:
            if r[2] is None:
                return r[0], r[1], filter_estimate(source, grid, r[0])
            return r  # type: ignore[no-any-return]
    new, phi = predict_step(state, dt, params)
    return new, phi, filter_estimate(source, grid, new)


def filter_estimate(source: str, grid: TMGrid, fs: FilterState) -> PositionEstimate:
    """:func:`engine.filter.estimate.filter_estimate` in one compiled call (on a compiled
    grid)."""
    if POSITION is not None:
        est = POSITION.position(source, getattr(grid, "_packed", None), fs.x, fs.P)
        if est is not None:
            return est  # type: ignore[no-any-return]
    return ref_estimate.filter_estimate(source, grid, fs)


# --------------------------------------------------------------------------- measurement update


def update(state: FilterState, rows: Measurement, params: FilterParams) -> UpdateResult:
    """:func:`engine.filter.update.update`: the numeric core and the whole result in one
    compiled call (x⁺, P⁺ in a new state, v̂, S, K, the LOM test and the LS factors)."""
    p = rows.z.shape[0]
    if p == 0:
        return _empty_update(state)
    if rows.bias_keys:
        new, H = _with_bias_columns(state, rows, params)
    else:
        new, H = state, rows.H
        if H.shape[1] < state.x.shape[0]:
            new, H = _full_width(state, rows, params)
    result = KU.update_result(new, H, rows.z, rows.R, rows.angle_rows, params.joseph, IPSI,
                              params.alpha, rows.labels)
    if result is None:
        return ref_update.update(state, rows, params)
    return result  # type: ignore[no-any-return]


_ROWS_LAST: list[tuple[object, int, np.ndarray | None]] = [(None, -1, None)]
"""The last ``h_template(cols, n)`` of :func:`update_rows` with its columns (compared by
identity: the cycle passes the same layout tuple every time) and n."""


def update_rows(state: FilterState, zs: list[float], var: list[float], layout: SensorLayout,
                params: FilterParams) -> UpdateResult:
    """:func:`engine.filter.update.update_rows`, the kernel reading the values and variances
    straight from the lists (``update_blocks``), without the :class:`Measurement`."""
    if zs:
        labels, cols_t, H, angle = layout
        n = state.x.shape[0]
        if H.shape[1] < n:  # the template over all n states, h_template(cols_t, n)
            last = _ROWS_LAST[0]
            if last[0] is cols_t and last[1] == n:
                H = last[2]
            else:
                H = h_template(cols_t, n)
                _ROWS_LAST[0] = (cols_t, n, H)
        result = KU.update_blocks(state, H, ((zs, var),), angle, params.joseph, IPSI,
                                  params.alpha, labels)
        if result is not None:
            return result  # type: ignore[no-any-return]
    return update(state, rows_measurement(zs, var, layout), params)


def update_rows_gated(state: FilterState, zs: list[float], var: list[float],
                      layout: SensorLayout, b: Measurement,
                      params: FilterParams) -> tuple[UpdateResult, float]:
    """:func:`engine.filter.update.update_rows_gated` (the depth rows stacked before the
    fix's, and the fix's Mahalanobis length) in one compiled call where the kernel takes
    them (``update_blocks`` with its gate)."""
    if zs:
        labels, cols_t, H, angle = layout
        r = update_two(state, (zs, var), cols_t, labels, angle, H.shape[1], b, params, len(zs))
        if r is not None:
            result, d = r
            if d is None:  # the kernel's distance declined
                d = innovation_distance(result, slice(len(zs), None))
            return result, d
    result = update(state, stack_measurements(rows_measurement(zs, var, layout), b), params)
    return result, innovation_distance(result, slice(len(zs), None))


_TWO_LAST: list[tuple[tuple[object, ...], tuple[object, ...]] | None] = [None]
"""The last plan of :func:`update_two`, (key, plan): the key is what the plan is made of (a's
columns, labels, angle rows and H width, b's columns, fix-error keys, labels and angle rows,
the state's fix-error states, the number of states), the plan H, the stacked angle rows and
labels and whether b's keys are the state's fix-error states. The cycle passes the same
objects every time, so the plan is made once."""


def update_two(state: FilterState, block_a: tuple[object, object],
               cols_a: tuple[tuple[int, ...], ...], labels_a: tuple[str, ...],
               angle_a: tuple[int, ...], width_a: int, b: Measurement,
               params: FilterParams, gate: int | None = None) -> Any:
    """The update with rows ``a`` (given by their block (z, R) for ``update_blocks``, H
    columns, labels, angle rows and H width; no fix-error keys) stacked before rows ``b``
    (template H, and the fix-error states of its keys already in the state): the
    :class:`UpdateResult` of ``update(state, stack_measurements(a, b), params)``, with
    ``gate`` (the first of b's rows) (result, distance or None). None: the caller runs the
    general code."""
    cb = b._cols
    if cb is None or not b.z.shape[0]:
        return None
    n = state.x.shape[0]
    bk = b.bias_keys
    fs = state.fix_states
    lb = b.labels
    ab = b.angle_rows
    key = (cols_a, labels_a, angle_a, width_a, cb, bk, lb, ab, fs, n)
    lk = _TWO_LAST[0]
    if lk is not None and lk[0] == key:
        H, angle, labels, keys_ok = lk[1]
    else:
        H = None
        keys_ok = False
        ka = len(cols_a)
        cols_t = cols_a + cb
        if bk:
            dk = distinct_key_tuple(bk)
            keys_ok = bool(dk) and dk == fs
            if keys_ok:
                H = _bias_h(cols_t, (None,) * ka + bk, fs, n)
        elif not (width_a > n or b.H.shape[1] > n):
            H = h_template(cols_t, n)
        if H is None:
            return None
        angle = tuple(angle_a)
        if ab:
            angle += tuple(ka + i for i in ab)
        labels = tuple(labels_a) + tuple(lb)
        _TWO_LAST[0] = (key, (H, angle, labels, keys_ok))
    if bk:
        cov = b.bias_cov
        # the stack's prior is b's (all of it), the fix-error states all there: the update of
        # state.with_fix_cov(fs, cov), whose fix_cov sym2(cov) the kernel's new state takes
        if not keys_ok or len(bk) != b.z.shape[0] or cov is None or \
                type(cov) is not np.ndarray or cov.dtype != np.float64 or \
                cov.shape != (len(fs), len(fs)):
            return None
        fc = KP.sym2(cov)
        new = state if fc is not None else state.with_fix_cov(fs, cov)
    else:
        if width_a > n or b.H.shape[1] > n:
            return None
        new, fc = state, None
    if gate is None:
        return KU.update_blocks(new, H, (block_a, (b.z, b.R)), angle, params.joseph, IPSI,
                                params.alpha, labels, fc)
    return KU.update_blocks(new, H, (block_a, (b.z, b.R)), angle, params.joseph, IPSI,
                            params.alpha, labels, fc, gate)


def innovation_distance(result: UpdateResult, rows: slice = slice(None)) -> float:
    """:func:`engine.filter.update.innovation_distance` in one compiled call (rows a slice of
    step 1)."""
    if type(rows) is slice:
        v = result.innovation
        start, stop, step = rows.indices(v.shape[0])
        if step == 1:
            d = KU.distance(v, result.S, start, stop)
            if d is not None:
                return d  # type: ignore[no-any-return]
    return ref_update.innovation_distance(result, rows)


_LSE_COLS = ((IX,), (IY,))
_LSE_LABELS = ("x_LSE", "y_LSE")
_LSE_H = h_template(_LSE_COLS, N_NAV)
"""The LSE rows' H over the nav states (the reference's ``h_template`` array)."""
_NEW = object.__new__


def lse_measurement(x_m: float, y_m: float, C2: np.ndarray, params: FilterParams | None = None,
                    keys: tuple[str, str] = ("fix_e", "fix_n")) -> Measurement:
    """:func:`engine.filter.measurements.lse_measurement`, the coloured rows' arrays made in one
    compiled call."""
    if params is not None and params.coloured:
        arrays = KP.lse(x_m, y_m, C2, params.fix_sigma_frac)
        if arrays is not None:
            tau = params.fix_tau_s
            m = _NEW(Measurement)  # ref_measurements._measurement(…) inline, the same dict
            m.__dict__.update(z=arrays[0], H=_LSE_H, R=arrays[1], labels=_LSE_LABELS,
                              angle_rows=(), bias_keys=keys, bias_cov=arrays[2],
                              bias_tau_s=(tau, tau), _cols=_LSE_COLS)
            return m
    return ref_measurements.lse_measurement(x_m, y_m, C2, params, keys)


# ---------------------------------------------------------- the prior of the fix, frozen results

_PRIOR: Any = getattr(native.kernel("runparse"), "prior", None)
"""``engine/native/runparse.c``'s ``prior`` (the filter's prior in one call), or None."""
_new_prior = slots_maker(PositionPrior)


def filter_prior(fs: FilterState) -> tuple[tuple[float, float], PositionPrior]:
    """:func:`engine.filter.estimate.filter_prior` in one compiled call."""
    if _PRIOR is not None:
        r = _PRIOR(fs.x, fs.P, IX, IY, _new_prior)
        if r is not None:
            return r  # type: ignore[no-any-return]
    return ref_estimate.filter_prior(fs)


_FREEZE: Any = getattr(native.kernel("outfmt"), "freeze_result", None)
"""``engine/native/outfmt.c``'s ``freeze_result``, or None."""


def freeze_result(fix: FixResult | None, phi: np.ndarray | None, u1: UpdateResult | None,
                  u2: UpdateResult | None) -> None:
    """:func:`engine.filter.estimate.freeze_result` of a cycle's fix, Φ and two updates in one
    compiled call."""
    if _FREEZE is None or _FREEZE(fix, phi, u1, u2) is None:
        ref_estimate.freeze_result(fix, phi, u1, u2)


# ------------------------------------------------------------------------------ first-use probe

REL_TOL = 1e-9
"""Relative agreement the probe asks (docs/PERFORMANCE.md); the absolute floor is that times
the largest magnitude of the array compared (a covariance's tiny off-diagonal terms)."""


def _agree(a: Any, b: Any) -> bool:
    """Numbers (floats, arrays) equal within :data:`REL_TOL` of their scale, NaN with NaN."""
    fa = np.asarray(a, dtype=float).ravel()
    fb = np.asarray(b, dtype=float).ravel()
    if fa.shape != fb.shape:
        return False
    with np.errstate(invalid="ignore"):
        mag = np.abs(fb)
        scale = float(mag[~np.isnan(mag)].max()) if fb.size and not np.isnan(fb).all() else 0.0
        ok = (fa == fb) | (np.abs(fa - fb) <= REL_TOL * np.maximum(mag, scale)) | \
            (np.isnan(fa) & np.isnan(fb))
    return bool(ok.all())


def _agree_each(a: tuple[float, ...], b: tuple[float, ...]) -> bool:
    """Scalars pairwise within :data:`REL_TOL` of each one's own magnitude."""
    return len(a) == len(b) and all(_agree(u, v) for u, v in zip(a, b, strict=True))


def _same_state(a: FilterState, b: FilterState) -> bool:
    return (a.fix_states == b.fix_states and a.fix_tau_s == b.fix_tau_s and _agree(a.t, b.t)
            and _agree(a.x, b.x) and _agree(a.P, b.P) and _agree(a.fix_cov, b.fix_cov))


def _same_update(a: UpdateResult, b: UpdateResult) -> bool:
    return (_same_state(a.state, b.state) and a.labels == b.labels
            and a.lom.verdict == b.lom.verdict and a.lom.dof == b.lom.dof
            and _agree_each((a.lom.t, a.lom.lower, a.lom.upper),
                            (b.lom.t, b.lom.lower, b.lom.upper))
            and _agree(a.innovation, b.innovation) and _agree(a.S, b.S) and _agree(a.K, b.K)
            and _agree(a.ls.t, b.ls.t) and a.ls.flags == b.ls.flags
            and a.ls.identified == b.ls.identified)


def _same_estimate(a: PositionEstimate, b: PositionEstimate) -> bool:
    ea, eb = a.ellipse, b.ellipse
    return (a.source == b.source
            and _agree_each((a.lat_deg, a.lon_deg, a.x_m, a.y_m, a.depth_m),
                            (b.lat_deg, b.lon_deg, b.x_m, b.y_m, b.depth_m))
            and _agree(a.cov, b.cov) and (ea is None) == (eb is None)
            and (ea is None or eb is None or _agree_each(
                (ea.a_m, ea.b_m, ea.az_deg), (eb.a_m, eb.b_m, eb.az_deg))))


def probe(grid: TMGrid) -> str | None:
    """Why the compiled filter is not used (None: it is): a few cycles of a coloured filter
    (prediction, sensor update, LSE and depth update with the gate, estimates on ``grid``, the
    prior) both ways, agreeing within the tolerance contract."""
    from engine.filter.measurements import depth_sensor_rows, sensor_rows
    from engine.filter.params import FilterParams

    if KP is None or KU is None:
        return native.status("kalman_predict" if KP is None else "kalman_update")
    params = FilterParams(coloured=True, p0="physical")
    x0, y0 = grid.forward(52.8, 3.9)
    fast = ref = init_state(0.0, x0, y0, 30.0, 5.0, 1.2, 0.01, 0.2, -0.1, params,
                            from_sensors=(True, True, True))
    C = np.array([[400.0, 120.0], [120.0, 250.0]])
    for k, (dt, heading) in enumerate(((10.0, 1.25), (0.5, 1.31), (60.0, 6.27))):
        zs, var, layout = sensor_rows(None, 5.1 + 0.1 * k, heading, 0.012, params)
        uf, ur = update_rows(fast, zs, var, layout, params), ref_update.update_rows(
            ref, zs, var, layout, params)
        if not _same_update(uf, ur):
            return f"first-use probe failed (sensor update, cycle {k})"
        pf = predict_estimate(uf.state, dt, params, "KF", grid)
        pr = ref_estimate.predict_estimate(ur.state, dt, params, "KF", grid)
        if not (_same_state(pf[0], pr[0]) and _agree(pf[1], pr[1])
                and _same_estimate(pf[2], pr[2])):
            return f"first-use probe failed (prediction, cycle {k})"
        if not (_same_state(predict_step(uf.state, dt, params)[0], pr[0])):
            return f"first-use probe failed (predict_step, cycle {k})"
        (xf, yf), prior_f = filter_prior(pf[0])
        (xr, yr), prior_r = ref_estimate.filter_prior(pr[0])
        if not (_agree_each((xf, yf, prior_f.x_m, prior_f.y_m),
                            (xr, yr, prior_r.x_m, prior_r.y_m))
                and _agree(prior_f.cov, prior_r.cov)):
            return f"first-use probe failed (prior, cycle {k})"
        fx, fy = xr + 40.0 * (k - 1), yr - 25.0 * k
        mf = lse_measurement(fx, fy, C * (1 + k), params)
        mr = ref_measurements.lse_measurement(fx, fy, C * (1 + k), params)
        if not all(_agree(getattr(mf, f), getattr(mr, f)) for f in ("z", "H", "R", "bias_cov")):
            return f"first-use probe failed (LSE rows, cycle {k})"
        depth = depth_sensor_rows(31.0 + k, params)
        gf = update_rows_gated(pf[0], *depth, mf, params)
        gr = ref_update.update_rows_gated(pr[0], *depth, mr, params)
        if not (_same_update(gf[0], gr[0]) and _agree(gf[1], gr[1])):
            return f"first-use probe failed (gated update, cycle {k})"
        u1, u2 = update(pf[0], mf, params), ref_update.update(pr[0], mr, params)
        if not (_same_update(u1, u2) and _agree(innovation_distance(u1, slice(0, None)),
                                                ref_update.innovation_distance(u2))):
            return f"first-use probe failed (update, cycle {k})"
        if not _same_estimate(filter_estimate("KF", grid, gf[0].state),
                              ref_estimate.filter_estimate("KF", grid, gr[0].state)):
            return f"first-use probe failed (estimate, cycle {k})"
        fast, ref = gf[0].state, gr[0].state
    return None


def probe_freeze() -> str | None:
    """Why the compiled :func:`freeze_result` is not used (None: it is): the arrays of two
    updates and a Φ made read-only by it, as the reference makes them."""
    from engine.filter.params import FilterParams

    params = FilterParams()
    state = init_state(0.0, 0.0, 0.0, 0.0, 1.0, 0.5, 0.0, 0.0, 0.0, params)
    rows = ref_measurements.lse_measurement(1.0, 2.0, np.eye(2) * 25.0, params)
    u1, u2 = ref_update.update(state, rows, params), ref_update.update(state, rows, params)
    phi = np.eye(3)
    _FREEZE(None, phi, u1, u2)
    arrays = (phi, *(a for u in (u1, u2) for a in (u.innovation, u.S, u.K, u.ls.l_inv, u.ls.w)))
    if any(a.flags.writeable for a in arrays):
        return "first-use probe failed (an array left writeable)"
    return None


def probe_make() -> str | None:
    """Why the compiled constructor of the cycle's dataclasses (:func:`slots_maker`) is not used
    (None: it is): a :class:`PositionEstimate` made by it equals the class's own."""
    cov = np.eye(2)
    args = ("KF", 52.0, 3.0, 1.0, 2.0, 3.0, cov, None)
    got, want = slots_maker(PositionEstimate)(*args), PositionEstimate(*args)
    if type(got) is not PositionEstimate or any(
            getattr(got, f) is not getattr(want, f) for f in PositionEstimate.__slots__):
        return "first-use probe failed (a field not set)"
    return None

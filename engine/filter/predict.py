"""Time update of the filter (6.20, 6.13–6.14): one step, a horizon (Kalman ▸ Predict) and the
Φ the smoother needs. Fix-error states decay as e^{−Δt/τ}.
"""

from __future__ import annotations

import math
from types import ModuleType
from typing import Any

import numpy as np

from engine import native
from engine.filter.model import step_constants, step_noise, transition_and_mean
from engine.filter.params import FilterParams, symmetrised
from engine.filter.state import N_NAV, FilterState

_UNRESOLVED = object()
_K: Any = _UNRESOLVED
"""The compiled time update (``engine/native/kalman_predict.c``) once resolved and bound to
numpy's BLAS, or None (not built, stale, ``UVNAV_PURE=1``, or numpy's OpenBLAS not found):
then :func:`_predict_py` runs. Resolved on the first prediction, not at import, because finding
the BLAS addresses loads the OpenBLAS libraries (start-up time)."""


def _kernel() -> ModuleType | None:
    """:data:`_K`, resolving and binding it on first use."""
    global _K
    if _K is _UNRESOLVED:
        _K = native.bound_kernel("kalman_predict")
    return _K


def predict_step(
    state: FilterState, dt: float, params: FilterParams
) -> tuple[FilterState, np.ndarray]:
    """Propagate x̂ and P over Δt s (6.20a/b, re-linearised at x̂ₖ|ₖ); returns (state, Φ used).

    Fix-error states decay as e^{−Δt/τ} with exact noise C_ij (1 − e^{−Δt(1/τ_i + 1/τ_j)}).
    """
    k = _K if _K is not _UNRESOLVED else _kernel()
    if k is not None and dt > 0.0:  # _predict(state, dt, params, True) inline (every cycle)
        c, fd = _step_memos(state, dt, params)
        # the kernel's x and P (new, read-only) in state._with_frozen(state.t + dt, x, P),
        # made by the kernel too: (new state, Φ)
        r = k.predict(state.x, state.P, c, fd, state.fix_cov, True, state, FilterState,
                      state.t + dt)
        if r is not None:
            return r  # type: ignore[no-any-return]
    return _predict(state, dt, params, True)


def predict_step_position(
    state: FilterState, dt: float, params: FilterParams, source: str, packed: object
) -> tuple[FilterState, np.ndarray, Any]:
    """:func:`predict_step` and the estimate ``position(source, packed, x, P)`` of the
    predicted state (``engine.run.cycle.filter_estimate`` with the compiled ``position``, grid
    ``packed`` = ``TMGrid._packed``) in one compiled call: (state, Φ, estimate). The estimate
    is None where the kernel does not make it (not built, declining, ``position`` not bound):
    the caller makes it as before."""
    k = _K if _K is not _UNRESOLVED else _kernel()
    if k is not None and dt > 0.0:  # predict_step's kernel call, with the position
        c, fd = _step_memos(state, dt, params)
        r = k.predict(state.x, state.P, c, fd, state.fix_cov, True, state, FilterState,
                      state.t + dt, source, packed)
        if r is not None:
            return r  # type: ignore[no-any-return]
    new, phi = _predict(state, dt, params, True)
    return new, phi, None


def _step_memos(state: FilterState, dt: float, params: FilterParams) -> tuple[Any, Any]:
    """The kernel's step constants for Δt s and the fix states' decay (None without fix
    states): ``step_constants(params, dt)`` and ``c.fix_decay(state.fix_tau_s)``, their memos
    read first (every cycle)."""
    c = params._memo.get(dt)
    if c is None:
        c = step_constants(params, dt)
    fd = None
    if state.fix_states:
        fd = c.fix.get(state.fix_tau_s)
        if fd is None:
            fd = c.fix_decay(state.fix_tau_s)
    return c, fd


def predict(state: FilterState, dt: float, params: FilterParams) -> FilterState:
    """x̂ₖ₊₁|ₖ, Pₖ₊₁|ₖ after Δt s (6.20; 6.13–6.14 when no update follows)."""
    return _predict(state, dt, params, False)[0]


def _predict(
    state: FilterState, dt: float, params: FilterParams, want_phi: bool
) -> tuple[FilterState, np.ndarray]:
    """Shared propagation; the full n×n Φ is assembled only if ``want_phi`` (else Φ_nav).

    Φ_nav, Q_d and the mean come from :func:`transition_and_mean` and :func:`step_noise` with
    the step's constants (built once per Δt); the products are those of 6.20b, block by block.
    The compiled kernel does the same operations in one call (same bits); :func:`_predict_py`
    is the Python it mirrors, run where the kernel is not available or declines the inputs.
    """
    if dt < 0.0:
        raise ValueError(f"negative time step {dt} s")
    if dt == 0.0:
        return state, np.eye(state.n)
    k = _K if _K is not _UNRESOLVED else _kernel()
    if k is not None:
        c = step_constants(params, dt)
        fd = c.fix_decay(state.fix_tau_s) if state.fix_states else None
        r = k.predict(state.x, state.P, c, fd, state.fix_cov, want_phi)
        if r is not None:  # the kernel's x and P are new and read-only already
            return state._with_frozen(state.t + dt, r[0], r[1]), r[2]
    return _predict_py(state, dt, params, want_phi)


def _predict_py(
    state: FilterState, dt: float, params: FilterParams, want_phi: bool
) -> tuple[FilterState, np.ndarray]:
    """:func:`_predict` in Python and numpy (Δt > 0): the reference of the compiled kernel."""
    c = step_constants(params, dt)
    P = state.P
    xs = state.x.tolist()
    Phi = transition_and_mean(xs, c)
    Qd = step_noise(Phi, c)
    if not state.fix_states:
        Pn = Phi.dot(P).dot(Phi.T)
        Pn += Qd
        return state._with(state.t + dt, np.array(xs), symmetrised(Pn)), Phi
    # Augmented: Φ = blockdiag(Φ_nav, D), D = diag(e^{−Δt/τ}); done block by block.
    fd = c.fix_decay(state.fix_tau_s)
    for i, di in enumerate(fd.d_list, start=N_NAV):
        xs[i] = xs[i] * di
    n = len(xs)
    Pn = np.empty((n, n))
    np.add(Phi.dot(P[:N_NAV, :N_NAV]).dot(Phi.T), Qd, out=Pn[:N_NAV, :N_NAV])
    Pnb = Pn[:N_NAV, N_NAV:]
    np.multiply(Phi.dot(P[:N_NAV, N_NAV:]), fd.d, out=Pnb)
    Pn[N_NAV:, :N_NAV] = Pnb.T
    Pbb = Pn[N_NAV:, N_NAV:]
    np.multiply(P[N_NAV:, N_NAV:], fd.dd, out=Pbb)
    Pbb += state.fix_cov * fd.one_minus_dd
    if want_phi:
        full = fd.phi.copy()
        full[:N_NAV, :N_NAV] = Phi
        Phi = full
    return state._with(state.t + dt, np.array(xs), symmetrised(Pn)), Phi


def predict_horizon(
    state: FilterState, horizon_s: float, step_s: float, params: FilterParams
) -> list[FilterState]:
    """Kalman ▸ Predict (THEORY §8.15): N = ceil(T/h) steps of h s, the last one shortened so
    the steps sum to T s exactly. Returns the N predicted states; the input is untouched."""
    if step_s <= 0.0 or horizon_s <= 0.0:
        raise ValueError("horizon and step must be positive (s)")
    step = min(step_s, horizon_s)
    n_steps = max(1, math.ceil(horizon_s / step - 1e-9))
    out: list[FilterState] = []
    s = state
    for i in range(n_steps):
        dt = step if i < n_steps - 1 else horizon_s - step * (n_steps - 1)
        s = predict(s, dt, params)
        out.append(s)
    return out

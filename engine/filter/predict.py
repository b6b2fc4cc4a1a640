"""Time update of the filter (6.20, 6.13–6.14): one step, a horizon (Kalman ▸ Predict) and the
Φ the smoother needs. Fix-error states decay as e^{−Δt/τ}.
"""

from __future__ import annotations

import math

import numpy as np

from engine.filter.model import step_constants, step_noise, transition_and_mean
from engine.filter.params import FilterParams, symmetrised
from engine.filter.state import N_NAV, FilterState


def predict_step(
    state: FilterState, dt: float, params: FilterParams
) -> tuple[FilterState, np.ndarray]:
    """Propagate x̂ and P over Δt s (6.20a/b, re-linearised at x̂ₖ|ₖ); returns (state, Φ used).

    Fix-error states decay as e^{−Δt/τ} with exact noise C_ij (1 − e^{−Δt(1/τ_i + 1/τ_j)}).
    """
    return _predict(state, dt, params, True)


def predict(state: FilterState, dt: float, params: FilterParams) -> FilterState:
    """x̂ₖ₊₁|ₖ, Pₖ₊₁|ₖ after Δt s (6.20; 6.13–6.14 when no update follows)."""
    return _predict(state, dt, params, False)[0]


def _predict(
    state: FilterState, dt: float, params: FilterParams, want_phi: bool
) -> tuple[FilterState, np.ndarray]:
    """Shared propagation; the full n×n Φ is assembled only if ``want_phi`` (else Φ_nav).

    Φ_nav, Q_d and the mean come from :func:`transition_and_mean` and :func:`step_noise` with
    the step's constants (built once per Δt); the products are those of 6.20b, block by block.
    """
    if dt < 0.0:
        raise ValueError(f"negative time step {dt} s")
    if dt == 0.0:
        return state, np.eye(state.n)
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
    Pn[:N_NAV, :N_NAV] = Phi.dot(P[:N_NAV, :N_NAV]).dot(Phi.T) + Qd
    Pn[:N_NAV, N_NAV:] = Phi.dot(P[:N_NAV, N_NAV:]) * fd.d
    Pn[N_NAV:, :N_NAV] = Pn[:N_NAV, N_NAV:].T
    Pn[N_NAV:, N_NAV:] = P[N_NAV:, N_NAV:] * fd.dd + state.fix_cov * fd.one_minus_dd
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

"""Process-noise variances from physical limits (thesis ch. 6, eq. 6.35; THEORY §8.9): pure
arithmetic, no NumPy, so the run configuration (:mod:`engine.run.config`) can compute its
defaults without loading the filter (console start-up time). :mod:`engine.filter.params`
re-exports both."""

from __future__ import annotations

import math

from engine.geodesy.angles import TWO_PI


def accel_variance(a_max: float, p_max: float, p_zero: float) -> float:
    """σ_a² (m²/s⁴) of Gelb's mixed acceleration pdf, eq. 6.35: (a_max²/3)(1 + 4 p_max − p_0)."""
    return a_max * a_max / 3.0 * (1.0 + 4.0 * p_max - p_zero)


def current_rate_variance(v_cm_ms: float, period_s: float) -> float:
    """σ_vc² (m²/s⁴) per current component, THEORY §8.9: σ = ½ V_cm (ω_v + ω_ψ), ω = 2π/period."""
    omega = TWO_PI / period_s
    return (0.5 * v_cm_ms * 2.0 * omega) ** 2


def tidal_current_psd(v_cm_ms: float, period_s: float, horizon_s: float) -> float:
    """Spectral density q (m²/s³) of a random-walk current per component whose variance over
    ``horizon_s`` equals that of a tidal stream's change, THEORY §8.9: a component
    V_cm cos(ωt + φ) with φ uniform changes over h by a variance V_cm²(1 − cos ωh); a random
    walk by q·h. So q = V_cm²(1 − cos ωh)/h, ω = 2π/period (s)."""
    omega = TWO_PI / period_s
    return v_cm_ms * v_cm_ms * (1.0 - math.cos(omega * horizon_s)) / horizon_s

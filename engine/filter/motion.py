"""Process noise of the COG/SOG stand-in learnt from the course and speed over ground it saw.

With ``sensors.cog_sog = "standin"`` the filter's heading and speed states are the course and
speed over ground, driven by white heading-rate and acceleration noise (Q of eq. 6.34: q_ψ =
(½ ψ̇_max)², q_v = σ_a²; with ``q_mode = "vanloan"`` spectral densities, THEORY D24). In a GNSS
outage the COG/SOG rows go with the fixes, so the outage's ellipse is set by that noise alone.
A yacht sailing a straight leg on open water and one tacking among islands differ by a factor
of ten in how much their course changes in ten minutes, and the COG/SOG history before the
outage shows which one this is (docs/REALDATA.md, "Where the ellipse fails").

Method: for a random walk ψ with spectral density q, E[(ψ(t+T) − ψ(t))²] = q·T, so the
squared change of the course over a lag T, divided by T, is an unbiased estimate of q
(likewise the speed's for σ_a²). A tack is a jump, not a random walk; a jump process of rate ν
and size J gives E[Δψ²]/T = ν·J² for every T, the same q a random walk would need to spread as
far, so a **mean** (not a robust statistic: the tacks must count) of these estimates over the
last ``window_s`` is what the filter takes. Every ``step_s`` a sample is kept; the change over
the lag from the kept sample T to T + ``step_s`` seconds old gives one estimate (overlapping
lags, Δt ≥ T):

    r_ψ = min(Δψ², window_s·q_cap) / Δt
    q_ψ ← q_ψ + (step / min(t_learnt, window_s))·(r_ψ − q_ψ)       (step: time since the last)

(a time-weighted running mean at first, an exponential window of ``window_s`` later). The clip
lets one event lift the mean by at most the cap (it is in T/step estimates, each weighted
step/window_s), so a COG that jumps (a receiver glitch, a wrong sentence) cannot hold it high
for longer than a window; it is counted. A COG is taken only at ``sensors.cog_min_sog_kn`` or
more (a COG at SOG ≈ 0 is the direction of the position noise, not a course: those samples are
skipped and counted, and the lags start again), and a gap of more than ``gap_s`` between kept
samples starts them again (a course change over a long gap can wrap past 180°).

The value applied is the cap (the configured ``turn_rate_max_deg_s`` / ``sigma_a2``) until
``min_s`` seconds have been learnt, then the learnt one held within [floor, cap]. The floor of
q_v is a third of its cap (:data:`ACCEL_FLOOR_OF_CAP`: a yacht's speed changes at once, after
no warning in its history). The floor of q_ψ (and the least floor of q_v) is
the resolution of the estimate itself: the stand-in's own measurement noise over one lag,
2σ²/T, with σ the least COG σ (:data:`engine.systems.sensors.COG_SIGMA_MIN_DEG`, 3°) and the
GNSS velocity σ (:data:`engine.systems.sensors.GNSS_VELOCITY_SIGMA_MS`, 0.1 m/s) of
docs/GNSS_WEIGHTS.md: below it a straight course and a noisy one cannot be told apart. The
estimate includes that noise, so it errs on the large (cautious) side. In an outage nothing is
learnt and the value in force is held: the ellipse still grows with the time since the last fix.

Pure functions of immutable values; angles in degrees, speeds m/s, times s, q_ψ in deg²/s,
q_v in m²/s³ (σ_a² of a 1-s step).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from datetime import datetime

from engine.systems.sensors import COG_SIGMA_MIN_DEG, GNSS_VELOCITY_SIGMA_MS

__all__ = ["MotionSettings", "MotionState", "applied", "learn", "start", "turn_rate_max_deg_s"]

LAG_S = 300.0
"""T, the lag of one estimate (s): long against the receiver's COG smoothing and the yaw with
the waves (seconds), of the order of the 5–10-minute outage it must describe."""
STEP_S = 60.0
"""How often a sample is kept and an estimate made (s): T/step = 5 overlapping lags."""
WINDOW_S = 3600.0
"""The averaging window (s): an hour holds several tacks of a beat to windward and keeps a
tacking spell in mind through a straight leg between two."""
MIN_S = 1200.0
"""Seconds learnt before the learnt value replaces the cap."""
GAP_S = 3.0 * STEP_S
"""A gap between kept samples longer than this (s, an outage or a stop) starts the lags again."""

ACCEL_FLOOR_OF_CAP = 1.0 / 3.0
"""The least σ_a² as a share of the cap. A sailing yacht's speed over ground is steady for long
spells and then changes at once (a sail change, heaving to, a stop), which its history need
not show: on the Plaka log (docs/REALDATA.md) the yacht slows from 5 kn to a stop after an
hour at a steady speed, and with the SOG's resolution floor alone (6.7·10⁻⁵ m²/s⁴) only 74 %
of the 10-minute windows hold the truth; a third of the thesis' σ_a² (eq. 6.35) holds 89 %.
A measured value [assumption], not a cited one: the cautious side of the two."""

_Sample = tuple[datetime, float, float]
"""(time, COG deg, SOG m/s)."""


@dataclass(frozen=True, slots=True)
class MotionSettings:
    """Bounds of the learnt process noise: caps (the configured values) and floors, q_ψ in
    deg²/s and q_v in m²/s³; the lag, step, window, least learnt time and gap in s."""

    turn_cap: float
    accel_cap: float
    turn_floor: float = 2.0 * COG_SIGMA_MIN_DEG**2 / LAG_S
    accel_floor: float = 2.0 * GNSS_VELOCITY_SIGMA_MS**2 / LAG_S
    """The SOG's resolution floor; :meth:`of` raises it to :data:`ACCEL_FLOOR_OF_CAP` of the
    cap."""
    lag_s: float = LAG_S
    step_s: float = STEP_S
    window_s: float = WINDOW_S
    min_s: float = MIN_S
    gap_s: float = GAP_S

    @classmethod
    def of(cls, turn_rate_max_deg_s: float, sigma_a2: float) -> MotionSettings:
        """The settings whose caps are the filter's ψ̇_max (deg/s, σ = ½ of it) and σ_a²;
        a floor above its cap is lowered to the cap."""
        turn_cap = (0.5 * turn_rate_max_deg_s) ** 2
        s = cls(turn_cap, sigma_a2)
        return cls(turn_cap, sigma_a2, min(s.turn_floor, turn_cap),
                   min(max(s.accel_floor, ACCEL_FLOOR_OF_CAP * sigma_a2), sigma_a2))


@dataclass(frozen=True, slots=True)
class MotionState:
    """The learnt heading-rate and acceleration noise of the stand-in.

    ``q_turn`` (deg²/s) and ``q_accel`` (m²/s³): the running means; ``seconds``: time learnt
    over; ``n``: estimates made; ``clipped``: estimates whose change hit the clip; ``skipped``:
    COG samples not taken (SOG below ``cog_min_sog_kn``, or not finite); ``kept``: the
    samples of the last T + step seconds, oldest first."""

    q_turn: float = 0.0
    q_accel: float = 0.0
    seconds: float = 0.0
    n: int = 0
    clipped: int = 0
    skipped: int = 0
    kept: tuple[_Sample, ...] = ()
    turn_rate_max_deg_s: float = 0.0
    """ψ̇_max (deg/s) in force: 2 √q_ψ (:func:`applied`), the filter's σ_ψ̇ being ½ of it."""
    sigma_a2: float = 0.0
    """σ_a² (m²/s⁴ of a 1-s step) in force (:func:`applied`)."""


def start(settings: MotionSettings) -> MotionState:
    """Nothing learnt yet: the caps apply."""
    return MotionState(turn_rate_max_deg_s=turn_rate_max_deg_s(settings.turn_cap),
                       sigma_a2=settings.accel_cap)


def learn(state: MotionState, settings: MotionSettings, time: datetime,
          cog_deg: float | None, sog_ms: float | None, cog_usable: bool) -> MotionState:
    """One record's COG/SOG (module docstring): kept every ``step_s``, and then an estimate
    over the lag to the kept sample T to T + step old. ``cog_usable`` False (SOG below the
    COG threshold) or a missing or non-finite value skips the sample and starts the lags
    again; a record with neither COG nor SOG (an outage) changes nothing."""
    if cog_deg is None and sog_ms is None:
        return state
    if cog_deg is None or sog_ms is None or not cog_usable or not (
            math.isfinite(cog_deg) and math.isfinite(sog_ms)):
        return replace(state, skipped=state.skipped + 1, kept=())
    kept = state.kept
    here = (time, cog_deg, sog_ms)
    if not kept:
        return replace(state, kept=(here,))
    step = (time - kept[-1][0]).total_seconds()
    if step < settings.step_s:
        return state
    if step > settings.gap_s:
        return replace(state, kept=(here,))
    lag = settings.lag_s
    ages = [(time - k[0]).total_seconds() for k in kept]
    old = [i for i, a in enumerate(ages) if a >= lag]
    if not old:
        return replace(state, kept=kept + (here,))
    i = old[-1]  # the youngest sample at least T old
    dt, base = ages[i], kept[i]
    new_kept = kept[i + 1:] + (here,)
    d_psi = (cog_deg - base[1] + 180.0) % 360.0 - 180.0
    d_v = sog_ms - base[2]
    sq_psi, sq_v = d_psi * d_psi, d_v * d_v
    lim_psi, lim_v = settings.window_s * settings.turn_cap, settings.window_s * settings.accel_cap
    clipped = state.clipped + (sq_psi > lim_psi or sq_v > lim_v)
    r_psi = min(sq_psi, lim_psi) / dt
    r_v = min(sq_v, lim_v) / dt
    seconds = state.seconds + step
    g = step / min(seconds, settings.window_s)
    new = MotionState(state.q_turn + g * (r_psi - state.q_turn),
                      state.q_accel + g * (r_v - state.q_accel),
                      seconds, state.n + 1, clipped, state.skipped, new_kept)
    qt, qa = applied(new, settings)
    return replace(new, turn_rate_max_deg_s=turn_rate_max_deg_s(qt), sigma_a2=qa)


def applied(state: MotionState | None, settings: MotionSettings) -> tuple[float, float]:
    """(q_ψ deg²/s, q_v m²/s³) in force: the caps until ``min_s`` has been learnt, then the
    learnt values within [floor, cap]."""
    if state is None or state.seconds < settings.min_s:
        return settings.turn_cap, settings.accel_cap
    qt = min(max(state.q_turn, settings.turn_floor), settings.turn_cap)
    qa = min(max(state.q_accel, settings.accel_floor), settings.accel_cap)
    return qt, qa


def turn_rate_max_deg_s(q_turn: float) -> float:
    """ψ̇_max (deg/s) of FilterParams whose σ (½ of it) has variance ``q_turn`` (deg²/s)."""
    return 2.0 * math.sqrt(q_turn)

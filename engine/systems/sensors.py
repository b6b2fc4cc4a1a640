"""Bounded-sensor conversions: log, gyro, inclinometer and the pressure-crystal depth sensor.

References: thesis §3.1 eq. 3.2–3.3 (pressure), §7.2 (conversions, L5541–5550), THEORY §3.7–3.8.
"""

from __future__ import annotations

import math

SENSOR_NAMES = ("gyro", "log", "rudder", "inclinometer", "pressure", "echosounder")
"""The bounded sensors in the order of A8.2 ``Sensors[]`` and of ``SensorValues.status``."""

SENSOR_STATUS = {"off": 0, "on": 1, "n/a": 2}
"""Sensor state word of the configuration → A8.2 status code: 0 connected but off, 1 on,
2 not connected (L8729–8731). The one map of the engine and the console."""

SENSOR_STATUS_WORD = {code: word for word, code in SENSOR_STATUS.items()}
"""A8.2 status code → the state word ("off", "on", "n/a"), as Pg 620 shows it."""

KNOT_MS = 1852.0 / 3600.0
"""One knot in m/s (1 nm = 1852 m exactly; the samples prove this factor, THEORY §14.1)."""

NM_M = 1852.0
"""One nautical mile in metres."""

PSI_PA = 6894.757
"""α of eq. 3.2: pascal per psi."""

CRYSTAL_F0_HZ = 40_000.0
"""Vacuum frequency f0 of the pressure crystal (Hz, thesis eq. 3.2)."""

CRYSTAL_A_PSI = 9750.0
"""Calibration coefficient A of eq. 3.2 (psi)."""

CRYSTAL_B_PSI = 5000.0
"""Calibration coefficient B of eq. 3.2 (psi)."""

BETA_M_PA = 1.0 / (1000.0 * 9.80665)
"""β of eq. 3.3: metres of fresh water per pascal (101.9716·10⁻⁶ m/Pa)."""

STANDARD_ATMOSPHERE_PA = 101_325.0
"""Surface pressure assumed when no reference frequency is configured (Pa)."""


def knots_to_ms(speed_kn: float) -> float:
    """Convert a log speed in knots to m/s (× 1852/3600)."""
    return speed_kn * KNOT_MS


def crystal_pressure_pa(freq_hz: float) -> float:
    """Absolute pressure (Pa) from the crystal frequency: P = α[A(1 − f/f0) − B(1 − f/f0)²]
    (eq. 3.2 as read in THEORY D41)."""
    u = 1.0 - freq_hz / CRYSTAL_F0_HZ
    return PSI_PA * (CRYSTAL_A_PSI * u - CRYSTAL_B_PSI * u * u)


def crystal_frequency_hz(pressure_pa: float) -> float:
    """Inverse of :func:`crystal_pressure_pa`: the crystal frequency (Hz) at ``pressure_pa``.

    Solves B u² − A u + P/α = 0 for the root with small u (the branch the sensor works on).
    """
    p_psi = pressure_pa / PSI_PA
    disc = CRYSTAL_A_PSI * CRYSTAL_A_PSI - 4.0 * CRYSTAL_B_PSI * p_psi
    if disc < 0.0:
        raise ValueError(f"pressure {pressure_pa:.0f} Pa is beyond the crystal's range")
    u = (CRYSTAL_A_PSI - math.sqrt(disc)) / (2.0 * CRYSTAL_B_PSI)
    return CRYSTAL_F0_HZ * (1.0 - u)


def surface_reference_hz(ref_freq_hz: float = 0.0) -> float:
    """The surface reference frequency: ``ref_freq_hz`` if set (> 0), else the frequency at one
    standard atmosphere (101 325 Pa)."""
    return ref_freq_hz if ref_freq_hz > 0.0 else crystal_frequency_hz(STANDARD_ATMOSPHERE_PA)


def pressure_depth_m(freq_hz: float, ref_freq_hz: float, s_weight: float = 1.026) -> float:
    """Depth (m, positive down) from the crystal frequency: d = (β/γ)(P − P_ref) (eq. 3.3), with
    γ = ``s_weight`` (specific weight of sea water) and P_ref from the surface frequency
    (:func:`crystal_pressure_pa` of both written out: the same operations, once a cycle)."""
    u = 1.0 - freq_hz / CRYSTAL_F0_HZ
    p = PSI_PA * (CRYSTAL_A_PSI * u - CRYSTAL_B_PSI * u * u)
    u = 1.0 - ref_freq_hz / CRYSTAL_F0_HZ
    p_ref = PSI_PA * (CRYSTAL_A_PSI * u - CRYSTAL_B_PSI * u * u)
    return BETA_M_PA / s_weight * (p - p_ref)


def depth_to_frequency_hz(depth_m: float, ref_freq_hz: float, s_weight: float = 1.026) -> float:
    """Crystal frequency (Hz) that :func:`pressure_depth_m` turns into ``depth_m`` (simulator)."""
    p = crystal_pressure_pa(ref_freq_hz) + depth_m * s_weight / BETA_M_PA
    return crystal_frequency_hz(p)


COG_SIGMA_MIN_DEG = 3.0
"""Least σ (deg) of a course over ground standing in for the gyro heading (``sensors.cog_sog``):
COG follows the antenna's track, which yaws and sways with the sea, and receivers smooth it
over seconds, so it lags in a turn; against the gyro's 0.65° (L1429) — docs/GNSS_WEIGHTS.md."""

GNSS_VELOCITY_SIGMA_MS = 0.1
"""σ (m/s) of a GNSS velocity component as a stand-in (Doppler noise of a few cm/s plus the
antenna's wave motion): it makes the COG σ grow as atan(σ_v / SOG) at low speed and is the
least σ of a SOG stand-in (docs/GNSS_WEIGHTS.md)."""

SOG_SIGMA_FRAC = 0.03
"""σ of a SOG stand-in as a fraction of the speed (surge with the waves; the EM log's is 0.02,
eq. 4.19)."""


def standin_sigmas(sog_kn: float) -> tuple[float, float]:
    """(σ of a COG stand-in in degrees, σ of a SOG stand-in in m/s) at ``sog_kn`` knots:
    max(:data:`COG_SIGMA_MIN_DEG`, atan(σ_v / SOG)) and max(σ_v, :data:`SOG_SIGMA_FRAC`·SOG),
    σ_v = :data:`GNSS_VELOCITY_SIGMA_MS`."""
    sog_ms = abs(knots_to_ms(sog_kn))
    cog = max(COG_SIGMA_MIN_DEG, math.degrees(math.atan2(GNSS_VELOCITY_SIGMA_MS, sog_ms)))
    return cog, max(GNSS_VELOCITY_SIGMA_MS, SOG_SIGMA_FRAC * sog_ms)

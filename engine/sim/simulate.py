"""Sensor simulator: a scenario (:mod:`engine.sim.scenario`) → ``.RUN`` records plus the truth.

The true vessel is propagated kinematically on the TM grid of the working datum (k0 = 1, no
false origin, CM fixed for the whole run at the start longitude rounded, thesis L6482–6490):
grid heading = true heading − convergence γ, velocity through the water v·cos ε along it, plus
the current (true set rotated by −γ), all times the point scale k (THEORY §8.4–8.5, eq. 6.25).
Heading, speed and depth follow each leg's targets as rate-limited ramps (turn rate, acceleration,
dive/climb rate; pitch ε = asin(ż/v), bow-down positive, |ε| ≤ ``max_pitch_deg``); positions are
integrated with the midpoint rule on ≤ 0.25-s sub-steps.

Each record's readings come from the truth at that epoch with the scenario's error models:

* GPS: grid error (E, N) = first-order Gauss–Markov (exact discretisation e_{k+1} = ρe_k + w,
  ρ = e^{−Δt/τ}, Var w = σ²(1 − ρ²), stationary start; THEORY §8.2) + white; the erroneous
  point is converted to ``run_gps_datum`` so that the program's conversion (h = 0 on the GPS
  datum, THEORY §2.1–2.2) gives it back exactly.
* Decca: total lane counts N from :func:`engine.systems.decca.decca_geometry` at the truth plus
  σ_scale·L·u + white, where L is the Cholesky factor of the A4 lane VCV
  (:func:`engine.systems.decca.decca_vcv_lanes`, thesis A4.1–A4.3) at the true position and u a
  vector
  of three unit Gauss–Markov processes: the error has exactly the A4 covariance at every epoch and
  the patterns are correlated through the shared master term. The fraction written is N mod 1.
* gyro: bias + Gauss–Markov + white (deg); EM log: v(1 + s) + b + N(0, (σ_f v)²) (kn, ≥ 0);
  inclinometer: pitch + bias + white (deg); pressure: depth + bias + white (m) written as the
  crystal frequency (eq. 3.2–3.3 inverted, :func:`engine.systems.sensors.depth_to_frequency_hz`);
  echo sounder: water depth − depth + N(0, (a + b·d)²) (m, ≥ 0); rudder: ``rudder_gain_s`` ×
  rate of turn (deg, +starboard, ±35°, display only).

GPS and Decca are written only on surfaced legs while depth ≤ ``fix_depth_max_m``; otherwise
``-``. The yielded :class:`engine.io.runfile.RunRecord` holds the *unquantised* readings (for
statistics) and ``raw`` = the line :func:`engine.io.runfile.format_run_record` writes (quantised to
0.001″, 0.001 lane, 0.1°, 0.1 kn, 0.01°, 0.001 Hz, 0.01 m).

Randomness: ``numpy.random.default_rng(seed)`` only, 6 draws for the stationary starts, then 16
per epoch in a fixed layout whether or not a sensor is used, so the same seed always gives the
same bytes (on the same platform and library versions).
"""

from __future__ import annotations

import dataclasses
import math
import os
import secrets
from collections.abc import Iterator
from dataclasses import dataclass
from datetime import datetime, timedelta
from pathlib import Path

import numpy as np

from engine.errors import InputError
from engine.geodesy.angles import wrap_180_deg
from engine.geodesy.ellipsoid import WGS84, Datum
from engine.geodesy.ellipsoidal import DatumShift, GeodesicSolver, datum_shift
from engine.geodesy.tmgrid import TMGrid, central_meridian_deg
from engine.io.datumfile import DatumFile, read_datum_file
from engine.io.deccafile import DeccaChain, read_chain_file
from engine.io.outputs import OutputFile
from engine.io.runfile import RunRecord, format_run_record
from engine.sim.nmea import SimNmea
from engine.sim.scenario import Leg, Scenario
from engine.systems.decca import ChainOnGrid, decca_geometry, decca_vcv_lanes, place_chain
from engine.systems.sensors import KNOT_MS, depth_to_frequency_hz, surface_reference_hz

__all__ = [
    "TRUTH_COLUMNS",
    "SimulationSetup",
    "SimulationSummary",
    "TruthRow",
    "format_truth_row",
    "read_data_files",
    "simulate",
    "simulation_setup",
    "truth_header",
    "write_simulation",
]

SUBSTEP_S = 0.25
"""Longest integration sub-step (s)."""

RUDDER_LIMIT_DEG = 35.0
"""Largest rudder angle written (deg)."""

N_DRAWS = 16
"""Standard normal draws per epoch (fixed layout, see :func:`_run`)."""

_CHUNK = 1024

TRUTH_COLUMNS: tuple[str, ...] = (
    "time", "lat_wgs84", "lon_wgs84", "lat", "lon", "x", "y", "depth_m", "heading_true_deg",
    "speed_kn", "current_e_ms", "current_n_ms", "surfaced", "pitch_deg",
)
"""Columns of the truth CSV (units in :func:`truth_header`)."""


@dataclass(frozen=True, slots=True)
class TruthRow:
    """The true state at one record's epoch.

    ``lat_deg``/``lon_deg`` geodetic on the working datum; ``lat_wgs84_deg``/``lon_wgs84_deg`` the
    WGS84 position that the program's h = 0 conversion maps onto it; ``x_m``/``y_m`` TM grid of the
    working datum on the run's fixed CM (m); ``depth_m`` positive down; ``heading_true_deg``
    [0, 360); ``speed_kn`` through the water along the hull; ``current_e_ms``/``current_n_ms``
    true east/north (m/s); ``surfaced`` = GPS and Decca received; ``pitch_deg`` bow-down positive.
    """

    time: datetime
    lat_wgs84_deg: float
    lon_wgs84_deg: float
    lat_deg: float
    lon_deg: float
    x_m: float
    y_m: float
    depth_m: float
    heading_true_deg: float
    speed_kn: float
    current_e_ms: float
    current_n_ms: float
    surfaced: bool
    pitch_deg: float


@dataclass(frozen=True, slots=True)
class SimulationSetup:
    """Everything the run needs besides the random numbers: datums, the fixed grid (CM deg), the
    Decca chain placed on it (None when Decca is off) and the pressure reference frequency (Hz)."""

    working: Datum
    gps_datum: Datum
    grid: TMGrid
    geodesic: GeodesicSolver
    placed: ChainOnGrid | None
    press_ref_hz: float

    @property
    def cm_deg(self) -> float:
        """Central meridian of the truth grid (deg)."""
        return self.grid.cm_deg


@dataclass(frozen=True, slots=True)
class SimulationSummary:
    """What :func:`write_simulation` wrote: record count, CM (deg), the paths and the number of
    NMEA sentences (0 without an NMEA log)."""

    n_records: int
    cm_deg: float
    run_path: Path
    truth_path: Path | None
    nmea_path: Path | None = None
    n_sentences: int = 0


# --------------------------------------------------------------------------------------------
# Set-up


def read_data_files(data_dir: str | os.PathLike[str]) -> tuple[DatumFile, dict[str, DeccaChain]]:
    """TO_WGS84.DAT and DECCA.CHN from ``data_dir`` (InputError if missing or bad; each chain's
    datum must be in the datum file, as for a run)."""
    d = Path(data_dir)
    datums = read_datum_file(d / "TO_WGS84.DAT")
    return datums, read_chain_file(d / "DECCA.CHN", known_datums=datums.datums)


def _datum(datums: DatumFile, name: str, field: str) -> Datum:
    try:
        return datums.datum(name)
    except InputError as err:
        if name.strip().upper() == "WGS84":
            return WGS84
        raise InputError(err.message, field=field, text=name) from None


def simulation_setup(
    scenario: Scenario, datums: DatumFile, chains: dict[str, DeccaChain]
) -> SimulationSetup:
    """Resolve datums, build the fixed TM grid (CM = start longitude rounded, A11) and place the
    Decca chain on it (station coordinates shifted to the working datum if the chain's differs).

    Raises InputError (field ``datum``, ``run_gps_datum`` or ``decca.chain``) for unknown names.
    """
    working = _datum(datums, scenario.datum, "datum")
    gps_datum = _datum(datums, scenario.run_gps_datum, "run_gps_datum")
    grid = TMGrid(working.ellipsoid, central_meridian_deg(scenario.start_lon_deg))
    placed = None
    if scenario.decca.on:
        chain = chains.get(scenario.decca.chain)
        if chain is None:
            raise InputError(
                "Unknown Decca chain !", field="decca.chain", text=scenario.decca.chain
            )
        stations = (chain.master, chain.red, chain.green, chain.purple)
        latlon = np.array([[s.lat_deg, s.lon_deg] for s in stations])
        if chain.datum_name.strip().upper() != working.name.strip().upper():
            shift = datum_shift(_datum(datums, chain.datum_name, "decca.chain"), working)
            latlon = np.array([shift.transform(float(a), float(b), 0.0)[:2] for a, b in latlon])
        placed = place_chain(chain, grid, latlon)
    return SimulationSetup(
        working=working,
        gps_datum=gps_datum,
        grid=grid,
        geodesic=GeodesicSolver(working.ellipsoid),
        placed=placed,
        press_ref_hz=surface_reference_hz(scenario.pressure.ref_freq_hz),
    )


class _FromWorking:
    """Working-datum (lat, lon) → (lat, lon) on ``target`` such that the program's conversion
    target → working with h = 0 on the target datum (THEORY §2.1–2.2) returns the input (to < 1 nm;
    two Newton steps on the horizontal residual, whose Jacobian is the identity to ~1e-5)."""

    def __init__(self, working: Datum, target: Datum) -> None:
        same = working.name.strip().upper() == target.name.strip().upper()
        self._shift: DatumShift | None = None if same else datum_shift(target, working)

    def __call__(self, lat_deg: float, lon_deg: float) -> tuple[float, float]:
        shift = self._shift
        if shift is None:
            return lat_deg, lon_deg
        la, lo, _h = shift.inverse(lat_deg, lon_deg, 0.0)
        for _ in range(2):
            f_la, f_lo, _h = shift.transform(la, lo, 0.0)
            la -= f_la - lat_deg
            lo -= f_lo - lon_deg
        return la, lo


# --------------------------------------------------------------------------------------------
# Kinematics


def _vertical_rate(speed_ms: float, depth_m: float, leg: Leg, sin_max_pitch: float) -> float:
    """Signed depth rate (m/s, + down) towards the leg's depth, limited by the pitch bound."""
    diff = leg.depth_m - depth_m
    if abs(diff) < 1e-9:
        return 0.0
    rate = leg.dive_rate_ms if diff > 0.0 else leg.climb_rate_ms
    return math.copysign(min(rate, speed_ms * sin_max_pitch), diff)


def _advance(
    heading: float, speed: float, depth: float, leg: Leg, accel: float, sin_max: float, h: float
) -> tuple[float, float, float]:
    """(true heading deg, speed m/s, depth m) after ``h`` seconds of the leg's ramps."""
    diff = wrap_180_deg(leg.course_deg - heading)  # ±180 → +180: turn to starboard
    step = leg.turn_rate_deg_s * h
    new_heading = leg.course_deg if abs(diff) <= step else (heading + math.copysign(step, diff))
    new_heading %= 360.0
    target = leg.speed_kn * KNOT_MS
    dv = target - speed
    new_speed = target if abs(dv) <= accel * h else speed + math.copysign(accel * h, dv)
    move = _vertical_rate(speed, depth, leg, sin_max) * h
    dz = leg.depth_m - depth
    new_depth = leg.depth_m if abs(dz) <= abs(move) + 1e-9 else depth + move
    return new_heading, new_speed, new_depth


def _leg_schedule(scenario: Scenario) -> list[Leg]:
    """The leg active at each record epoch (leg durations are multiples of the interval)."""
    out: list[Leg] = []
    for leg in scenario.legs:
        out.extend([leg] * (leg.duration_s // scenario.sample_interval_s))
    return out


# --------------------------------------------------------------------------------------------
# The run


def simulate(
    scenario: Scenario,
    datums: DatumFile,
    chains: dict[str, DeccaChain],
    seed: int,
) -> Iterator[tuple[TruthRow, RunRecord]]:
    """Stream (truth, record) pairs, one per epoch t = k·Δt, k = 0 … ``scenario.n_records`` − 1.

    The set-up (datums, grid, chain) is resolved before the first item, so an InputError for an
    unknown datum or chain is raised by this call, not by ``next()``. Same ``seed`` → same output.
    """
    setup = simulation_setup(scenario, datums, chains)
    return _run(scenario, setup, seed)


@dataclass(slots=True)
class _Processes:
    """The unit first-order Gauss–Markov processes of the correlated errors, GPS (E, N), Decca
    (R, G, P) and gyro, with their one-epoch factors ρ = e^{−Δt/τ} and q = √(1 − ρ²)."""

    rho: tuple[float, float, float]
    q: tuple[float, float, float]
    u_gps: np.ndarray
    u_dec: np.ndarray
    u_gyr: float

    @classmethod
    def start(cls, scenario: Scenario, dt: float, rng: np.random.Generator) -> _Processes:
        """Stationary starts (6 draws) for an epoch interval ``dt`` [s]."""
        taus = (scenario.gps.tau_s, scenario.decca.tau_s, scenario.gyro.gm_tau_s)
        rho = tuple(math.exp(-dt / tau) for tau in taus)
        q = tuple(math.sqrt(1.0 - r * r) for r in rho)
        init = rng.standard_normal(6)
        return cls((rho[0], rho[1], rho[2]), (q[0], q[1], q[2]),
                   init[0:2].copy(), init[2:5].copy(), float(init[5]))

    def advance(self, n: np.ndarray) -> None:
        """One epoch on, driven by this epoch's draws ``n`` (layout: module doc)."""
        (r_gps, r_dec, r_gyr), (q_gps, q_dec, q_gyr) = self.rho, self.q
        self.u_gps = r_gps * self.u_gps + q_gps * n[0:2]
        self.u_dec = r_dec * self.u_dec + q_dec * n[4:7]
        self.u_gyr = r_gyr * self.u_gyr + q_gyr * float(n[10])


@dataclass(slots=True)
class _Vessel:
    """The true vessel on the working grid: x, y [m], heading [deg true], speed through the water
    [m/s], depth [m]."""

    x: float
    y: float
    heading: float
    speed: float
    depth: float

    def propagate(self, scenario: Scenario, leg: Leg, gamma: float, kscale: float) -> None:
        """One epoch Δt on (midpoint rule on sub-steps ≤ :data:`SUBSTEP_S`); ``gamma`` is the
        grid convergence [deg] and ``kscale`` the point scale at the epoch's position."""
        dt = float(scenario.sample_interval_s)
        n_sub = max(1, math.ceil(dt / SUBSTEP_S - 1e-12))
        h = dt / n_sub
        accel = scenario.acceleration_ms2
        sin_max = math.sin(math.radians(scenario.max_pitch_deg))
        ang = math.radians(leg.current.set_deg - gamma)
        vc = leg.current.speed_kn * KNOT_MS
        cgx, cgy = vc * math.sin(ang), vc * math.cos(ang)
        heading, speed, depth = self.heading, self.speed, self.depth
        for _ in range(n_sub):
            m_head, m_speed, m_depth = _advance(heading, speed, depth, leg, accel, sin_max, h / 2)
            r = _vertical_rate(m_speed, m_depth, leg, sin_max)
            v_h = math.sqrt(max(m_speed * m_speed - r * r, 0.0))
            psi = math.radians(m_head - gamma)
            self.x += h * kscale * (v_h * math.sin(psi) + cgx)
            self.y += h * kscale * (v_h * math.cos(psi) + cgy)
            heading, speed, depth = _advance(m_head, m_speed, m_depth, leg, accel, sin_max, h / 2)
        self.heading, self.speed, self.depth = heading, speed, depth


def _run(
    scenario: Scenario, setup: SimulationSetup, seed: int
) -> Iterator[tuple[TruthRow, RunRecord]]:
    rng = np.random.default_rng(seed)
    dt = float(scenario.sample_interval_s)
    to_wgs84 = _FromWorking(setup.working, WGS84)
    to_gps = _FromWorking(setup.working, setup.gps_datum)
    proc = _Processes.start(scenario, dt, rng)
    first = scenario.legs[0]
    x, y = setup.grid.forward(scenario.start_lat_deg, scenario.start_lon_deg)
    vessel = _Vessel(x, y, first.course_deg % 360.0, first.speed_kn * KNOT_MS, first.depth_m)
    draws = np.empty((0, N_DRAWS))
    for k, leg in enumerate(_leg_schedule(scenario)):
        row = k % _CHUNK
        if row == 0:
            draws = rng.standard_normal((_CHUNK, N_DRAWS))
        n = draws[row]
        if k > 0:
            proc.advance(n)
        time = scenario.start_time + timedelta(seconds=k * dt)
        truth, gamma, kscale = _truth(scenario, setup, to_wgs84, vessel, leg, time)
        hdop = scenario.gps.hdop_at(k * dt) if scenario.gps.hdop > 0.0 else None
        gps_lat, gps_lon = _gps_reading(scenario, setup, to_gps, vessel, truth.surfaced, proc, n,
                                        hdop)
        decca = _decca_reading(scenario, setup, vessel, truth.surfaced, proc, n, leg)
        rec = RunRecord(k + 1, time, gps_lat, gps_lon, decca,
                        *_sensor_readings(scenario, setup, vessel, leg, truth.pitch_deg, proc, n))
        rec = dataclasses.replace(rec, raw=format_run_record(rec))
        if hdop is not None and gps_lat is not None:  # not in the .RUN line: memory only
            rec = dataclasses.replace(rec, gps_hdop=hdop, gps_quality=scenario.gps.quality)
        yield truth, rec
        vessel.propagate(scenario, leg, gamma, kscale)


def _truth(
    scenario: Scenario, setup: SimulationSetup, to_wgs84: _FromWorking, v: _Vessel, leg: Leg,
    time: datetime,
) -> tuple[TruthRow, float, float]:
    """The truth row at this epoch, the grid convergence γ [deg] and point scale k there."""
    lat, lon = setup.grid.inverse(v.x, v.y)
    _x, _y, gamma, kscale = setup.grid.forward_full(lat, lon)
    w_lat, w_lon = to_wgs84(lat, lon)
    sin_max = math.sin(math.radians(scenario.max_pitch_deg))
    rate_z = _vertical_rate(v.speed, v.depth, leg, sin_max)
    pitch = math.degrees(math.asin(rate_z / v.speed)) if v.speed > 0.0 else 0.0
    ce, cn = leg.current.east_north_ms()
    fixes = leg.surfaced and v.depth <= scenario.fix_depth_max_m + 1e-9
    truth = TruthRow(
        time, w_lat, w_lon, lat, lon, v.x, v.y, v.depth, v.heading, v.speed / KNOT_MS, ce, cn,
        fixes, pitch,
    )
    return truth, gamma, kscale


def _gps_reading(
    scenario: Scenario, setup: SimulationSetup, to_gps: _FromWorking, v: _Vessel, fixes: bool,
    proc: _Processes, n: np.ndarray, hdop: float | None = None,
) -> tuple[float | None, float | None]:
    """GPS latitude, longitude [deg on the GPS datum], or None when off or submerged; with an
    ``hdop`` the σ per axis is HDOP·UERE/√2 (:class:`engine.sim.scenario.GpsModel`)."""
    g = scenario.gps
    if not (g.on and fixes):
        return None, None
    sigma, white = g.sigma_m, g.white_sigma_m
    if hdop is not None:
        total = hdop * g.uere_m / math.sqrt(2.0)
        sigma, white = total * math.sqrt(1.0 - g.white_frac), total * math.sqrt(g.white_frac)
    e_x = sigma * float(proc.u_gps[0]) + white * float(n[2])
    e_y = sigma * float(proc.u_gps[1]) + white * float(n[3])
    return to_gps(*setup.grid.inverse(v.x + e_x, v.y + e_y))


def _decca_reading(
    scenario: Scenario, setup: SimulationSetup, v: _Vessel, fixes: bool, proc: _Processes,
    n: np.ndarray, leg: Leg,
) -> tuple[float | None, float | None, float | None]:
    """Decca lane fractions (Red, Green, Purple) in [0, 1), or None when off or submerged; the
    correlated error is scaled per pattern and by the leg's sky-wave factor."""
    dc = scenario.decca
    if setup.placed is None or not fixes:
        return (None, None, None)
    geom = decca_geometry(setup.placed, v.x, v.y, setup.geodesic)
    total = geom.n_calc.copy()
    scale = dc.sigma_scale * leg.decca_sigma_factor
    if scale > 0.0:
        chol = np.linalg.cholesky(decca_vcv_lanes(geom, dc.cf))
        per = (dc.red_scale, dc.green_scale, dc.purple_scale)
        corr = chol @ proc.u_dec
        if per != (1.0, 1.0, 1.0):
            corr = corr * np.array(per)
        total += scale * corr
    if dc.white_sigma_lanes > 0.0:
        total += dc.white_sigma_lanes * n[7:10]
    fr = [float(val) % 1.0 for val in total]
    fr = [0.0 if f >= 1.0 else f for f in fr]
    return (fr[0], fr[1], fr[2])


def _sensor_readings(
    scenario: Scenario, setup: SimulationSetup, v: _Vessel, leg: Leg, pitch: float,
    proc: _Processes, n: np.ndarray,
) -> tuple[float | None, ...]:
    """Heading, log speed, rudder, inclination, pressure frequency and echo depth readings
    (the RunRecord's fields after Decca; None for a sensor not fitted)."""
    sens = scenario.sensors
    gy, lg, inc, pr, ec = (scenario.gyro, scenario.log, scenario.inclinometer,
                           scenario.pressure, scenario.echosounder)
    hdg = spd = rud = incl = pfreq = echo = None
    if sens.gyro:
        hdg = (v.heading + gy.bias_deg + gy.gm_sigma_deg * proc.u_gyr
               + gy.sigma_deg * float(n[11]))
        hdg %= 360.0
        if hdg >= 360.0:
            hdg = 0.0
    if sens.log:
        v_kn = v.speed / KNOT_MS
        spd = v_kn * (1.0 + lg.scale_factor) + lg.bias_kn + lg.sigma_frac * v_kn * float(n[12])
        spd = min(max(spd, 0.0), 60.0)
    if sens.rudder:
        diff = wrap_180_deg(leg.course_deg - v.heading)
        turn = 0.0 if abs(diff) < 1e-9 else math.copysign(leg.turn_rate_deg_s, diff)
        rud = max(-RUDDER_LIMIT_DEG, min(RUDDER_LIMIT_DEG, scenario.rudder_gain_s * turn))
    if sens.inclinometer:
        incl = pitch + inc.bias_deg + inc.sigma_deg * float(n[13])
        incl = max(-90.0, min(90.0, incl))
    if sens.pressure:
        measured = v.depth + pr.bias_m + pr.sigma_m * float(n[14])
        pfreq = depth_to_frequency_hz(measured, setup.press_ref_hz, pr.s_weight)
    if sens.echosounder and scenario.water_depth_m is not None:
        under = scenario.water_depth_m - v.depth
        echo = max(0.0, under + (ec.sigma_a_m + ec.sigma_b * under) * float(n[15]))
    return hdg, spd, rud, incl, pfreq, echo


# --------------------------------------------------------------------------------------------
# Output


def _num(value: float, decimals: int) -> str:
    """Fixed-point text without a negative zero."""
    text = f"{value:.{decimals}f}"
    if text.startswith("-") and float(text) == 0.0:
        text = text[1:]
    return text


def format_truth_row(row: TruthRow) -> str:
    """One truth CSV line (no line ending): degrees to 1e-9, metres to 1 mm (see header)."""
    return ",".join(
        (
            row.time.strftime("%Y-%m-%dT%H:%M:%SZ"),
            _num(row.lat_wgs84_deg, 9),
            _num(row.lon_wgs84_deg, 9),
            _num(row.lat_deg, 9),
            _num(row.lon_deg, 9),
            _num(row.x_m, 3),
            _num(row.y_m, 3),
            _num(row.depth_m, 3),
            _num(row.heading_true_deg, 4),
            _num(row.speed_kn, 4),
            _num(row.current_e_ms, 4),
            _num(row.current_n_ms, 4),
            "1" if row.surfaced else "0",
            _num(row.pitch_deg, 3),
        )
    )


def truth_header(scenario: Scenario, setup: SimulationSetup, seed: int) -> list[str]:
    """Comment lines (``#``) describing the truth file, then the column-name line."""
    ell = setup.working.ellipsoid
    cm = setup.cm_deg
    cm_text = f"{abs(cm):g} {'W' if cm < 0 else 'E'}"
    return [
        f"# UVNAV simulator truth for scenario {Path(scenario.source).name}"
        + (f" ({scenario.name})" if scenario.name else ""),
        f"# seed {seed}; {scenario.n_records} records every {scenario.sample_interval_s} s from "
        f"{scenario.start_time:%Y-%m-%dT%H:%M:%SZ}",
        f"# lat, lon: geodetic degrees on the working datum {setup.working.name} "
        f"(ellipsoid {ell.name}, a = {ell.a_m:.3f} m, 1/f = {ell.inv_f:.9g})",
        "# lat_wgs84, lon_wgs84: the WGS84 point whose h = 0 conversion to the working datum "
        "gives lat, lon",
        f"# x, y: TM grid on the working datum, k0 = 1, no false origin, CM {cm_text} "
        f"(cm_deg = {cm:g}), metres",
        "# depth_m positive down; heading_true_deg; speed_kn through the water; current_e_ms, "
        "current_n_ms true east/north m/s",
        "# surfaced: 1 = GPS and Decca received; pitch_deg bow-down positive",
        ",".join(TRUTH_COLUMNS),
    ]


def _temporary(final: Path) -> Path:
    """A new, empty temporary file in ``final``'s directory (exclusive create, so never an
    existing file; the usual permissions, as the final file would get)."""
    while True:
        tmp = final.with_name(f".{final.name}.{secrets.token_hex(4)}.tmp")
        try:
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
        except FileExistsError:
            continue
        except OSError as exc:
            raise OSError(exc.errno, exc.strerror, str(final)) from exc
        return tmp


def _rename(tmp: Path, final: Path) -> None:
    try:
        os.replace(tmp, final)
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror, str(final)) from exc


def write_simulation(
    scenario: Scenario,
    run_path: str | os.PathLike[str],
    truth_path: str | os.PathLike[str] | None,
    seed: int,
    *,
    datums: DatumFile,
    chains: dict[str, DeccaChain],
    nmea_path: str | os.PathLike[str] | None = None,
) -> SimulationSummary:
    """Simulate and write the ``.RUN`` file (thesis grammar, LF line ends, no header), the
    truth CSV (``None`` = none) and the NMEA 0183 log of the same readings (``None`` = none;
    CR LF line ends as on the wire, :mod:`engine.sim.nmea`). Files are written to new
    temporary files beside them (``.NAME.XXXX.tmp``, exclusive create: nothing existing is
    touched) and renamed at the end, so an error never leaves a half-written output. Existing
    files are replaced (the CLI checks by engine/io/outputs.py that they are earlier outputs,
    not inputs). An OSError names the output file it concerns. The NMEA log draws no random
    numbers: the ``.RUN`` and truth are the same bytes with or without it."""
    setup = simulation_setup(scenario, datums, chains)
    finals = [Path(run_path), None if truth_path is None else Path(truth_path),
              None if nmea_path is None else Path(nmea_path)]
    tmps: list[Path | None] = [None, None, None]
    handles: list[OutputFile | None] = [None, None, None]
    nmea = SimNmea(setup.gps_datum) if nmea_path is not None else None
    n = n_sentences = 0
    try:
        for i, final in enumerate(finals):
            if final is not None:
                tmps[i] = _temporary(final)
        run_tmp, truth_tmp, nmea_tmp = tmps
        assert run_tmp is not None
        # OutputFile: a write or close error names the file asked for, not the temporary one.
        run_fh = OutputFile(open(run_tmp, "w", encoding="ascii", newline="\n"), finals[0])
        handles[0] = run_fh
        if truth_tmp is not None and finals[1] is not None:
            handles[1] = OutputFile(open(truth_tmp, "w", encoding="utf-8", newline="\n"),
                                    finals[1])
        if nmea_tmp is not None and finals[2] is not None:
            handles[2] = OutputFile(open(nmea_tmp, "w", encoding="ascii", newline=""),
                                    finals[2])
        _run_fh, truth_fh, nmea_fh = handles
        if truth_fh is not None:
            truth_fh.write("\n".join(truth_header(scenario, setup, seed)) + "\n")
        for truth, rec in _run(scenario, setup, seed):
            run_fh.write(rec.raw + "\n")
            if truth_fh is not None:
                truth_fh.write(format_truth_row(truth) + "\n")
            if nmea_fh is not None and nmea is not None:
                lines = nmea.epoch(rec, heading_true_deg=truth.heading_true_deg,
                                   speed_kn=truth.speed_kn, pitch_deg=truth.pitch_deg,
                                   current_e_ms=truth.current_e_ms,
                                   current_n_ms=truth.current_n_ms)
                nmea_fh.write("".join(line + "\r\n" for line in lines))
                n_sentences += len(lines)
            n += 1
        for fh in handles:
            if fh is not None:
                fh.close()
        for tmp, final in zip(tmps, finals, strict=True):
            if tmp is not None and final is not None:
                _rename(tmp, final)
    finally:
        for fh in handles:
            if fh is not None and not fh.closed:
                try:
                    fh.close()
                except OSError:
                    pass
        for tmp in tmps:
            if tmp is not None and tmp.exists():
                tmp.unlink()
    return SimulationSummary(n, setup.cm_deg, finals[0], finals[1], finals[2], n_sentences)

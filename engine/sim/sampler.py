"""Randomized missions: a seed → one scenario and the start-up configuration an operator enters.

:func:`draw_mission` is a pure function of the seed (and the data files, for the Decca lane
entries at the start): it draws the truth's error statistics and the mission's dynamics from
fixed ranges (:data:`RANGES`, docs/SIMULATOR.md "Randomized missions", each with its source)
that were chosen before any result was seen and do not depend on the engine's defaults. It
returns the scenario TOML (docs/SIMULATOR.md) and the run configuration TOML with start-up values
only (datum, DR position, depth, the operator's current estimate, GPS on/off, Decca chain,
zone/lanes and patterns; docs/CONFIG.md), both checked by the engine's own parsers: a draw the
engine cannot start is a :class:`SamplerError` (a sampler bug), never a silent drop.

Randomness: ``numpy.random.default_rng([seed, SAMPLER_STREAM])`` only, a stream independent of
the simulator's noise (``default_rng(seed)``), drawn in a fixed order.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from pathlib import Path

import numpy as np

from engine.errors import InputError
from engine.io.datumfile import DatumFile
from engine.io.deccafile import DeccaChain
from engine.io.formatting import format_dms_input
from engine.io.operator_input import zone_lane_of
from engine.run.config import parse_config_text
from engine.sim.scenario import Scenario, parse_scenario_text
from engine.sim.simulate import simulation_setup
from engine.systems.decca import decca_geometry

__all__ = [
    "RANGES",
    "SAMPLER_VERSION",
    "SampledMission",
    "SamplerError",
    "SamplerOptions",
    "draw_mission",
    "start_zone_lanes",
]

SAMPLER_VERSION = 1
"""Raised whenever a seed would draw another mission (part of a campaign run's key)."""
SAMPLER_STREAM = 0x5A3D_1993
"""Second entropy word of the sampler's generator: its draws never coincide with the
simulator's noise for the same seed."""

RANGES: Mapping[str, tuple[float, float, str]] = {
    # name: (low, high, distribution)
    "mission_s": (1800.0, 43200.0, "log"),
    "surfaced_s": (30.0, 3600.0, "log"),
    "dive_s": (300.0, 10800.0, "log"),
    "gps_sigma_m": (10.0, 70.0, "log"),
    "gps_tau_s": (60.0, 900.0, "log"),
    "gps_white_m": (1.0, 10.0, "uniform"),
    "gps_hdop": (0.8, 2.5, "uniform"),
    "gps_hdop_swing": (0.0, 0.5, "uniform"),
    "gps_hdop_period_s": (600.0, 3600.0, "uniform"),
    "decca_pattern_scale": (0.5, 3.0, "log"),
    "decca_tau_s": (60.0, 1800.0, "log"),
    "skywave_factor": (3.0, 8.0, "log"),
    "current_kn": (0.0, 2.0, "uniform"),
    "current_entry_error_kn": (0.0, 1.0, "uniform"),
    "log_scale": (-0.05, 0.05, "uniform"),
    "gyro_bias_deg": (-1.5, 1.5, "uniform"),
    "gyro_drift_sigma_deg": (0.2, 1.0, "uniform"),
    "gyro_drift_tau_s": (1200.0, 7200.0, "log"),
    "outage_s": (60.0, 600.0, "log"),
    "leg_s": (300.0, 1800.0, "uniform"),
    "speed_surfaced_kn": (4.0, 12.0, "uniform"),
    "speed_dived_kn": (3.0, 8.0, "uniform"),
    "dive_depth_m": (20.0, 60.0, "uniform"),
}
"""Every drawn range: (low, high, ``"uniform"`` or ``"log"`` = log-uniform). Units in the names;
sources and the choice of distribution in docs/SIMULATOR.md, "Randomized missions"."""

P_HDOP_RECEIVER = 0.3
"""Share of missions whose GNSS error follows a per-epoch HDOP (the receiver class of
docs/GNSS_WEIGHTS.md) instead of a constant σ."""
P_SYSTEMS = (("gps+decca", 0.6), ("gps", 0.2), ("decca", 0.2))
"""Fixing systems of a mission and their shares."""
P_OUTAGE = 0.2
"""Chance that a surfaced period of at least 10 min holds one fix outage."""
P_SKYWAVE = 0.5
"""Chance that a surfaced leg at night is a sky-wave episode."""

CHAIN_AREAS: Mapping[str, tuple[float, float, float, float]] = {
    "9B": (53.0, 4.1, 0.3, 0.4),
    "2E": (51.9, 3.6, 0.2, 0.3),
}
"""Chain → (lat, lon of the area's centre in degrees ED50, half-height, half-width in degrees):
the sea areas of the bundled 9B and 2E missions (data/scenarios M1, M2, M5, M6), inside each
chain's day and night coverage (< 200 km from the stations, thesis L909)."""
CHAIN_SELECT: Mapping[str, tuple[str, ...]] = {"9B": ("red", "green"),
                                               "2E": ("red", "green", "purple")}
"""Patterns the operator selects (as in the bundled 9B and 2E missions)."""
WAYPOINT_RADIUS_M = 25_000.0
"""Each leg steers towards a point drawn within this radius of the area's centre, so that a
12-h mission stays in the chain's coverage."""
DIVE_RATE_MS = 0.2
"""Vertical speed of dives and climbs (the scenario default)."""


class SamplerError(RuntimeError):
    """A drawn mission the engine refuses: a bug of the sampler (the seed and the engine's message
    are in the text), never a mission to drop."""


@dataclass(frozen=True)
class SamplerOptions:
    """What a campaign or ``uvnav simulate --random`` may choose: the epoch interval (s, whole;
    every duration is rounded to it), the longest mission (s; the drawn length is capped, not
    redrawn) and the ``data_dir`` written into the scenario and the configuration."""

    sample_interval_s: int = 1
    max_mission_s: int = 43200
    data_dir: str = "."

    def digest_text(self) -> str:
        """The options as text for a run key."""
        return (f"v{SAMPLER_VERSION}:dt={self.sample_interval_s}:max={self.max_mission_s}")


@dataclass(frozen=True)
class SampledMission:
    """One draw: the seed, the scenario and configuration TOML texts, the parsed scenario and a
    flat record of the drawn values (for tables and for explaining a bad mission)."""

    seed: int
    scenario_text: str
    config_text: str
    scenario: Scenario
    drawn: Mapping[str, float | str] = field(default_factory=dict)


class _Draw:
    """The generator with the range helpers."""

    def __init__(self, seed: int) -> None:
        self.rng = np.random.default_rng([seed, SAMPLER_STREAM])

    def r(self, name: str) -> float:
        lo, hi, kind = RANGES[name]
        u = float(self.rng.random())
        if kind == "log":
            return math.exp(math.log(lo) + u * (math.log(hi) - math.log(lo)))
        return lo + u * (hi - lo)

    def u(self) -> float:
        return float(self.rng.random())

    def pick(self, shares: tuple[tuple[str, float], ...]) -> str:
        u = self.u()
        acc = 0.0
        for name, p in shares:
            acc += p
            if u < acc:
                return name
        return shares[-1][0]


def _sun_elevation_deg(t: datetime, lat_deg: float, lon_deg: float) -> float:
    """Approximate solar elevation (deg; declination and hour angle, no equation of time: about
    ±1° here, enough to tell day from night)."""
    doy = t.timetuple().tm_yday
    decl = math.radians(-23.44 * math.cos(2.0 * math.pi * (doy + 10) / 365.0))
    hours = t.hour + t.minute / 60.0 + t.second / 3600.0
    ha = math.radians(15.0 * (hours - 12.0) + lon_deg)
    lat = math.radians(lat_deg)
    s = math.sin(lat) * math.sin(decl) + math.cos(lat) * math.cos(decl) * math.cos(ha)
    return math.degrees(math.asin(max(-1.0, min(1.0, s))))


def _round_to(x: float, step: int, minimum: int) -> int:
    return max(minimum, int(round(x / step)) * step)


@dataclass
class _Leg:
    duration_s: int
    course_deg: float
    speed_kn: float
    depth_m: float
    surfaced: bool | None
    skywave: float = 1.0


@dataclass
class _Plan:
    """The mission as legs, with the sampler's flat-earth track to steer towards waypoints."""

    d: _Draw
    dt: int
    lat0: float
    lon0: float
    current_en_ms: tuple[float, float]
    start: datetime
    legs: list[_Leg] = field(default_factory=list)
    x: float = 0.0
    y: float = 0.0
    t: int = 0

    def add(self, duration: int, speed_kn: float, depth_m: float, surfaced: bool | None,
            night_skywave: bool) -> None:
        """Legs of ``leg_s`` (the last one shorter) over ``duration`` s, each steering to a new
        waypoint; at night a surfaced leg is a sky-wave episode with chance :data:`P_SKYWAVE`."""
        left = duration
        while left > 0:
            n = min(left, _round_to(self.d.r("leg_s"), self.dt, self.dt))
            if 0 < left - n < 60:  # no tail leg under a minute
                n = left
            ang = 2.0 * math.pi * self.d.u()
            rad = WAYPOINT_RADIUS_M * math.sqrt(self.d.u())
            wx, wy = rad * math.sin(ang), rad * math.cos(ang)
            course = math.degrees(math.atan2(wx - self.x, wy - self.y)) % 360.0
            course = round(course, 1) % 360.0
            factor = 1.0
            u_sky, f_sky = self.d.u(), self.d.r("skywave_factor")
            if night_skywave:
                mid = self.start + timedelta(seconds=self.t + n / 2)
                lat = self.lat0 + self.y / 111_200.0
                lon = self.lon0 + self.x / (111_200.0 * math.cos(math.radians(self.lat0)))
                if _sun_elevation_deg(mid, lat, lon) < 0.0 and u_sky < P_SKYWAVE:
                    factor = round(f_sky, 3)
            self.legs.append(_Leg(n, course, round(speed_kn, 1), depth_m, surfaced, factor))
            v = speed_kn * 1852.0 / 3600.0
            c = math.radians(course)
            self.x += n * (v * math.sin(c) + self.current_en_ms[0])
            self.y += n * (v * math.cos(c) + self.current_en_ms[1])
            self.t += n
            left -= n


def _fmt(x: float) -> str:
    text = f"{x:.6g}"
    return text if any(ch in text for ch in ".en") else text + ".0"


def _scenario_text(name: str, drawn: Mapping[str, float | str], plan: _Plan, opts: SamplerOptions,
                   position: str) -> str:
    g = drawn
    lines = [
        f"# Randomized mission, seed {g['seed']} (engine.sim.sampler, version {SAMPLER_VERSION};",
        "# ranges and sources in docs/SIMULATOR.md, \"Randomized missions\").",
        f'name = "{name}"',
        f'start_time = "{plan.start.strftime("%Y-%m-%dT%H:%M:%SZ")}"',
        'datum = "ED50"',
        f'start_position = "{position}"',
        f"sample_interval_s = {opts.sample_interval_s}",
        'run_gps_datum = "WGS84"',
        f'data_dir = "{opts.data_dir}"',
        "",
        "[current]",
        f"set_deg = {_fmt(float(g['current_set_deg']))}",
        f"speed_kn = {_fmt(float(g['current_kn']))}",
        "",
        "[gps]",
        f"on = {'true' if g['gps'] == 'on' else 'false'}",
        f"sigma_m = {_fmt(float(g['gps_sigma_m']))}",
        f"tau_s = {_fmt(float(g['gps_tau_s']))}",
        f"white_sigma_m = {_fmt(float(g['gps_white_m']))}",
    ]
    if float(g["gps_hdop"]) > 0.0:
        lines += [f"hdop = {_fmt(float(g['gps_hdop']))}",
                  f"hdop_swing = {_fmt(float(g['gps_hdop_swing']))}",
                  f"hdop_period_s = {_fmt(float(g['gps_hdop_period_s']))}",
                  f"uere_m = {_fmt(float(g['gps_uere_m']))}",
                  f"white_frac = {_fmt(float(g['gps_white_frac']))}"]
    lines += [
        "",
        "[decca]",
        f"on = {'true' if g['decca'] == 'on' else 'false'}",
        f'chain = "{g["chain"]}"',
        "cf = 64.0",
        f"tau_s = {_fmt(float(g['decca_tau_s']))}",
        f"red_scale = {_fmt(float(g['decca_red_scale']))}",
        f"green_scale = {_fmt(float(g['decca_green_scale']))}",
        f"purple_scale = {_fmt(float(g['decca_purple_scale']))}",
        "",
        "[sensors]",
        "gyro = true", "log = true", "rudder = true", "inclinometer = true", "pressure = true",
        "echosounder = false",
        "",
        "[gyro]",
        f"bias_deg = {_fmt(float(g['gyro_bias_deg']))}",
        "sigma_deg = 0.15",
        f"gm_sigma_deg = {_fmt(float(g['gyro_drift_sigma_deg']))}",
        f"gm_tau_s = {_fmt(float(g['gyro_drift_tau_s']))}",
        "",
        "[log]",
        f"scale_factor = {_fmt(float(g['log_scale']))}",
        "sigma_frac = 0.02",
        "",
        "[inclinometer]",
        "bias_deg = 0.1",
        "sigma_deg = 0.5",
        "",
        "[pressure]",
        "sigma_m = 1.45",
    ]
    for leg in plan.legs:
        lines += ["", "[[leg]]", f"duration_s = {leg.duration_s}",
                  f"course_deg = {_fmt(leg.course_deg)}", f"speed_kn = {_fmt(leg.speed_kn)}"]
        if leg.depth_m > 0.0:
            lines.append(f"depth_m = {_fmt(leg.depth_m)}")
        if leg.surfaced is not None:
            lines.append(f"surfaced = {'true' if leg.surfaced else 'false'}")
        if leg.skywave != 1.0:
            lines.append(f"decca_sigma_factor = {_fmt(leg.skywave)}")
    return "\n".join(lines) + "\n"


def start_zone_lanes(scenario: Scenario, datums: DatumFile, chains: Mapping[str, DeccaChain]
                     ) -> dict[str, str]:
    """The zone/lane entries (``"C19"``) an operator reads off the chart at the scenario's start:
    the zone letter and the whole lane holding the lane model's count at the true start
    (:func:`engine.systems.decca.decca_geometry`), per pattern."""
    setup = simulation_setup(scenario, datums, dict(chains))
    if setup.placed is None:
        return {"red": "", "green": "", "purple": ""}
    x, y = setup.grid.forward(scenario.start_lat_deg, scenario.start_lon_deg)
    n = decca_geometry(setup.placed, x, y, setup.geodesic).n_calc
    out = {}
    for k, pattern in enumerate(("red", "green", "purple")):
        letter, lane = zone_lane_of(float(n[k]), pattern)
        out[pattern] = f"{letter}{math.floor(lane)}"
    return out


def _config_text(run_file: str, drawn: Mapping[str, float | str], position: str,
                 lanes: Mapping[str, str], opts: SamplerOptions) -> str:
    g = drawn
    decca_on = g["decca"] == "on"
    select = ", ".join(f'"{p}"' for p in CHAIN_SELECT[str(g["chain"])]) if decca_on else ""
    return "\n".join([
        f"# Start-up values only: what an operator enters for randomized mission seed {g['seed']}",
        "# (the current as estimated, off the truth; no [filter], [lsq] or [demo] table).",
        'datum = "ED50"',
        f'dr_position = "{position}"',
        "depth_m = 0.0",
        f"current_set_deg = {_fmt(float(g['entry_set_deg']))}",
        f"current_speed_kn = {_fmt(float(g['entry_kn']))}",
        f'run_file = "{run_file}"',
        'run_gps_datum = "WGS84"',
        f'data_dir = "{opts.data_dir}"',
        "",
        "[gps]",
        f"on = {'true' if g['gps'] == 'on' else 'false'}",
        "",
        "[decca]",
        f"on = {'true' if decca_on else 'false'}",
        f'chain = "{g["chain"]}"',
        f'red = "{lanes["red"] if decca_on else ""}"',
        f'green = "{lanes["green"] if decca_on else ""}"',
        f'purple = "{lanes["purple"] if decca_on else ""}"',
        f"select = [{select}]",
    ]) + "\n"


def draw_mission(seed: int, datums: DatumFile, chains: Mapping[str, DeccaChain],
                 options: SamplerOptions | None = None, *, run_file: str = "RANDOM.RUN",
                 base_dir: Path = Path(".")) -> SampledMission:
    """Draw the mission of ``seed`` (whole number ≥ 0). ``datums``/``chains`` are the data
    files (TO_WGS84.DAT, DECCA.CHN) the mission will run with; ``run_file`` is written into the
    configuration and ``base_dir`` resolves its ``data_dir``. Raises :class:`SamplerError` if
    the engine refuses the drawn scenario or configuration (a sampler bug)."""
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"seed must be a whole number >= 0, got {seed!r}")
    opts = options or SamplerOptions()
    dt = opts.sample_interval_s
    d = _Draw(seed)
    g: dict[str, float | str] = {"seed": seed}
    # the setting: chain, systems, place and time
    chain = "9B" if d.u() < 0.5 else "2E"
    systems = d.pick(P_SYSTEMS)
    g.update(chain=chain, systems=systems, gps="on" if "gps" in systems else "off",
             decca="on" if "decca" in systems else "off")
    lat_c, lon_c, dlat, dlon = CHAIN_AREAS[chain]
    lat0 = round((lat_c + dlat * (2.0 * d.u() - 1.0)) * 3600.0) / 3600.0
    lon0 = round((lon_c + dlon * (2.0 * d.u() - 1.0)) * 3600.0) / 3600.0
    start = (datetime(1992, 1, 1, tzinfo=UTC) + timedelta(days=int(d.u() * 366))
             + timedelta(seconds=int(d.u() * 86400)))
    g.update(lat0=lat0, lon0=lon0, start=start.isoformat())
    total = _round_to(min(d.r("mission_s"), float(opts.max_mission_s)), 60, 60)
    total = _round_to(total, dt, dt)
    g["mission_s"] = total
    # GNSS
    sig, tau, white = d.r("gps_sigma_m"), d.r("gps_tau_s"), d.r("gps_white_m")
    u_hdop = d.u()
    hdop, swing, period = d.r("gps_hdop"), d.r("gps_hdop_swing"), d.r("gps_hdop_period_s")
    g.update(gps_sigma_m=round(sig, 2), gps_tau_s=round(tau, 1), gps_white_m=round(white, 2),
             gps_hdop=0.0)
    if u_hdop < P_HDOP_RECEIVER:
        # σ(t) = h(t)·UERE/√2 with the drawn σ at the mean HDOP (docs/GNSS_WEIGHTS.md)
        total_sig = math.hypot(sig, white)
        g.update(gps_hdop=round(hdop, 1), gps_hdop_swing=round(swing, 2),
                 gps_hdop_period_s=round(period), gps_white_frac=round(
                     (white / total_sig) ** 2, 4),
                 gps_uere_m=round(total_sig * math.sqrt(2.0) / round(hdop, 1), 2))
    # Decca
    g.update(decca_red_scale=round(d.r("decca_pattern_scale"), 3),
             decca_green_scale=round(d.r("decca_pattern_scale"), 3),
             decca_purple_scale=round(d.r("decca_pattern_scale"), 3),
             decca_tau_s=round(d.r("decca_tau_s"), 1))
    # current and the operator's estimate of it
    cur, cur_set = d.r("current_kn"), 360.0 * d.u()
    err, err_dir = d.r("current_entry_error_kn"), 360.0 * d.u()
    ce = cur * math.sin(math.radians(cur_set)) + err * math.sin(math.radians(err_dir))
    cn = cur * math.cos(math.radians(cur_set)) + err * math.cos(math.radians(err_dir))
    g.update(current_kn=round(cur, 2), current_set_deg=round(cur_set, 1) % 360.0,
             entry_error_kn=round(err, 2), entry_kn=round(math.hypot(ce, cn), 2),
             entry_set_deg=round(math.degrees(math.atan2(ce, cn)) % 360.0, 1) % 360.0)
    # dead-reckoning sensors
    g.update(log_scale=round(d.r("log_scale"), 4), gyro_bias_deg=round(d.r("gyro_bias_deg"), 2),
             gyro_drift_sigma_deg=round(d.r("gyro_drift_sigma_deg"), 2),
             gyro_drift_tau_s=round(d.r("gyro_drift_tau_s")))
    # the mission: surfaced periods and dives, alternating from a surfaced start
    kn = 1852.0 / 3600.0
    cur_en = (float(g["current_kn"]) * kn * math.sin(math.radians(float(g["current_set_deg"]))),
              float(g["current_kn"]) * kn * math.cos(math.radians(float(g["current_set_deg"]))))
    plan = _Plan(d, dt, lat0, lon0, cur_en, start)
    surfaced_s = dived_s = outage_s = 0
    n_dives = 0
    depth = 0.0
    left = total
    skywave = g["decca"] == "on"
    while left > 0:
        # a surfaced period: the climb from the last dive, then the drawn time at the surface
        climb = _round_to(depth / DIVE_RATE_MS, dt, 0) if depth > 0.0 else 0
        at_surface = _round_to(d.r("surfaced_s"), dt, dt)
        u_out, out_len, out_at = d.u(), _round_to(d.r("outage_s"), dt, dt), d.u()
        speed = d.r("speed_surfaced_kn")
        span = min(left, climb + at_surface)
        outage = (u_out < P_OUTAGE and at_surface >= 600 and out_len < at_surface
                  and span == climb + at_surface)
        if outage:
            before = _round_to(out_at * (at_surface - out_len), dt, 0)
            if climb + before > 0:
                plan.add(climb + before, speed, 0.0, None, skywave)
            plan.add(out_len, speed, 0.0, False, False)
            if at_surface - out_len - before > 0:
                plan.add(at_surface - out_len - before, speed, 0.0, None, skywave)
            outage_s += out_len
        else:
            plan.add(span, speed, 0.0, None, skywave)
        surfaced_s += span
        left -= span
        depth = 0.0
        if left <= 0:
            break
        dive = min(left, _round_to(d.r("dive_s"), dt, dt))
        depth = round(d.r("dive_depth_m"), 1)
        plan.add(dive, d.r("speed_dived_kn"), depth, False, False)
        dived_s += dive
        n_dives += 1
        left -= dive
    g.update(surfaced_s=surfaced_s, dived_s=dived_s, outage_s=outage_s, dives=n_dives,
             skywave_legs=sum(leg.skywave != 1.0 for leg in plan.legs),
             skywave_max=max((leg.skywave for leg in plan.legs), default=1.0))
    position = format_dms_input(lat0, lon0)
    name = f"random mission {seed}"
    scen_text = _scenario_text(name, g, plan, opts, position)
    where = f"random mission seed {seed}"
    try:
        scenario = parse_scenario_text(scen_text, f"{where} scenario", base_dir,
                                       known_datums=datums.datums, known_chains=list(chains))
        lanes = start_zone_lanes(scenario, datums, chains)
        cfg_text = _config_text(run_file, g, position, lanes, opts)
        parse_config_text(cfg_text, f"{where} configuration", base_dir,
                          known_datums=datums.datums, known_chains=list(chains))
    except InputError as err:
        raise SamplerError(f"sampler bug: the engine refuses {where}: {err}") from None
    return SampledMission(seed, scen_text, cfg_text, scenario, g)

"""Operator commands applied between cycles (THEORY §12.6: Setup, Obs, Kalman, Demo menus).

Each command is a small frozen dataclass; :func:`apply_command` returns the new configuration,
the new navigation state and a one-line description for the ``.OUT`` log.  Nothing here touches
a screen: the console builds commands from its dialogs, the script runner from its lines.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from engine.filter.state import replace_current, replace_position
from engine.io.formatting import format_lat_dms, format_lon_dms
from engine.lsq.fix import MAX_BRR, ManualObservation
from engine.run.config import FILTER_PRESETS, VESSEL_PRESETS, FilterConfig, RunConfig
from engine.run.cycle import NavState, RunContext
from engine.systems.sensors import knots_to_ms


@dataclass(frozen=True)
class SetDatum:
    """Setup ▸ Params ▸ Datum: new working datum (a name from TO_WGS84.DAT)."""

    name: str


@dataclass(frozen=True)
class SetDRPosition:
    """Setup ▸ Params ▸ DR Pos: new DR position (degrees, working datum).

    At the surface it supplies the provisional coordinates of the LS; submerged it restarts the
    filter position (thesis L5473, L6524) with σ = ``filter.dr_sigma_m`` per axis.
    """

    lat_deg: float
    lon_deg: float


@dataclass(frozen=True)
class SetCurrent:
    """Setup ▸ Params ▸ Current: set (degrees true, direction of flow) and drift (knots).

    Resets the filter's current (grid East/North, m/s: the set rotated by −γ at the MPP) and its
    covariance block to the initial value (THEORY §8.11)."""

    set_deg: float
    speed_kn: float


@dataclass(frozen=True)
class SetGps:
    """Setup ▸ Systems ▸ GPS: on/off and receiver type ("C/A" or "P")."""

    on: bool
    receiver: str = "C/A"


@dataclass(frozen=True)
class SetDecca:
    """Setup ▸ Systems ▸ Decca: on/off, chain, zone+lane per pattern ("" = none), selection."""

    on: bool
    chain: str = "9B"
    red: str = ""
    green: str = ""
    purple: str = ""
    select: tuple[str, ...] = ()


@dataclass(frozen=True)
class SetSensor:
    """Setup ▸ Sensors: switch one sensor ("gyro", "log", …) to "on" or "off"."""

    name: str
    state: str


@dataclass(frozen=True)
class SetFiltering:
    """Kalman ▸ Filtering: the navigation filter on/off."""

    on: bool


@dataclass(frozen=True)
class SetParameters:
    """Demo / developer parameters: replace keys of one configuration table.

    ``table`` is one of "corrections", "lsq", "filter", "demo"; ``values`` maps attribute names
    (as in :mod:`engine.run.config`) to new values.  Validation is the configuration's own.
    """

    table: str
    values: tuple[tuple[str, Any], ...]


@dataclass(frozen=True)
class AddObservation:
    """Obs ▸ Bearing / Distance / Radar: queue manual observations for the next cycle only."""

    observations: tuple[ManualObservation, ...]


Command = (
    SetDatum
    | SetDRPosition
    | SetCurrent
    | SetGps
    | SetDecca
    | SetSensor
    | SetFiltering
    | SetParameters
    | AddObservation
)

TABLES = ("corrections", "lsq", "filter", "demo", "gps", "decca", "sensors")


def _reset_position(ctx: RunContext, nav: NavState, lat: float, lon: float) -> NavState:
    fs = nav.filter
    if fs is not None and nav.cm_deg is not None:
        x, y = ctx.grid(nav.cm_deg).forward(lat, lon)
        fs = replace_position(fs, x, y, np.eye(2) * ctx.config.filter.dr_sigma_m**2)
    return replace(nav, mpp_lat_deg=lat, mpp_lon_deg=lon, filter=fs, filter_has_fix=False)


def apply_command(
    ctx: RunContext, nav: NavState, cmd: Command
) -> tuple[RunConfig, NavState, str]:
    """Apply ``cmd`` to the run of ``ctx``; returns (config, state, log text).

    Raises InputError/ValueError for an invalid value (the configuration validates itself),
    leaving the caller's objects unchanged.  A datum change only changes the configuration: the
    caller rebuilds the context and moves the state with :func:`engine.run.cycle.rebase_state`.
    """
    cfg = ctx.config
    if isinstance(cmd, SetDatum):
        return cfg.replace(datum=cmd.name), nav, f"Setup > Params > Datum {cmd.name}"
    if isinstance(cmd, SetDRPosition):
        new_nav = _reset_position(ctx, nav, cmd.lat_deg, cmd.lon_deg)
        pos = f"{format_lat_dms(cmd.lat_deg)} {format_lon_dms(cmd.lon_deg)}"
        text = f"Setup > Params > DR Pos {pos}"
        return cfg, new_nav, text
    if isinstance(cmd, SetCurrent):
        new_cfg = cfg.replace(current_set_deg=cmd.set_deg, current_speed_kn=cmd.speed_kn)
        fs = nav.filter
        if fs is not None:
            vc = knots_to_ms(cmd.speed_kn)
            # The filter's current lives in the grid, like its heading (THEORY D4, §8.4):
            # grid set = true set − γ, γ the convergence at the MPP on the run's CM.
            gamma = 0.0
            if nav.cm_deg is not None:
                gamma = ctx.grid(nav.cm_deg).convergence_deg(nav.mpp_lat_deg, nav.mpp_lon_deg)
            s = math.radians(cmd.set_deg - gamma)
            var = 1.0 if cfg.filter.p0 == "thesis" else 0.25
            fs = replace_current(fs, vc * math.sin(s), vc * math.cos(s), var)
        return new_cfg, replace(nav, filter=fs), (
            f"Setup > Params > Current {cmd.set_deg:.1f} deg {cmd.speed_kn:.1f} kn"
        )
    if isinstance(cmd, SetGps):
        gps = replace(cfg.gps, on=cmd.on, receiver=cmd.receiver)
        return cfg.replace(gps=gps), nav, (
            f"Setup > Systems > GPS {'on' if cmd.on else 'off'} {cmd.receiver}"
        )
    if isinstance(cmd, SetDecca):
        decca = replace(cfg.decca, on=cmd.on, chain=cmd.chain, red=cmd.red, green=cmd.green,
                        purple=cmd.purple, select=tuple(cmd.select))
        sel = "".join(p[0].upper() for p in cmd.select)
        nav = replace(nav, decca_track=(None, None, None))  # the new zone/lane entries apply
        return cfg.replace(decca=decca), nav, (
            f"Setup > Systems > Decca {'on' if cmd.on else 'off'} {cmd.chain} "
            f"R={cmd.red or '-'} G={cmd.green or '-'} P={cmd.purple or '-'} sel={sel or '-'}"
        )
    if isinstance(cmd, SetSensor):
        sensors = replace(cfg.sensors, **{cmd.name: cmd.state})
        return cfg.replace(sensors=sensors), nav, f"Setup > Sensors > {cmd.name} {cmd.state}"
    if isinstance(cmd, SetFiltering):
        flt = replace(cfg.filter, on=cmd.on)
        return cfg.replace(filter=flt), nav, f"Kalman > Filtering {'on' if cmd.on else 'off'}"
    if isinstance(cmd, SetParameters):
        if cmd.table not in TABLES:
            raise ValueError(f"unknown parameter table {cmd.table!r}")
        values = dict(cmd.values)
        if cmd.table == "filter" and "preset" in values:
            # A preset switch sets the keys the preset decides; the other keys stay as they are
            # unless edited in the same command (docs/CONFIG.md "The filter decision").
            values = {**FILTER_PRESETS[str(values["preset"]).lower()], **values}
        if cmd.table == "filter" and "vessel" in values:
            # Likewise the vessel: "surface" sets its values, "submarine" the thesis' ones back
            # (docs/CONFIG.md "The vessel decision"); "auto" is resolved when a run starts.
            vessel = str(values["vessel"]).lower()
            sub = FilterConfig()
            decided = {"surface": VESSEL_PRESETS["surface"],
                       "submarine": {k: getattr(sub, k) for k in VESSEL_PRESETS["surface"]}}
            values = {**decided.get(vessel, {}), **values}
        table = replace(getattr(cfg, cmd.table), **values)
        text = " ".join(f"{k}={v}" for k, v in cmd.values)
        if cmd.table == "demo" and "press_ref_freq_hz" in dict(cmd.values):
            nav = replace(nav, press_ref_hz=None)  # the next reading uses the new reference
        return cfg.replace(**{cmd.table: table}), nav, f"Parameters [{cmd.table}] {text}"
    if isinstance(cmd, AddObservation):
        queued = (nav.pending_obs + cmd.observations)[:MAX_BRR]
        text = "; ".join(
            f"{o.kind} {o.station} {o.value:.2f} ({o.sensor or o.kind})" for o in cmd.observations
        )
        return cfg, replace(nav, pending_obs=queued), f"Obs > {text}"
    raise TypeError(f"not a command: {cmd!r}")

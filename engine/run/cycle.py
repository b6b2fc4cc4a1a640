"""The processing cycle: one ``.RUN`` record in, one immutable :class:`CycleResult` out.

Functional core (THEORY §12.4–12.5, §9): ``step(context, state, record)`` returns the
next :class:`NavState` and the cycle's result without touching anything else, so the console, the
headless replay and the tests all drive the same code, and a cycle can be recomputed (e.g. after
the operator discards an LOP under ``LOPReject = 'A'``) simply by calling ``step`` again.
Frames: the TM grid of the working datum with CM = MPP longitude rounded (THEORY D3);
geodetic positions on the working datum; headings true outside the filter, grid inside it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from datetime import datetime

import numpy as np

from engine.filter import adapt as nadapt
from engine.filter import divergence as ndiv
from engine.filter import horizon as nhorizon
from engine.filter import motion as nmotion
from engine.filter.estimate import PositionEstimate, filter_estimate, position_estimate
from engine.filter.kalman import (
    FilterParams,
    FilterState,
    Measurement,
    UpdateResult,
    derived_fix_model,
    fix_states_from_fix,
    inflate_fix_states,
    init_state,
    lop_measurement,
    restart_dr_states,
    restart_fix_states,
    stack_measurements,
)
from engine.filter.measurements import SensorLayout, depth_sensor_rows, sensor_rows
from engine.filter.state import IVCX, IVCY, IX, IY, move_to_grid, replace_position
from engine.geodesy.angles import wrap_180_deg
from engine.geodesy.ellipsoid import WGS84, Datum
from engine.geodesy.ellipsoidal import DatumShift, GeodesicSolver, datum_shift
from engine.geodesy.tmgrid import TMGrid, central_meridian_deg
from engine.io.datumfile import DatumFile
from engine.io.deccafile import DeccaChain
from engine.io.operator_input import parse_zone_lane
from engine.io.runfile import RunRecord
from engine.lsq.fix import (
    GPS_VAR_CA_M2,
    GPS_VAR_P_M2,
    SLOT_BRR0,
    FixResult,
    LsqSettings,
    ManualObservation,
    PositionPrior,
    lop_name,
    slots_of,
)
from engine.lsq.statistics import REJECT_BOUND, CumulativeVariance
from engine.run.config import RunConfig, resolve_vessel
from engine.run.parts import REFERENCE, CycleParts, choose
from engine.systems import registry
from engine.systems.base import (
    CycleInputs,
    NavSystem,
    SystemReading,
)
from engine.systems.decca import (
    DECCA,
    DECCA_TRACK_GAP_S,
    LANE_SIGMA_MAX,
    ChainOnGrid,
    DeccaReading,
    LaneSource,
    lane_sigma,
    place_chain_on_datum,
)
from engine.systems.gps import GPS, GpsInput, quality_name
from engine.systems.registry import systems_string
from engine.systems.sensors import (
    SENSOR_NAMES,
    knots_to_ms,
    pressure_depth_m,
    standin_sigmas,
    surface_reference_hz,
)

CM_HYSTERESIS_DEG = 0.05
"""Extra margin beyond 0.5° before the CM switches, so a ship on a half-degree meridian does not
make the grid flip every cycle (THEORY D3: switch at 0.5°, keep the grid stable)."""



FILTER_KEY_TO_PARAM = {
    "log_bias_rw_ms_sqrth": "bias_rw_log_ms_sqrth",
    "gyro_bias_rw_deg_sqrth": "bias_rw_gyro_deg_sqrth",
    "incl_bias_rw_deg_sqrth": "bias_rw_incl_deg_sqrth",
}
"""``[filter]`` keys whose FilterParams field is named differently; every other key that names a
FilterParams field is copied as it is (a new filter parameter needs no line here)."""


def filter_params_from_config(cfg: RunConfig, gnss_receiver: bool = False) -> FilterParams:
    """The filter parameters of a run configuration (THEORY §8.9–8.11, §15); ``"auto"``
    fix-error τ and fraction follow from the systems on
    (``engine.filter.kalman.derived_fix_model``); ``gnss_receiver``: for fixes whose GPS is
    weighted by the receiver's HDOP × UERE (docs/GNSS_WEIGHTS.md)."""
    f = cfg.filter
    params = {fl.name for fl in fields(FilterParams) if fl.init}
    kw = {FILTER_KEY_TO_PARAM.get(fl.name, fl.name): getattr(f, fl.name) for fl in fields(f)}
    kw = {name: value for name, value in kw.items() if name in params}
    gps_var = (GPS_VAR_P_M2 if cfg.gps.p_code else GPS_VAR_CA_M2) * cfg.lsq.gps_se_sf
    tau, frac = derived_fix_model(cfg.gps.on, gps_var, cfg.decca.on, cfg.gps.p_code,
                                  gnss_receiver)
    for name, auto in (("fix_tau_s", tau), ("fix_sigma_frac", frac)):
        kw[name] = auto if kw[name] == "auto" else float(kw[name])
    return FilterParams(coloured=f.model == "coloured", **kw)


def lsq_settings_from_config(cfg: RunConfig) -> LsqSettings:
    """The LS parameters of a run configuration (A8.2)."""
    q = cfg.lsq
    return LsqSettings(
        epsilon_m=q.epsilon_m,
        s02=q.s02,
        lop_reject=q.lop_reject,
        reliab_interval=q.reliab_interval_pct,
        scale_vcv=q.scale_vcv,
        estimator=q.estimator,
        conf_region=q.conf_region_pct,
    )


@dataclass(frozen=True, slots=True)
class _ConfigDerived:
    """Per-configuration values of the cycle, computed once (:meth:`RunContext.derived`)
    instead of every cycle: the ``.OUT``/JSONL systems string, the sensors' A8.2 status codes
    in the order of ``SENSOR_NAMES``, and the configuration's part of the fix source
    (:func:`fix_source`). Keyed by the identity of the (frozen) configuration and of the
    registry's system tuple they were computed from."""

    config: RunConfig
    systems: tuple[object, ...]
    systems_string: str
    sensor_status: tuple[int, ...]
    fix_source: tuple[object, ...]
    run_systems: tuple[NavSystem, ...]
    """The systems the run reads the registry's with (:meth:`CycleParts.run_systems`)."""
    adapt: nadapt.AdaptSettings | None = None
    """How the fix-VCV factor is learnt (``[filter] adapt``; None: not learnt)."""
    recover: ndiv.RecoverSettings | None = None
    """The remedy of a diverged filter (``[filter] recover``; None: off)."""
    dr_adapt: nhorizon.DrAdaptSettings | None = None
    """How the dead-reckoning noise factor is learnt (``[filter] adapt_dr``; None: not)."""
    motion: nmotion.MotionSettings | None = None
    """Bounds of the COG/SOG stand-in's learnt process noise (None: not learnt)."""

    @classmethod
    def of(cls, cfg: RunConfig, parts: CycleParts) -> _ConfigDerived:
        """The values of ``cfg`` under the registry as it is now."""
        return cls(cfg, registry.SYSTEMS, systems_string(cfg),
                   tuple(cfg.sensors.status(n) for n in SENSOR_NAMES), fix_source(cfg),
                   parts.run_systems(registry.SYSTEMS), adapt_settings(cfg),
                   recover_settings(cfg), dr_adapt_settings(cfg),
                   motion_settings(cfg))


def recover_settings(cfg: RunConfig) -> ndiv.RecoverSettings | None:
    """The divergence remedy of a configuration (``[filter] recover*``, docs/CONFIG.md, THEORY
    §8.18); None when off."""
    f = cfg.filter
    if f.recover == "off" or not f.on:
        return None
    return ndiv.RecoverSettings(f.recover, f.recover_epochs, f.recover_gap_s)


def adapt_settings(cfg: RunConfig) -> nadapt.AdaptSettings | None:
    """The noise adaptation of a configuration (``[filter] adapt*``, docs/CONFIG.md); None
    when it is off or the filter is off."""
    f = cfg.filter
    if not (f.adapt and f.on):
        return None
    return nadapt.AdaptSettings(window=f.adapt_window, clip=f.adapt_clip,
                               fix_max=f.adapt_fix_max)


def dr_adapt_settings(cfg: RunConfig) -> nhorizon.DrAdaptSettings | None:
    """The dead-reckoning noise adaptation of a configuration (``[filter] adapt_dr*``,
    THEORY §8.19); None when it, the fix factor's adaptation or the filter is off."""
    f = cfg.filter
    if not (f.adapt_dr and f.adapt and f.on):
        return None
    h = f.adapt_dr_horizon_s
    return nhorizon.DrAdaptSettings(horizon_s=h, stagger_s=h / 2.0, mu_min=f.adapt_dr_min,
                                    mu_max=f.adapt_dr_max, max_age_s=max(7200.0, h))

def motion_settings(cfg: RunConfig) -> nmotion.MotionSettings | None:
    """The learnt process noise of the COG/SOG stand-in (engine.filter.motion): with the
    filter and ``[filter] adapt`` on and ``sensors.cog_sog = "standin"``, capped at the
    configured ``turn_rate_max_deg_s`` and ``sigma_a2``; else None."""
    f = cfg.filter
    if not (f.adapt and f.on and cfg.sensors.standin):
        return None
    return nmotion.MotionSettings.of(f.turn_rate_max_deg_s, f.sigma_a2)


@dataclass(frozen=True, slots=True)
class _Makers:
    """The cycle's dataclasses made from every field positionally, as the run's parts make
    them (:attr:`CycleParts.make`)."""

    result: Callable[..., CycleResult]
    nav: Callable[..., NavState]
    sensor_values: Callable[..., SensorValues]
    inputs: Callable[..., CycleInputs]
    prediction: Callable[..., _Prediction]
    filtering: Callable[..., _Filtering]

    @classmethod
    def of(cls, parts: CycleParts) -> _Makers:
        """The constructors of ``parts``."""
        make = parts.make
        return cls(make(CycleResult), make(NavState), make(SensorValues), make(CycleInputs),
                   make(_Prediction), make(_Filtering))


@dataclass
class RunContext:
    """What a run needs besides its state: configuration, data files and derived solvers.

    Rebuilt (cheaply) whenever the operator changes the set-up; holds small per-run caches of TM
    grids and Decca chains placed on them, keyed by central meridian.
    """

    config: RunConfig
    datums: DatumFile
    chains: dict[str, DeccaChain]
    working: Datum
    gps_shift: DatumShift | None
    gps_to_wgs84: DatumShift | None
    """``run_gps_datum`` → WGS84 for the Pg 100 ECEF and height (None when the .RUN is WGS84)."""
    geodesic: GeodesicSolver
    filter_params: FilterParams
    lsq: LsqSettings
    zone_lane: tuple[tuple[int, int] | None, tuple[int, int] | None, tuple[int, int] | None]
    filter_params_gnss: FilterParams | None = None
    """The filter parameters for a fix whose GPS is receiver-weighted (HDOP × UERE): "auto"
    τ and fraction of a modern receiver (docs/GNSS_WEIGHTS.md); None: as ``filter_params``."""
    parts: CycleParts = REFERENCE
    """The collaborators the cycle does its hot work with (chosen by the run loop)."""
    _grids: dict[float, TMGrid] = field(default_factory=dict)
    _placed: dict[float, ChainOnGrid | None] = field(default_factory=dict)
    _derived: _ConfigDerived | None = field(default=None, repr=False, compare=False)
    _motion_params: dict[tuple[int, int], FilterParams] = field(
        default_factory=dict, repr=False, compare=False)
    _motion_last: tuple[tuple[float, float], FilterParams] | None = field(
        default=None, repr=False, compare=False)
    new: _Makers = field(init=False, repr=False, compare=False)
    """The cycle's dataclasses made positionally by the run's parts (:class:`_Makers`)."""

    def __post_init__(self) -> None:
        self.new = _Makers.of(self.parts)

    def derived(self) -> _ConfigDerived:
        """What every cycle reads from the configuration and the system registry, computed once
        per configuration (a test or the console may put another ``config`` in place: then it
        is computed again; so is it when a test registers another system)."""
        d = self._derived
        if d is None or d.config is not self.config or d.systems is not registry.SYSTEMS:
            d = self._derived = _ConfigDerived.of(self.config, self.parts)
        return d

    def motion_params(self, motion: nmotion.MotionState) -> FilterParams:
        """``filter_params`` with the stand-in's learnt ψ̇_max and σ_a² (engine.filter.motion),
        on a grid of 1–2 % steps in their logarithms so that a run makes few of them (each
        keeps its own per-Δt constants), never above the configured ones (the caps: those
        parameters themselves); at most 256 are kept."""
        last = self._motion_last
        if last is not None and last[0] == (motion.turn_rate_max_deg_s, motion.sigma_a2):
            return last[1]
        base = self.filter_params
        turn, a2 = motion.turn_rate_max_deg_s, motion.sigma_a2
        if turn >= base.turn_rate_max_deg_s and a2 >= base.sigma_a2:
            p = base  # the caps: the configured parameters themselves
        else:
            key = (round(50.0 * math.log(turn)), round(100.0 * math.log(a2)))
            p = self._motion_params.get(key)
            if p is None:
                if len(self._motion_params) >= 256:
                    self._motion_params.clear()
                p = self._motion_params[key] = replace(
                    base, turn_rate_max_deg_s=min(math.exp(key[0] / 50.0),
                                                  base.turn_rate_max_deg_s),
                    sigma_a2=min(math.exp(key[1] / 100.0), base.sigma_a2))
        self._motion_last = ((motion.turn_rate_max_deg_s, motion.sigma_a2), p)
        return p

    def grid(self, cm_deg: float) -> TMGrid:
        """The TM grid of the working datum at central meridian ``cm_deg``."""
        g = self._grids.get(cm_deg)
        if g is None:
            g = self.parts.grid(self.working.ellipsoid, cm_deg)
            self._grids[cm_deg] = g
        return g

    def placed_chain(self, cm_deg: float) -> ChainOnGrid | None:
        """The selected Decca chain on the grid of ``cm_deg`` (None if Decca has no chain)."""
        if cm_deg in self._placed:
            return self._placed[cm_deg]
        chain = self.chains.get(self.config.decca.chain)
        placed = None
        if chain is not None:
            shift = None
            if chain.datum_name.upper() != self.working.name.upper():
                shift = self.parts.datum_shift(self.datums.datum(chain.datum_name),
                                               self.working)
            placed = place_chain_on_datum(chain, self.grid(cm_deg), shift)
        self._placed[cm_deg] = placed
        return placed


def build_context(cfg: RunConfig, datums: DatumFile, chains: dict[str, DeccaChain],
                  parts: CycleParts | None = None) -> RunContext:
    """Build the run context for ``cfg`` (raises InputError for an unknown datum or chain)
    with the collaborators ``parts`` (None: the run's choice, :func:`engine.run.parts.choose`);
    ``filter.vessel = "auto"`` is resolved for the run file (:func:`resolve_vessel`)."""
    if parts is None:
        parts = choose()
    cfg = resolve_vessel(cfg)
    working = datums.datum(cfg.datum)
    gps_datum = datums.datum(cfg.run_gps_datum) if cfg.run_gps_datum.upper() != "WGS84" else WGS84
    shift = None if gps_datum.name.upper() == working.name.upper() else parts.datum_shift(
        gps_datum, working
    )
    to_wgs = None if gps_datum is WGS84 else parts.datum_shift(gps_datum, WGS84)
    d = cfg.decca
    zl = tuple(
        parse_zone_lane(text, pattern) if text else None
        for text, pattern in ((d.red, "red"), (d.green, "green"), (d.purple, "purple"))
    )
    return RunContext(
        config=cfg,
        datums=datums,
        chains=chains,
        working=working,
        gps_shift=shift,
        gps_to_wgs84=to_wgs,
        geodesic=parts.geodesic(working.ellipsoid),
        filter_params=filter_params_from_config(cfg),
        lsq=lsq_settings_from_config(cfg),
        zone_lane=(zl[0], zl[1], zl[2]),
        filter_params_gnss=filter_params_from_config(cfg, gnss_receiver=True),
        parts=parts,
    )


@dataclass(frozen=True, slots=True)
class SensorValues:
    """Converted sensor values of a cycle (None = not available) and each sensor's status code
    (A8.2: 0 connected-off, 1 on, 2 not connected) in the order of ``SENSOR_NAMES``."""

    status: tuple[int, ...]
    heading_true_deg: float | None
    speed_kn: float | None
    rudder_deg: float | None
    incl_deg: float | None
    depth_m: float | None
    echo_m: float | None
    convergence_deg: float
    reference: str = "water"
    """What the dead reckoning is referenced to: "water" (gyro heading, log speed: the filter's
    current states are the current), "ground" (COG/SOG stand in, ``sensors.cog_sog``: ψ is
    the course and v the speed over ground, the current states only take up what the fixes show
    beyond them) or "none" (no heading or speed: no dead reckoning)."""
    heading_sigma_deg: float | None = None
    """σ of the heading row when it is not the gyro's (COG stand-in); None: the gyro's."""
    speed_sigma_ms: float | None = None
    """σ of the speed row when it is not the log's (SOG stand-in); None: the log's."""

    @property
    def standin(self) -> bool:
        """True when COG/SOG stand in for the gyro heading / log speed this cycle."""
        return self.reference == "ground"


@dataclass(frozen=True, slots=True)
class CycleResult:
    """Everything one cycle produced (immutable; the pages, logs and tests read only this)."""

    n: int
    record: int
    time: datetime
    raw: str
    dt_s: float
    datum: str
    cm_deg: float
    systems: str
    sensors: SensorValues
    gps: GpsInput | None
    decca_fractions: tuple[float | None, float | None, float | None]
    decca_on: bool
    fix: FixResult | None
    kf_pred: PositionEstimate | None
    kf: PositionEstimate | None
    mpp: PositionEstimate
    filter_status: str
    filter_state: FilterState | None
    filter_update: UpdateResult | None
    cumulative: CumulativeVariance
    manual: tuple[ManualObservation, ...] = ()
    messages: tuple[str, ...] = ()
    smoother_link: tuple[FilterState, FilterState, np.ndarray] | None = None
    """(state at the previous epoch after this record's gyro/log update, its prediction to this
    epoch, Φ): what the RTS smoother needs to go back over this step."""
    sensor_update: UpdateResult | None = None
    """The update with this record's gyro, log and inclinometer rows, made before the step into
    this epoch (docs/DECISIONS.md "Sensor timing"); ``filter_update`` is the update at this
    epoch (fix or raw LOPs, and the pressure depth). Both carry their LOM and LS tests."""
    fix_fails_tests: bool = False
    """The LSE failed its tests (:func:`fix_fit`): a message says so; .OUT/JSONL record it."""
    fix_cov_scale: float = 1.0
    """The factor the LSE's VCV was multiplied by before the filter and the MPP used it: S² of
    a fix failing its tests, or the learnt factor (``[filter] adapt``) when that is larger."""
    fix_gate: str = ""
    """Why this epoch's fix is marked: "gross" (kept out by the gross-error gate,
    :data:`GROSS_GATE_SIGMA`), "innovation" (taken, but the filter's innovation (LOM) test
    rejects it), "recovered" (the filter was found diverged and the remedy of ``[filter]
    recover`` acted, THEORY §8.18), "" otherwise. The messages say the same in words."""
    lane_slips: int = 0
    """Decca lane slips corrected against GPS this cycle (one per pattern)."""
    adapt: nadapt.AdaptState | None = None
    """The learnt fix-VCV factor after this cycle (``[filter] adapt``; None: off)."""
    adapt_logged: bool = False
    """The factor moved by more than :data:`ADAPT_LOG_STEP` since it was last logged (or
    this is the first cycle with a factor), or the dead-reckoning factor changed: the ``.OUT``
    has an ``ADAPT`` line."""
    decca_cf: float | None = None
    """The ``Decca.CF`` of this cycle's Decca VCV (None: no Decca reading)."""
    decca_condition: str = ""
    """Its sky-wave condition (``SD``, ``WD``, ``SN``, ``WN``) when ``lsq.decca_cf = "auto"``
    chose it ("" for a fixed CF)."""
    dr_adapt: nhorizon.DrAdaptState | None = None
    """The learnt dead-reckoning noise factor μ after this cycle (``[filter] adapt_dr``,
    THEORY §8.19; None: off)."""
    motion: nmotion.MotionState | None = None
    """The COG/SOG stand-in's learnt process noise after this cycle (None: not learnt); the
    ``.OUT`` has a ``MOTION`` line with the ``ADAPT`` line."""


@dataclass(frozen=True, slots=True)
class NavState:
    """What one cycle hands to the next (the thesis' "common block", minus configuration)."""

    n: int = 0
    last_time: datetime | None = None
    cm_deg: float | None = None
    mpp_lat_deg: float = 0.0
    mpp_lon_deg: float = 0.0
    filter: FilterState | None = None
    cumulative: CumulativeVariance = field(default_factory=CumulativeVariance)
    pending_obs: tuple[ManualObservation, ...] = ()
    press_ref_hz: float | None = None
    decca_track: tuple[tuple[float, datetime] | None, ...] = (None, None, None)
    filter_has_fix: bool = False
    fix_source: tuple[object, ...] | None = None
    """The fix source (:func:`fix_source`) the filter's Gauss–Markov fix-error states model."""
    gated_fixes: int = 0
    """Fixes in a row kept out of the filter as gross errors (:data:`GROSS_GATE_SIGMA`)."""
    dr_reference: str = ""
    """The dead-reckoning reference of the last cycle (:attr:`SensorValues.reference`; "" before
    the first): a change is said."""
    filter_reference: str = "water"
    """The reference ("water" or "ground") the filter's current and log/gyro bias states belong
    to: a sensor update with the other one restarts them (:func:`restart_dr_states`)."""
    adapt: nadapt.AdaptState | None = None
    """The learnt fix-VCV factor (engine.filter.adapt; None: adaptation off)."""
    adapt_logged: float = 0.0
    """The factor last written to the ``.OUT`` (0: none yet)."""
    decca_condition: str = ""
    """The last Decca sky-wave condition ``lsq.decca_cf = "auto"`` chose ("": none yet): a
    change is said."""
    divergence: ndiv.DivergenceWatch | None = None
    """The run of consistent innovation-test rejections (``[filter] recover``; None: none)."""
    dr_adapt: nhorizon.DrAdaptState | None = None
    """The learnt dead-reckoning noise factor and its shadow predictions (THEORY §8.19)."""
    motion: nmotion.MotionState | None = None
    """The COG/SOG stand-in's learnt process noise (engine.filter.motion; None: not learnt)."""
    motion_logged: float = 0.0
    """ψ̇_max × σ_a² last written to the ``.OUT`` (0: none yet)."""


def initial_state(cfg: RunConfig) -> NavState:
    """The state before the first record: the operator's DR position, no filter yet."""
    return NavState(mpp_lat_deg=cfg.dr_lat_deg, mpp_lon_deg=cfg.dr_lon_deg)


GROSS_GATE_SIGMA = 30.0
"""A fix whose innovation is longer than this many σ (Mahalanobis, against S = HPHᵀ + R) is a
gross error, not a statistical one: the filter does not take it (a GPS fix 5800 km off would
otherwise pull speed and current to hundreds of m/s). The w-tests flag anything beyond ~3 σ; the
gate only stops what no test could make good. A lane slip of one Decca lane (~500 m) against a
20 m filter is 25 σ and still goes in, to be flagged by the tests as the thesis does."""
GROSS_GATE_RESET = 3
"""After this many gated LSE fixes in a row the filter, not the fixes, is taken to be wrong: its
position restarts from the LSE as at the start of a run (THEORY D22)."""

DEPTH_PLAUSIBLE_M = (-20.0, 11_000.0)
"""Pressure depths (m, positive down) a reading may give: from 20 m above the surface (a wrong
reference frequency, a crystal out of calibration) to the deepest ocean. A reading outside is
not used; the cycle says so (a run must not take a −268 km depth into the filter)."""


def _sensors(ctx: RunContext, nav: NavState, rec: RunRecord, grid: TMGrid,
             lat: float, lon: float,
             messages: list[str]) -> tuple[SensorValues, float | None]:
    cfg = ctx.config
    status = ctx.derived().sensor_status
    depth = None
    ref = nav.press_ref_hz
    if status[4] == 1 and rec.press_freq_hz is not None:
        if ref is None:
            ref = surface_reference_hz(cfg.demo.press_ref_freq_hz)
        depth = pressure_depth_m(rec.press_freq_hz, ref, cfg.demo.s_weight)
        if not DEPTH_PLAUSIBLE_M[0] <= depth <= DEPTH_PLAUSIBLE_M[1]:
            messages.append(f"Pressure {rec.press_freq_hz:.3f} Hz gives depth {depth:.0f} m: "
                            "implausible, not used")
            depth = None
    heading = rec.heading_deg if status[0] == 1 else None
    speed = rec.speed_kn if status[1] == 1 else None
    reference, h_sigma, s_sigma = "water", None, None
    if heading is None or speed is None:
        reference = "none"
        if cfg.sensors.standin and rec.sog_kn is not None:
            # Ground reference for both rows (docs/GNSS_WEIGHTS.md): a water heading with a
            # ground speed would leave the drift angle to the current states at every turn.
            reference = "ground"
            speed = rec.sog_kn
            heading = (rec.cog_deg if rec.cog_deg is not None
                       and rec.sog_kn >= cfg.sensors.cog_min_sog_kn else None)
            h_sigma, s_sigma = standin_sigmas(rec.sog_kn)
    values = ctx.new.sensor_values(  # SensorValues(...) positionally: the order of the fields
        status,
        heading,
        speed,
        rec.rudder_deg if status[2] == 1 else None,
        rec.incl_deg if status[3] == 1 else None,
        depth,
        rec.echo_m if status[5] == 1 else None,
        grid.convergence_deg(lat, lon),
        reference,
        h_sigma,
        s_sigma,
    )
    return values, ref


def _reference_messages(nav: NavState, sens: SensorValues, rec: RunRecord,
                        messages: list[str]) -> None:
    """Say when the dead-reckoning reference changes (first cycle: only when it is not the
    gyro/log, so a 1993 run's messages stay as they were)."""
    ref = sens.reference
    if ref == nav.dr_reference or (ref == "water" and nav.dr_reference == ""):
        return
    if ref == "ground":
        h_sigma = sens.heading_sigma_deg or 0.0
        messages.append(f"COG/SOG stand in for the missing gyro/log (σ COG {h_sigma:.1f}°, "
                        f"SOG {sens.speed_sigma_ms or 0.0:.2f} m/s): dead reckoning over "
                        "ground, current = what the fixes show beyond COG/SOG")
    elif ref == "none":
        have = rec.sog_kn is not None
        messages.append("No gyro heading or log speed: no dead reckoning, LSE only"
                        + (' (COG/SOG in the record: sensors.cog_sog = "standin" uses them)'
                           if have else ""))
    else:
        messages.append("Gyro and log back: dead reckoning through the water")


def _cm_for(nav: NavState, lon: float) -> float:
    cm = nav.cm_deg
    if cm is None:
        return central_meridian_deg(lon)
    diff = wrap_180_deg(lon - cm)
    if abs(diff) > 0.5 + CM_HYSTERESIS_DEG:
        return central_meridian_deg(lon)
    return cm


_NO_COV = np.full((2, 2), np.nan)
"""Placeholder VCV of a cycle without a fix (never used: every use is behind ``fix``)."""


def fix_fit(fix: FixResult | None) -> tuple[float, str | None]:
    """How far the filter and the MPP may trust an LSE that fails its own tests.

    A fix fails when the unit-variance test rejects S² on the high side (eq. 5.15–5.17: the
    residuals are larger than its a priori VCV allows) or when every tested LOP fails the
    w-test (|w| > 2.576, eq. 5.10). Returns (factor, message): the fix's VCV C_x̂ is to be
    multiplied by the a posteriori variance factor S² (> the test's upper bound > 1), the
    estimate of how much C_l understates the errors (the thesis' own ScaleVCV remedy, A8.2; the
    "advice: scale the a priori VCV by S²" of engine.lsq.statistics). The filter then weighs the fix
    by what its residuals show instead of what was assumed: a fix whose LOPs are hundreds of σ
    apart (a damaged chain file, S² ~ 10⁵) moves the filter by ~1/S² of what it would have, and
    its ellipse as the MPP is S² larger in area. Dropping such fixes instead would lose every
    fix of a run whose a priori VCV is merely optimistic (Decca at night); scaling degrades
    gracefully and the message says what happened. A fix already scaled by ScaleVCV keeps its
    factor 1 (scaled once); a hybrid fix (filter prediction as LOPs) is the filter's to test.
    ``(1.0, None)`` when the fix passes.
    """
    if fix is None or not fix.lse_ok or fix.tested is None:
        return 1.0, None
    vt = fix.tested.variance_test
    s2 = fix.s2
    global_fail = vt is not None and s2 is not None and s2 > vt.upper
    n_w = 0  # used LOPs with a finite w; all flagged while each |w| > REJECT_BOUND
    all_flagged = True
    for lop in fix.lops:
        if lop.used and math.isfinite(lop.w):
            if not abs(lop.w) > REJECT_BOUND:
                all_flagged = False
                break
            n_w += 1
    all_flagged = all_flagged and n_w > 0
    if not (global_fail or all_flagged):
        return 1.0, None
    parts = []
    if global_fail and vt is not None and s2 is not None:
        parts.append(f"S² {s2:.3g} > {vt.upper:.3g}")
    if all_flagged:
        parts.append(f"{n_w}/{n_w} w-tests fail")
    # Short enough for the console's 80-column message line (shown first of the cycle's).
    if fix.tested.adjustment.scaled or s2 is None or s2 <= 1.0:
        return 1.0, f"Fix fails its tests ({'; '.join(parts)})"
    return s2, f"Fix fails its tests ({'; '.join(parts)}): VCV × S² used"


def step(
    ctx: RunContext,
    nav: NavState,
    rec: RunRecord,
    *,
    excluded_slots: Sequence[int] = (),
) -> tuple[NavState, CycleResult]:
    """Process one record: sensors, LOPs, LSE (or too-few-LOPs / DR-only path), filter, MPP.

    The phases, in order: the record's interval and grid, sensors, dead reckoning (filter
    start, sensor update, prediction), the systems' readings, the fix and its fitness, the
    filter updates, the MPP, and the assembly of the result and the next state.
    Raises nothing for bad data (the parser already rejected malformed records); a record whose
    time does not advance raises :class:`ValueError`, which the replay loop logs and skips.
    """
    dt = _interval(ctx, nav, rec)
    messages: list[str] = []
    cm, grid, fstate = _grid_for_cycle(ctx, nav, messages)
    sens, press_ref = _sensors(ctx, nav, rec, grid, nav.mpp_lat_deg, nav.mpp_lon_deg,
                               messages)
    _reference_messages(nav, sens, rec, messages)
    motion = nav.motion
    msettings = ctx.derived().motion
    q_params = None
    if msettings is not None:
        motion = _learn_motion(ctx, motion, msettings, rec)
        q_params = ctx.motion_params(motion)
    pred = _dead_reckoning(ctx, nav, fstate, sens, grid, dt, q_params)
    x_start, prior = _provisional(ctx, nav, grid, pred.state)
    readings = _read_systems(ctx, nav, rec, grid, cm, x_start, prior, messages)
    fix = _fix(ctx, nav, grid, x_start, prior, readings, excluded_slots, messages)
    fit_scale, fit_note, fix_cov = _fitness(fix, messages)
    gnss = gnss_source(readings[GPS.name])
    settings = ctx.derived().adapt
    learnt = None
    if settings is not None:
        learnt = _adapt_before(ctx, nav, gnss)
        lam = learnt.fix_factor
        if fix is not None and lam > fit_scale:
            # the learnt fix VCV (THEORY §8.17); a fix failing its tests keeps its own
            # S² when that is larger (never both)
            fix_cov = fix.cov * lam
            fit_scale = lam
    filt = _update_filter(ctx, nav, pred, sens, fix, fix_cov, gnss, messages,
                          (dt, fit_scale))
    logged = nav.adapt_logged
    log_adapt = False
    if settings is not None and learnt is not None:
        learnt = _adapt_after(learnt, fix, filt.result, settings, messages, fit_scale)
        log_adapt = not (logged > 0.0 and abs(learnt.fix_factor / logged - 1.0)
                         <= ADAPT_LOG_STEP)
    dr = nav.dr_adapt
    dr_settings = ctx.derived().dr_adapt
    if dr_settings is not None:
        dr = _dr_adapt(ctx, nav, pred, filt, fix, fix_cov, gnss, cm, dt, dr_settings,
                       messages)
        log_adapt = log_adapt or nav.dr_adapt is None or dr.mu != nav.dr_adapt.mu
    if log_adapt and learnt is not None:
        logged = learnt.fix_factor
    motion_logged = nav.motion_logged
    if motion is not None:
        mq = motion.turn_rate_max_deg_s * motion.sigma_a2
        if log_adapt or not (motion_logged > 0.0 and abs(mq / motion_logged - 1.0)
                             <= ADAPT_LOG_STEP):
            log_adapt, motion_logged = True, mq
    kf_est = None
    if filt.state is not None and filt.status == "ON":
        # Without an update at this epoch (dead reckoning only: a dive) the filtered state is
        # the prediction, whose estimate the cycle has already made: not converted again.
        kf_est = (pred.estimate if filt.state is pred.state and pred.estimate is not None
                  else ctx.parts.estimate("KF", grid, filt.state))
    mpp = _mpp(ctx, nav, grid, kf_est, filt.state, fix, fix_cov, messages)
    cumulative = nav.cumulative
    if fix is not None and fix.lse_ok and fix.s2 is not None:
        cumulative = cumulative.update(fix.s2, fix.n_used - 2)
    lanes = readings[DECCA.name].detail
    decca_cf, condition = _decca_condition(nav, readings[DECCA.name].value, messages)
    n = nav.n + 1
    link = filt.link
    # CycleResult(...) and NavState(...) positionally, in the order of their fields
    result = ctx.new.result(
        n, rec.line_no, rec.time, rec.raw, dt, ctx.working.name, cm,
        ctx.derived().systems_string, sens, readings[GPS.name].detail, rec.decca,
        ctx.config.decca.on, fix, pred.estimate, kf_est, mpp, filt.status, filt.state,
        filt.result, cumulative, nav.pending_obs, tuple(messages), link,
        pred.sensor_update, fit_note is not None, fit_scale, filt.gate,
        0 if lanes is None else lanes.slips, learnt, log_adapt, decca_cf, condition, dr, motion,
    )
    ctx.parts.freeze(fix, None if link is None else link[2], filt.result, pred.sensor_update)
    next_nav = ctx.new.nav(
        n, rec.time, cm, mpp.lat_deg, mpp.lon_deg, filt.state, cumulative, (), press_ref,
        nav.decca_track if lanes is None else lanes.track, filt.has_fix, filt.source,
        filt.gated, sens.reference, pred.reference, learnt, logged,
        condition or nav.decca_condition, filt.watch, dr, motion, motion_logged,
    )
    return next_nav, result


def _decca_condition(nav: NavState, reading: DeccaReading | None,
                     messages: list[str]) -> tuple[float | None, str]:
    """(``Decca.CF`` of this cycle's Decca reading or None, its "auto" condition code or "");
    a condition other than the last one chosen is said (docs/THEORY.md §3.5)."""
    if reading is None:
        return None, ""
    cond = reading.condition
    if cond is None:
        return reading.cf, ""
    if cond.code != nav.decca_condition:
        messages.append(f"Decca sky-wave: {cond.name}, CF {cond.cf:.4g} "
                        f"(sun {cond.sun_deg:+.1f}°)")
    return reading.cf, cond.code


ADAPT_LOG_STEP = 0.05
"""The ``.OUT`` gets an ``ADAPT`` line when the learnt fix factor has moved by more than this
(relative) since the last one it got: the factor moves by at most ~1 % a fix epoch once it has
settled, so a log holds a line every half minute or so while the factor moves (63 in a 20-min
Decca-only run with errors 3 × their VCV) and none while it holds."""


def _learn_motion(ctx: RunContext, motion: nmotion.MotionState | None,
                  settings: nmotion.MotionSettings, rec: RunRecord) -> nmotion.MotionState:
    """This record's COG/SOG into the stand-in's learnt process noise (engine.filter.motion):
    a COG is usable at ``sensors.cog_min_sog_kn`` or more."""
    if motion is None:
        motion = nmotion.start(settings)
    sog = rec.sog_kn
    if sog is None and rec.cog_deg is None:
        return motion
    usable = sog is not None and sog >= ctx.config.sensors.cog_min_sog_kn
    return nmotion.learn(motion, settings, rec.time, rec.cog_deg,
                         None if sog is None else knots_to_ms(sog), usable)


def _adapt_before(ctx: RunContext, nav: NavState,
                  gnss: tuple[object, ...] | None) -> nadapt.AdaptState:
    """The learnt fix factor for this cycle's fix source: the one learnt so far, or λ = 1
    when the source is new (a new receiver, chain or pattern set is a new error process)."""
    base = ctx.derived().fix_source
    # _with_gnss(base, gnss, nav.fix_source), its usual case (a GPS record) done here
    source = base + gnss if gnss is not None else _with_gnss(base, gnss, nav.fix_source)
    learnt = nav.adapt
    if learnt is None or learnt.source != source:
        return nadapt.start(source)
    return learnt


def _adapt_after(learnt: nadapt.AdaptState, fix: FixResult | None,
                 result: UpdateResult | None, settings: nadapt.AdaptSettings,
                 messages: list[str], scale: float = 1.0) -> nadapt.AdaptState:
    """One step of the learnt factor from this epoch's LSE (its S² when it has redundancy)
    and fix update (the NIS of its ``x_LSE``/``y_LSE`` rows); neither: unchanged. A fix kept
    out by the gross-error gate is not in ``result``; a hybrid fix (the filter's prediction
    as LOPs) is not an independent LSE and teaches nothing."""
    if fix is None or not fix.lse_ok or fix.uses_prior:
        return learnt
    nis = None
    if result is not None and "x_LSE" in result.labels:
        i = result.labels.index("x_LSE")
        # The update weighed the fix with its VCV × ``scale`` (λ, or S² of a fix failing its
        # tests): its NIS is λ_true/scale·χ²₂/2. learn_fix divides by the λ in force, as it
        # does S² (relative to the a-priori VCV), so the NIS goes in relative to it too:
        # × scale. Not multiplied, the fixed point was √λ_true (THEORY §8.17).
        nis = nadapt.fix_nis_ratio(result.innovation, result.S, slice(i, i + 2)) * scale
    dof = fix.n_used - 2
    learnt, msg = nadapt.learn_fix(learnt, settings, nis=nis, s2=fix.s2, s2_dof=dof)
    if msg is not None:
        messages.append(msg)
    return learnt


def _dr_adapt(ctx: RunContext, nav: NavState, pred: _Prediction, filt: _Filtering,
              fix: FixResult | None, fix_cov: np.ndarray, gnss: tuple[object, ...] | None,
              cm: float, dt: float, settings: nhorizon.DrAdaptSettings,
              messages: list[str]) -> nhorizon.DrAdaptState:
    """The shadow predictions of this cycle (THEORY §8.19): each takes this record's sensor
    rows and step; the oldest due one is checked against a fix the filter took (not a gross
    error, not a hybrid fix) and μ learnt from it; a new one starts from the filter after the
    fix update. A new grid or dead-reckoning reference drops them (another frame)."""
    st = nav.dr_adapt or nhorizon.DrAdaptState()
    fs = filt.state
    if (pred.state is None or fs is None or (nav.cm_deg is not None and cm != nav.cm_deg)
            or pred.reference != nav.filter_reference):
        return st._with((), None, st.last_start) if st.shadows else st
    parts = ctx.parts
    params = nhorizon.scaled_params(ctx.filter_params, st.mu)
    if st.shadows:
        zs, var, layout = pred.rows if pred.rows is not None else ((), (), None)
        st = nhorizon.advance(st, zs, var, layout, dt, params, parts.update_rows,
                              parts.predict, settings)
    taken = (fix is not None and fix.lse_ok and not fix.uses_prior and filt.gate != "gross"
             and filt.status == "ON" and filt.has_fix)
    if st.shadows and fs.t - st.shadows[0].t0 >= settings.horizon_s - 1e-6:  # one is due
        p = ctx.filter_params_gnss if gnss and ctx.filter_params_gnss is not None else \
            ctx.filter_params
        white = 1.0 - p.fix_sigma_frac if p.coloured else 1.0
        st, msg = nhorizon.check(st, fs.t, (fix.x_m, fix.y_m) if taken and fix else None,
                                 fix_cov if taken else None, white, params, parts.update_rows,
                                 parts.predict, settings)
        if msg is not None:
            messages.append(msg)
    if taken:
        st = nhorizon.start_shadow(st, fs, settings)
    return st


def _interval(ctx: RunContext, nav: NavState, rec: RunRecord) -> float:
    """The time step into this record (s): ``demo.delta_t_s`` for the first record, else the
    time since the last (ValueError when it does not advance)."""
    if nav.last_time is None:
        return float(ctx.config.demo.delta_t_s)
    dt = (rec.time - nav.last_time).total_seconds()
    if dt <= 0.0:
        raise ValueError(f"record time {rec.time:%H:%M:%S} does not advance")
    return dt


def _grid_for_cycle(ctx: RunContext, nav: NavState,
                    messages: list[str]) -> tuple[float, TMGrid, FilterState | None]:
    """The cycle's CM (from the provisional position, the last MPP, THEORY D3), its grid
    and the filter state re-projected onto it when the CM changed."""
    cm = _cm_for(nav, nav.mpp_lon_deg)
    grid = ctx.grid(cm)
    fstate = nav.filter
    if fstate is not None and nav.cm_deg is not None and cm != nav.cm_deg:
        fstate = reproject_state(fstate, ctx.grid(nav.cm_deg), grid)
        messages.append(f"CM changed to {cm:+.0f}°: grid re-projected")
    return cm, grid, fstate


@dataclass(slots=True)
class _Prediction:
    """The dead-reckoning phase: the predicted filter state at this epoch and its estimate, the
    smoother link, the update with this record's gyro/log/inclinometer rows and whether there
    were any (None/False without a filter)."""

    state: FilterState | None = None
    estimate: PositionEstimate | None = None
    link: tuple[FilterState, FilterState, np.ndarray] | None = None
    sensor_update: UpdateResult | None = None
    dr_sensors: bool = False
    reference: str = "water"
    """The reference the filter's current and bias states now belong to."""
    rows: tuple[list[float], list[float], SensorLayout] | None = None
    """This record's gyro/log/inclinometer rows (values, variances, layout; THEORY §8.19's
    shadow predictions take them too)."""


def _dead_reckoning(ctx: RunContext, nav: NavState, fstate: FilterState | None,
                    sens: SensorValues, grid: TMGrid, dt: float,
                    q_params: FilterParams | None = None) -> _Prediction:
    """Start the filter from the DR position if needed, update it with this record's sensors
    and predict it one step (THEORY D22); ``q_params``: the parameters of the step over
    ground with the stand-in's learnt process noise (:meth:`RunContext.motion_params`)."""
    params = ctx.filter_params
    gamma = sens.convergence_deg
    heading_grid = (
        None if sens.heading_true_deg is None else math.radians(sens.heading_true_deg - gamma)
    )
    speed_ms = None if sens.speed_kn is None else knots_to_ms(sens.speed_kn)
    incl = None if sens.incl_deg is None else math.radians(sens.incl_deg)
    initialised = False
    reference = nav.filter_reference
    if fstate is None and heading_grid is not None and speed_ms is not None:
        fstate = _start_filter(ctx, nav, grid, gamma, speed_ms, heading_grid, incl, sens)
        initialised = True
        reference = sens.reference
    if fstate is None:
        return _Prediction(reference=reference)
    if sens.reference in ("water", "ground") and sens.reference != reference:
        # COG/SOG ↔ gyro/log: the current and the two biases belong to the other sensors.
        fstate = restart_dr_states(fstate, params)
        reference = sens.reference
    if reference == "ground" and sens.reference == "none":
        # Over ground (COG/SOG stand-in) without COG/SOG this record (a GNSS outage): a water
        # speed or a compass heading alone is not the ground speed/course the filter's states
        # are, and the current that separates them is not estimated over ground; using the
        # log's 2-5 % σ on the ground speed made the outage ellipse far too small on the Plaka
        # log (docs/REALDATA.md). The filter coasts on its process noise instead.
        heading_grid = speed_ms = None
    # Heading and speed of this record drive the step into it (THEORY §14.1 item 6: the
    # sample's KF row moves on the mean of the two records' gyro headings). A state just
    # initialised from this record's readings has them already (no double counting).
    # The rows of sensor_measurement(fstate, log_ms=…, gyro_grid_rad=…, incl_rad=…), updated
    # from their values, variances and layout (update_rows).
    zs, var, layout = sensor_rows(None, speed_ms, heading_grid, incl, params,
                                  sens.speed_sigma_ms, sens.heading_sigma_deg)
    dr_sensors = len(zs) > 0
    sens_result = None
    if dr_sensors and not initialised:
        sens_result = ctx.parts.update_rows(fstate, zs, var, layout, params)
        fstate = sens_result.state
    if q_params is not None and reference == "ground":
        params = q_params
    qparams = params if nav.dr_adapt is None else nhorizon.scaled_params(params,
                                                                         nav.dr_adapt.mu)
    pred_state, phi, est = ctx.parts.predict_estimate(fstate, dt, qparams, "KF", grid)
    # _Prediction(...) positionally, every field
    return ctx.new.prediction(pred_state, est, (fstate, pred_state, phi), sens_result,
                              dr_sensors, reference, (zs, var, layout))


def _start_filter(ctx: RunContext, nav: NavState, grid: TMGrid, gamma: float, speed_ms: float,
                  heading_grid: float, incl: float | None, sens: SensorValues) -> FilterState:
    """The filter's first state: the DR position and depth, this record's speed, grid heading
    and inclination, the configured current (grid set), P0 per ``filter.p0``. Over ground
    (COG/SOG stand-in) the current starts at 0 (SOG/COG already hold it) and the speed and
    heading have the stand-in's σ."""
    cfg = ctx.config
    x0, y0 = grid.forward(nav.mpp_lat_deg, nav.mpp_lon_deg)
    set_rad = math.radians(cfg.current_set_deg)
    vc = 0.0 if sens.standin else knots_to_ms(cfg.current_speed_kn)
    pos_cov = None if cfg.filter.p0 == "thesis" else np.eye(2) * cfg.filter.dr_sigma_m**2
    params = ctx.filter_params
    if sens.standin and sens.speed_sigma_ms is not None and sens.heading_sigma_deg is not None:
        params = replace(params, sigma_gyro_deg=sens.heading_sigma_deg, log_sigma_frac=0.0,
                         log_sigma_floor_ms=sens.speed_sigma_ms)
    return init_state(
        0.0, x0, y0, cfg.depth_m, speed_ms, heading_grid, incl or 0.0,
        vc * math.sin(set_rad - math.radians(gamma)),
        vc * math.cos(set_rad - math.radians(gamma)),
        params, pos_cov=pos_cov, from_sensors=(True, True, incl is not None),
    )


def _provisional(ctx: RunContext, nav: NavState, grid: TMGrid,
                 pred_state: FilterState | None) -> tuple[tuple[float, float],
                                                         PositionPrior | None]:
    """The provisional position of the fix (grid m) and the filter's a priori position: the
    prediction when there is a filter, else the last MPP without a prior."""
    if pred_state is None:
        return grid.forward(nav.mpp_lat_deg, nav.mpp_lon_deg), None
    return ctx.parts.prior(pred_state)  # type: ignore[no-any-return]


def _read_systems(ctx: RunContext, nav: NavState, rec: RunRecord, grid: TMGrid, cm: float,
                  x_start: tuple[float, float], prior: PositionPrior | None,
                  messages: list[str]) -> dict[str, SystemReading]:
    """Every navigation system's reading of this record, in registry order (a system sees the
    readings before it: Decca checks its lanes against GPS)."""
    readings: dict[str, SystemReading] = {}
    extend = messages.extend
    make = ctx.new.inputs  # CycleInputs(...) positionally
    config = ctx.config
    for system in ctx.derived().run_systems:
        reading = system.read(make(config, ctx, nav, rec, grid, cm, x_start, prior,
                                   dict(readings)))
        if reading.messages:
            extend(reading.messages)
        readings[system.name] = reading
    return readings


def _fix(ctx: RunContext, nav: NavState, grid: TMGrid, x_start: tuple[float, float],
         prior: PositionPrior | None, readings: Mapping[str, SystemReading],
         excluded_slots: Sequence[int], messages: list[str]) -> FixResult | None:
    """The least-squares fix of the systems' readings (None when no system observed anything),
    with the operator messages of its tests."""
    values: dict[str, object] = {}
    observes = False
    for name, r in readings.items():  # one loop (no generator and comprehension frames)
        values[name] = r.value
        if r.observes:
            observes = True
    if not observes:
        return None
    fix = ctx.parts.compute_fix(grid, ctx.geodesic, x_start, prior=prior, settings=ctx.lsq,
                      excluded_slots=excluded_slots, readings=values,
                      systems=ctx.derived().run_systems)
    if fix.candidate_slot is not None:
        name = lop_name(fix.candidate_slot, system="KF" if fix.uses_prior else "GPS",
                        manual=nav.pending_obs)
        messages.append(f"LOP {name} fails the w-test: discard it?")
    messages.extend(fix.messages)
    if fix.rejected_slots or fix.candidate_slot is not None:  # else gps_voted_out is None
        voted = gps_voted_out(fix)
        if voted is not None:
            messages.append(voted)
    return fix


def _fitness(fix: FixResult | None,
             messages: list[str]) -> tuple[float, str | None, np.ndarray]:
    """A fix that fails its tests is not taken at face value (:func:`fix_fit`, issue 15 item
    6): (VCV factor, message, the VCV the filter and the MPP use); the message goes first."""
    fit_scale, fit_note = fix_fit(fix)
    if fit_note is not None:
        messages.insert(0, fit_note)  # first: the console's message line shows it at 80 columns
    fix_cov = _NO_COV if fix is None else (fix.cov if fit_scale == 1.0 else fix.cov * fit_scale)
    return fit_scale, fit_note, fix_cov


@dataclass(slots=True)
class _Filtering:
    """The filter's side of one cycle as the update phase advances it: state, smoother link,
    whether it has taken a fix, the fix source its fix-error states model, gated fixes in a
    row, its status ("ON", "OFF", "N/A"), the update at this epoch and the fix's gate mark."""

    state: FilterState | None
    link: tuple[FilterState, FilterState, np.ndarray] | None
    has_fix: bool
    source: tuple[object, ...] | None
    gated: int
    status: str
    result: UpdateResult | None = None
    gate: str = ""
    watch: ndiv.DivergenceWatch | None = None


def _update_filter(ctx: RunContext, nav: NavState, pred: _Prediction, sens: SensorValues,
                   fix: FixResult | None, fix_cov: np.ndarray, gnss: tuple[object, ...] | None,
                   messages: list[str], lop_weight: tuple[float, float] = (0.0, 1.0)
                   ) -> _Filtering:
    """The filter updates at this epoch: the first LSE initialises the position; then the fix
    (or the raw LOPs on the too-few-LOPs path, THEORY D20) with the pressure depth, behind
    the gross-error gate; with the filter off, dead reckoning restarts from each LSE.
    ``gnss``: the receiver part of the fix source (:func:`gnss_source`); ``lop_weight``: (the
    epoch interval in s, the factor on the fix VCV) for raw LOPs (:func:`lop_vcv_factor`)."""
    cfg, params = ctx.config, ctx.filter_params
    # _Filtering(...) with every field positionally (result None, gate "")
    f = ctx.new.filtering(pred.state, pred.link, nav.filter_has_fix, nav.fix_source,
                          nav.gated_fixes, "OFF" if not cfg.filter.on else "N/A", None, "",
                          nav.divergence)
    lse_ok = fix is not None and fix.lse_ok
    # The pressure depth's rows (sensor_measurement(state, depth_m=…)'s values, variances and
    # layout, depth_sensor_rows): updated from them (update_rows, update_gated).
    depth_rows: tuple[list[float], list[float], SensorLayout] | None = None
    if pred.state is not None and sens.depth_m is not None:
        depth_rows = depth_sensor_rows(sens.depth_m, params)  # sensor_rows(depth, None, …)
    if f.state is not None and fix is not None and lse_ok and not f.has_fix:
        # The first LSE initialises the filter position (THEORY D22): a DR start kilometres
        # away with the thesis P0 = I would otherwise pull against every fix.
        f.state = replace_position(f.state, fix.x_m, fix.y_m, fix_cov)
        f.has_fix = True
        f.source = _with_gnss(ctx.derived().fix_source, gnss, f.source)
        gp = ctx.filter_params_gnss
        if gnss and gp is not None and gp.coloured and cfg.filter.on:
            # The position now carries this fix's slowly varying error (τ 30 min): its
            # fix-error states start correlated with it (docs/GNSS_WEIGHTS.md). The 1993
            # fixed-weight runs keep their start (τ of minutes), exactly as before.
            f.state = fix_states_from_fix(f.state, ("fix_e", "fix_n"),
                                          gp.fix_sigma_frac * fix_cov, gp, gp.fix_tau_s)
    elif f.state is not None and cfg.filter.on:
        meas = _fix_measurement(ctx, f, fix, fix_cov, gnss, messages, lop_weight)
        if meas is not None:
            depth_rows = _gated_update(ctx, nav, f, meas, depth_rows, fix, fix_cov, messages)
        elif pred.dr_sensors:
            f.status = "ON"  # DR-only path: model plus bounded sensors (THEORY §12.5)
    elif f.state is not None and fix is not None and lse_ok:
        # Filter off: dead reckoning restarts from each LSE (THEORY §12.6 Kalman ▸ Filtering).
        f.state = replace_position(f.state, fix.x_m, fix.y_m, fix_cov)
    if f.state is not None and depth_rows is not None:
        depth_result = ctx.parts.update_rows(f.state, *depth_rows, params)
        f.state = depth_result.state
        f.result = f.result or depth_result
    return f


def _fix_measurement(ctx: RunContext, f: _Filtering, fix: FixResult | None, fix_cov: np.ndarray,
                     gnss: tuple[object, ...] | None, messages: list[str],
                     lop_weight: tuple[float, float] = (0.0, 1.0)) -> Measurement | None:
    """The filter's measurement of this fix: the LSE (restarting the fix-error states when the
    fix source changed), else the raw LOPs of a hybrid fix, else None. A fix with
    receiver-weighted GPS takes the fix-error model of a modern receiver
    (``RunContext.filter_params_gnss``)."""
    if fix is None or not fix.ok:
        return None
    if not fix.lse_ok:
        p = ctx.filter_params
        dt, scale = lop_weight
        factor = lop_vcv_factor(dt, p.fix_tau_s, p.fix_sigma_frac) if p.coloured else 1.0
        return _raw_lop_measurement(fix, scale * factor)
    params = ctx.filter_params
    if gnss and ctx.filter_params_gnss is not None:
        params = ctx.filter_params_gnss
    meas = ctx.parts.lse_measurement(fix.x_m, fix.y_m, fix_cov, params)
    base = ctx.derived().fix_source
    # _with_gnss(base, gnss, f.source); with this record's receiver part (not None) it is
    # base + gnss, done here
    source = base + gnss if gnss is not None else _with_gnss(base, gnss, f.source)
    if gnss and source == f.source:
        _rescale_gnss_fix_states(f, meas)
    if source != f.source:
        # A new fix source is a new, independent error process: one Gauss–Markov pair
        # models the LSE error of one source (docs/DECISIONS.md "Correlated fixes"); a change of the
        # receiver's fix quality (SPS → DGPS → RTK) is one too (docs/GNSS_WEIGHTS.md).
        old, f.source = f.source, source
        if meas.bias_cov is not None and f.link is not None and f.state is not None:
            restarted, phi_r = restart_fix_states(f.state, meas.bias_keys[:2], meas.bias_cov,
                                                  f.link[2], meas.bias_tau_s[:2])
            if restarted is not f.state and phi_r is not None:
                f.state = restarted
                f.link = (f.link[0], restarted, phi_r)
                messages.append(_source_message(old, source))
    return meas


def _rescale_gnss_fix_states(f: _Filtering, meas: Measurement) -> None:
    """A receiver-weighted fix of the same source whose VCV grew (a larger HDOP): the growth of
    the fix-error states' stationary VCV is added to their variance at once
    (:func:`inflate_fix_states`), instead of creeping in over τ (30 min), which would leave the
    ellipse too small while the HDOP rises. A shrinking VCV is left to the prediction's decay
    (cautious). Nothing about how the error itself changes is assumed (docs/GNSS_WEIGHTS.md)."""
    st = f.state
    keys = [k for k in meas.bias_keys[:2] if k is not None]
    if st is None or meas.bias_cov is None or len(keys) < 2 or \
            not all(k in st.fix_states for k in keys):
        return
    idx = [st.fix_states.index(k) for k in keys]
    grow = np.asarray(meas.bias_cov, dtype=float) - st.fix_cov[np.ix_(idx, idx)]
    vals, vecs = np.linalg.eigh(0.5 * (grow + grow.T))
    if vals.max() <= 0.0:
        return
    add = (vecs * np.clip(vals, 0.0, None)) @ vecs.T
    f.state = inflate_fix_states(st, keys, add)
    if f.link is not None:
        f.link = (f.link[0], f.state, f.link[2])


def _source_message(old: tuple[object, ...] | None, new: tuple[object, ...]) -> str:
    """The message of a fix-source change: the GNSS quality change in words when that is what
    changed, else the general one."""
    q_old, q_new = _gnss_part(old), _gnss_part(new)
    base_old = None if old is None else old[:len(old) - len(q_old)]
    if q_old != q_new and base_old == new[:len(new) - len(q_new)]:
        def words(q: tuple[object, ...]) -> str:
            return str(q[0][1]) if q else "fixed weights"  # type: ignore[index]
        return (f"GNSS fix {words(q_old)} → {words(q_new)}: fix-error states restarted")
    return "Fix source changed: fix-error states restarted"


def _gnss_part(source: tuple[object, ...] | None) -> tuple[object, ...]:
    """The receiver part (``("GNSS", quality)`` as its last item) of a fix source, or ()."""
    if source and isinstance(source[-1], tuple) and source[-1][:1] == ("GNSS",):
        return source[-1:]
    return ()


def gnss_source(reading: SystemReading) -> tuple[object, ...] | None:
    """The receiver part of this cycle's fix source: ``(("GNSS", "DGPS"),)`` for a
    receiver-weighted or SA-free ("sps") GPS fix (its GGA quality in words, "?" without
    one), () for a fixed-weighted (SA-era) one, None
    when the record has no GPS fix (the previous receiver part stands)."""
    value = reading.value
    weight = getattr(value, "weight", None)
    if value is None or weight is None:
        return None
    if not weight.sa_free:
        return ()
    return (("GNSS", quality_name(weight.quality)),)


def cycle_fix_source(cfg: RunConfig, gnss: tuple[object, ...] | None,
                     previous: tuple[object, ...] | None) -> tuple[object, ...]:
    """This cycle's fix source: :func:`fix_source` of the configuration plus the receiver part
    (:func:`gnss_source`; a record without GPS keeps the previous one, so a gap in the fixes
    does not restart anything)."""
    return _with_gnss(fix_source(cfg), gnss, previous)


def _with_gnss(base: tuple[object, ...], gnss: tuple[object, ...] | None,
               previous: tuple[object, ...] | None) -> tuple[object, ...]:
    """:func:`cycle_fix_source` with the configuration's part ``base`` already known."""
    if gnss is None:
        gnss = ()
        if previous is not None:
            part = _gnss_part(previous)
            if previous[:len(previous) - len(part)] == base:
                gnss = part
    return base + gnss


def _gated_update(ctx: RunContext, nav: NavState, f: _Filtering, meas: Measurement,
                  depth_rows: tuple[list[float], list[float], SensorLayout] | None,
                  fix: FixResult | None, fix_cov: np.ndarray,
                  messages: list[str]) -> tuple[list[float], list[float], SensorLayout] | None:
    """One update with everything measured at this epoch, taken unless the fix is a gross
    error (:data:`GROSS_GATE_SIGMA`); after :data:`GROSS_GATE_RESET` gated LSEs the filter
    position restarts from the LSE. Returns the depth rows still to be applied (None: done)."""
    assert f.state is not None
    # One update for all measured at this epoch: the depth rows stacked before the fix's, and
    # the gate's innovation_distance of the fix's rows, the last (update_gated).
    parts = ctx.parts
    if depth_rows is None:
        trial = parts.update(f.state, meas, ctx.filter_params)
        d_sigma = parts.innovation_distance(trial, slice(0, None))
    else:
        trial, d_sigma = parts.update_gated(f.state, *depth_rows, meas, ctx.filter_params)
    f.status = "ON"
    if d_sigma <= GROSS_GATE_SIGMA:
        rec = ctx.derived().recover
        if rec is not None and fix is not None and fix.lse_ok and not fix.uses_prior:
            taken = _watch_divergence(ctx, nav, f, meas, depth_rows, fix, fix_cov, trial, rec,
                                      messages)
            if taken is None:  # re-initialised from this fix: only the depth rows are left
                return depth_rows
            trial = taken
        f.result, f.state, f.has_fix, f.gated = trial, trial.state, True, 0
        if f.watch is not None and f.watch.streak:
            f.watch = ndiv.settle(f.watch, (float(trial.state.x[IX]), float(trial.state.x[IY])),
                                  f.gate == "recovered")
        if trial.lom.verdict == "reject" and not f.gate:
            f.gate = "innovation"
            messages.append(innovation_message(trial))
        return None
    f.gate = "gross"
    f.gated = nav.gated_fixes + 1
    messages.append(f"Fix {d_sigma:.3g} σ from the filter: a gross error, not used "
                    f"({f.gated} in a row)")
    if fix is not None and fix.lse_ok and f.gated >= GROSS_GATE_RESET:
        # The filter, not the fixes, is what went wrong (THEORY D22 start again).
        f.state = replace_position(f.state, fix.x_m, fix.y_m, fix.cov)
        messages.append(f"Filter position re-initialised from the LSE after "
                        f"{f.gated} gated fixes")
        f.gated = 0
    return depth_rows


def _watch_divergence(ctx: RunContext, nav: NavState, f: _Filtering, meas: Measurement,
                      depth_rows: tuple[list[float], list[float], SensorLayout] | None,
                      fix: FixResult, fix_cov: np.ndarray, trial: UpdateResult,
                      rec: ndiv.RecoverSettings, messages: list[str]) -> UpdateResult | None:
    """The divergence watch of an LSE fix update (THEORY §8.18): count consistent
    innovation-test rejections of good fixes; after ``rec.epochs`` of them in a row act:
    "reset" re-initialises the position from the LSE (returns None: the fix is used up) and
    widens the current, "fade" returns the update made with the prior P × T/T_upper. Else
    returns ``trial`` unchanged. The first action of a run of rejections is said once."""
    prior = f.state
    assert prior is not None
    upper = ndiv.fix_rows_upper(ctx.filter_params.alpha)
    verdict, t_fix = ndiv.fix_rows_test(trial.innovation, trial.S, trial.labels, upper)
    w = ndiv.observe(f.watch or ndiv.DivergenceWatch(), t_s=prior.t, verdict=verdict,
                     fix_good=verdict != "reject" or fix_fit(fix)[1] is None,
                     fix_xy=(fix.x_m, fix.y_m), fix_cov=fix.cov,
                     prior_xy=(float(prior.x[IX]), float(prior.x[IY])),
                     cm_deg=_cm_for(nav, nav.mpp_lon_deg))
    f.watch = w
    if not ndiv.due(w, rec):
        return trial
    offset = math.hypot(fix.x_m - float(prior.x[IX]), fix.y_m - float(prior.x[IY]))
    since = None if w.last_ok_s is None else prior.t - w.last_ok_s
    if rec.mode == "reset":
        st = replace_position(prior, fix.x_m, fix.y_m, fix_cov)
        keys = [k for k in meas.bias_keys[:2] if k is not None]
        if len(keys) == 2 and all(k in st.fix_states for k in keys) \
                and meas.bias_cov is not None:
            # the fix-error states start again as at a position taken from a fix
            st = fix_states_from_fix(st, keys, np.asarray(meas.bias_cov)[:2, :2],
                                     ctx.filter_params, meas.bias_tau_s[0])
        add = ndiv.current_inflation(offset, since)
        if add > 0.0:
            P = np.array(st.P)
            P[IVCX, IVCX] += add
            P[IVCY, IVCY] += add
            st = replace(st, P=P)
        f.state, f.has_fix, f.gate = st, True, "recovered"
        messages.append(ndiv.message("reset", w.streak, offset, since))
        f.watch = ndiv.DivergenceWatch(last_ok_s=prior.t, last_update_s=prior.t)
        return None
    lam = ndiv.fade_factor(t_fix, upper)
    faded = replace(prior, P=np.asarray(prior.P) * lam)
    if depth_rows is None:
        out = ctx.parts.update(faded, meas, ctx.filter_params)
    else:
        out, _ = ctx.parts.update_gated(faded, *depth_rows, meas, ctx.filter_params)
    if not w.acted:
        f.gate = "recovered"
        messages.append(ndiv.message("fade", w.streak, offset, since))
    return out


def _mpp(ctx: RunContext, nav: NavState, grid: TMGrid, kf_est: PositionEstimate | None,
         state: FilterState | None, fix: FixResult | None, fix_cov: np.ndarray,
         messages: list[str]) -> PositionEstimate:
    """The most probable position: filtered if the filter produced it, else the LSE, else the
    prediction, else the last MPP without precision (A6)."""
    if kf_est is not None:
        return kf_est
    if fix is not None and fix.lse_ok:
        depth = ctx.config.depth_m if state is None else state.depth_m
        return position_estimate("LSE", grid, fix.x_m, fix.y_m, depth, fix_cov)
    if state is not None:
        return ctx.parts.estimate("DR", grid, state)
    x0, y0 = grid.forward(nav.mpp_lat_deg, nav.mpp_lon_deg)
    messages.append("No MPP: gyro and log must stay switched on !")
    return position_estimate("DR", grid, x0, y0, ctx.config.depth_m, np.full((2, 2), np.nan))


def innovation_message(u: UpdateResult) -> str:
    """The message line for a fix update whose innovation (LOM) test rejects it (thesis
    eq. 6.38–6.40): the statistic against its upper bound and the most suspect row."""
    t = u.ls.t
    worst = int(np.argmax(np.abs(t))) if t.size else None
    row = "" if worst is None else f", worst {u.labels[worst]} w = {float(t[worst]):+.1f}"
    return (f"Fix fails the innovation test: T = {u.lom.t:.2f} > {u.lom.upper:.2f}{row} "
            "(taken; check it)")


def gps_voted_out(fix: FixResult) -> str | None:
    """The message for a fix whose w-test rejected (or, under LOPReject 'A', proposes to
    reject) a GPS LOP while Decca lanes are in it: GPS has no integer ambiguity, Decca has, so
    the likelier culprit is a wrong Decca lane and the operator must hear of it (issue 11)."""
    if not fix.rejected_slots and fix.candidate_slot is None:
        return None  # nothing voted out (the usual cycle)
    gps_slots = set(slots_of(GPS.name))
    out = gps_slots & set(fix.rejected_slots)
    if fix.candidate_slot in gps_slots:
        out.add(fix.candidate_slot)  # type: ignore[arg-type]
    if not out or all(t is None for t in fix.decca_observed):
        return None
    return ("GPS voted out by the w-test against Decca: GPS has no lane ambiguity, "
            "check the Decca lanes")


def fix_source(cfg: RunConfig) -> tuple[object, ...]:
    """What produces the LSE, as far as its error process is concerned: the GPS receiver type
    (C/A or P code) when GPS is on, the Decca chain and selected patterns when Decca is on.

    A change (Setup ▸ Systems) starts the filter's Gauss–Markov fix-error states afresh; a
    single record without GPS or one LOP rejected by the w-test does not.
    Each system says what identifies its error process (``NavSystem.fix_source``).
    """
    return tuple(item for system in registry.SYSTEMS for item in system.fix_source(cfg))


def _raw_lop_measurement(fix: FixResult, factor: float = 1.0) -> Measurement | None:
    """The too-few-LOPs path: feed the real LOPs (not the hybrid LSE) to the filter (A10),
    their VCV ``Cl`` × ``factor`` (:func:`lop_vcv_factor` × the learnt fix factor)."""
    raw = fix.raw_lops
    if raw is None or not raw.slots:
        return None
    return lop_measurement(raw.A, raw.omc_m, raw.x_ref,
                           raw.Cl if factor == 1.0 else raw.Cl * factor,
                           labels=tuple(f"lop{s}" for s in raw.slots))


def lop_vcv_factor(dt_s: float, tau_s: float, coloured_frac: float) -> float:
    """The factor on a raw LOP's VCV that makes one epoch count as the share of an independent
    sample it is (THEORY §9.3): the LOP error is the fix-error model's, a fraction
    ``coloured_frac`` Gauss–Markov with τ ``tau_s`` (s) and the rest white, sampled every
    ``dt_s`` s. Raw LOPs have no fix-error states, so the filter takes them as white; n
    samples of a first-order Gauss–Markov sequence (ρ = e^{−Δt/τ}) hold the information on
    their mean of n(1 − ρ)/(1 + ρ) independent ones (the AR(1) effective sample size; Bayley &
    Hammersley 1946, *J. R. Stat. Soc. Suppl.* 8, 184–197; von Storch & Zwiers 1999,
    *Statistical Analysis in Climate Research*, §17.1), so the coloured share's variance is
    weighted by (1 + ρ)/(1 − ρ): (1 − f) + f(1 + ρ)/(1 − ρ). 1 for Δt ≫ τ; Δt ≤ 0 (the first
    epoch) counts as 1 s."""
    rho = math.exp(-max(dt_s, 1.0) / tau_s)
    return (1.0 - coloured_frac) + coloured_frac * (1.0 + rho) / (1.0 - rho)


def reproject_state(
    fs: FilterState,
    old: TMGrid,
    new: TMGrid,
    shift: DatumShift | None = None,
) -> FilterState:
    """Move a filter state from grid ``old`` to grid ``new`` (another CM and/or datum).

    Position goes through geodetic coordinates (and the datum ``shift`` when the datum changes);
    the grid heading, the current and the horizontal covariance rotate by the change of grid
    convergence Δγ (THEORY D3: ψ_grid = ψ_true − γ).  Grid scale differences (< 2·10⁻⁵ within
    ±0.5° of the CM) are ignored.
    """
    lat, lon = old.inverse(*fs.east_north_m)
    g_old = old.convergence_deg(lat, lon)
    if shift is not None:
        lat, lon, _h = shift.transform(lat, lon, 0.0)
    x_new, y_new = new.forward(lat, lon)
    return move_to_grid(fs, x_new, y_new, math.radians(new.convergence_deg(lat, lon) - g_old))


def rebase_state(nav: NavState, old: RunContext, new: RunContext) -> NavState:
    """Carry a navigation state over to a new context whose working datum differs (Setup ▸
    Params ▸ Datum): the MPP and the filter are transformed; the cumulative variance is kept."""
    if old.working == new.working:
        return nav
    shift = datum_shift(old.working, new.working)
    lat, lon, _h = shift.transform(nav.mpp_lat_deg, nav.mpp_lon_deg, 0.0)
    fs = nav.filter
    if fs is not None and nav.cm_deg is not None:
        fs = reproject_state(fs, old.grid(nav.cm_deg), new.grid(nav.cm_deg), shift)
    return replace(nav, mpp_lat_deg=lat, mpp_lon_deg=lon, filter=fs)


__all__ = [
    "DECCA_TRACK_GAP_S",
    "LANE_SIGMA_MAX",
    "CycleResult",
    "LaneSource",
    "GpsInput",
    "NavState",
    "PositionEstimate",
    "RunContext",
    "SLOT_BRR0",
    "SensorValues",
    "build_context",
    "filter_estimate",
    "initial_state",
    "lane_sigma",
    "step",
    "stack_measurements",
]

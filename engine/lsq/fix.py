"""One least-squares position fix from GPS, Decca and manual bearings/distances (thesis ch. 5, A5).

Everything is on the TM grid of the working datum (metres, x = easting, y = northing); every
observation row is metric (lsq.md §3.3), so the design matrix is dimensionless and the VCV in m².
The observation vector has fixed slots (lsq.md §3.5, Pg 821/830)::

    0 GPS "Lat" (northing)   1 GPS "Lon" (easting)      — or the filter's two position LOPs
    2 Decca Red   3 Decca Green   4 Decca Purple
    5..9  up to five bearing / distance observations (BRR), in input order
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from engine.geodesy.angles import wrap_pi
from engine.geodesy.ellipsoidal import GeodesicSolver, line_scale_factor, mean_radius_sq
from engine.geodesy.tmgrid import TMGrid
from engine.lsq.adjustment import Adjustment, Linearisation
from engine.lsq.confidence import Ellipse, eigenvalues_2x2, error_ellipse
from engine.lsq.snooping import TestedAdjustment, adjust_with_testing
from engine.lsq.statistics import classify_w
from engine.systems.decca import (
    PATTERNS,
    ChainOnGrid,
    DeccaGeometry,
    decca_geometry,
    decca_vcv_m2,
    resolve_total_lanes,
)

N_SLOTS = 10
MAX_BRR = 5
SLOT_GPS_LAT, SLOT_GPS_LON = 0, 1
SLOT_DECCA = (2, 3, 4)
SLOT_BRR0 = 5

GPS_VAR_CA_M2 = 2500.0
"""A priori variance of a C/A-code GPS coordinate (σ = 50 m; thesis L5564, Pg 611/821)."""
GPS_VAR_P_M2 = 8.9**2
"""A priori variance of a P-code GPS coordinate: 2 d_rms 17.8 m → σ 8.9 m (program.md A13)."""


@dataclass(frozen=True, slots=True)
class GpsFix:
    """A GPS position already on the working datum and grid (metres), with its a priori variance
    per coordinate (m², already × ``GPS.SE_SF``) and the operator's corrections north/east (m)."""

    lat_deg: float
    lon_deg: float
    x_m: float
    y_m: float
    var_m2: float
    corr_north_m: float = 0.0
    corr_east_m: float = 0.0


@dataclass(frozen=True, slots=True)
class DeccaReading:
    """One cycle's Decca input: lane fractions (None = no reading), the operator's zone/lane per
    pattern (None = not entered), selected patterns, corrections "C-O" (lanes) and ``Decca.CF``.

    ``totals`` (uncorrected total lane counts per pattern) overrides the zone/lane resolution when
    the caller tracks lanes from cycle to cycle like a decometer
    (``engine.systems.decca.track_lane``).
    """

    placed: ChainOnGrid
    fractions: tuple[float | None, float | None, float | None]
    zone_lane: tuple[tuple[int, int] | None, tuple[int, int] | None, tuple[int, int] | None]
    selected: tuple[bool, bool, bool]
    corrections_lanes: tuple[float, float, float] = (0.0, 0.0, 0.0)
    cf: float = 64.0
    totals: tuple[float | None, float | None, float | None] | None = None


@dataclass(frozen=True, slots=True)
class ManualObservation:
    """An Obs-menu observation to a charted station (geodetic on the working datum).

    ``kind`` is "bearing" (``value`` degrees true, ship → station) or "distance" (``value``
    metres); ``sigma`` is degrees for a bearing and metres for a distance; ``sensor`` names the
    instrument (compass repeater, periscope, radar).
    """

    kind: str
    station: str
    lat_deg: float
    lon_deg: float
    value: float
    sigma: float
    sensor: str = ""


DECCA_PATTERN_NAMES = ("Red", "Grn", "Prp")
"""Short Decca pattern names of the LOP tables (Pg 631) and the operator messages."""


def lop_name(slot: int, *, system: str = "GPS",
             manual: Sequence[ManualObservation] = ()) -> str:
    """The name of LOP ``slot`` as the tables and dialogs give it, for operator messages.

    ``GPS Lat``/``GPS Lon`` (``system`` "KF" when the filter's prediction stands in for GPS on
    the too-few-LOPs path), ``Decca Red``/``Grn``/``Prp``, and for an Obs-menu observation its
    sensor, ``Brg`` or ``Dist`` and the station as typed (``periscope Brg Heiloo``). Slot
    numbers are those of :data:`SLOT_GPS_LAT` … :data:`SLOT_BRR0`.
    """
    if slot in (SLOT_GPS_LAT, SLOT_GPS_LON):
        return f"{system} {'Lat' if slot == SLOT_GPS_LAT else 'Lon'}"
    if slot in SLOT_DECCA:
        return f"Decca {DECCA_PATTERN_NAMES[SLOT_DECCA.index(slot)]}"
    i = slot - SLOT_BRR0
    if 0 <= i < len(manual):
        o = manual[i]
        kind = "Brg" if o.kind == "bearing" else "Dist"
        return f"{o.sensor or o.kind} {kind} {o.station}"
    return f"slot {slot}"


@dataclass(frozen=True, slots=True)
class PositionPrior:
    """The filter's predicted position used as two pseudo-LOPs when too few LOPs exist (lsq.md
    §4.8, kalman.md §10.3): grid (x, y) in metres and its 2×2 VCV (m², order x, y)."""

    x_m: float
    y_m: float
    cov: np.ndarray


@dataclass(frozen=True, slots=True)
class LsqSettings:
    """LS parameters of A8.2: break-off ``epsilon_m``, ``s02``, ``LOPReject`` policy, α in %,
    ``ScaleVCV``, the estimator ("lsq", "huber", "danish") and the confidence level (%)."""

    epsilon_m: float = 1.0
    s02: float = 1.0
    lop_reject: str = "A"
    reliab_interval: float = 5.0
    scale_vcv: bool = False
    estimator: str = "lsq"
    conf_region: float = 95.0
    max_iter: int = 10


@dataclass(frozen=True, slots=True)
class LopRow:
    """One row of the LOP tables (Pg 631/633): what was read, corrected, computed and tested.

    ``read``/``calc`` are degrees for GPS rows, lanes for Decca, degrees (bearing) or metres
    (distance) for BRR rows; ``v_m`` the metric residual; ``az_deg`` the LOP azimuth; ``sigma_d``
    (m), ``w``, ``tau``, ``vf`` the test quantities (NaN when not computed: the screens' 999.99).
    """

    slot: int
    system: str
    pattern: str
    read: float
    correction: float
    calc: float
    v_m: float
    az_deg: float
    used: bool
    sigma_d: float = math.nan
    w: float = math.nan
    tau: float = math.nan
    vf: float = math.nan
    verdict: str = ""


@dataclass(frozen=True)
class FixResult:
    """The outcome of one LS fix: position, precision, per-LOP table and the raw adjustment.

    ``messages``: operator texts of this fix (Decca half-zone warnings, the tests' verdicts,
    a robust estimator's down-weighting or fall-back); ``reason`` says why when ``ok`` is False.
    """

    ok: bool
    reason: str | None
    x_m: float
    y_m: float
    lat_deg: float
    lon_deg: float
    cov: np.ndarray
    ellipse: Ellipse | None
    category: str
    n_used: int
    rms_m: float
    s2: float | None
    lops: tuple[LopRow, ...]
    tested: TestedAdjustment | None
    decca_observed: tuple[float | None, float | None, float | None] = (None, None, None)
    decca_geometry: DeccaGeometry | None = None
    rejected_slots: tuple[int, ...] = ()
    candidate_slot: int | None = None
    uses_prior: bool = False
    messages: tuple[str, ...] = field(default=())
    raw_lops: RawLops | None = None


@dataclass(frozen=True)
class RawLops:
    """The real LOPs of a too-few-LOPs fix, linearised at the filter's prediction ``x_ref``
    (grid m): metric rows ``A`` (k×2), O − C ``omc_m`` (k,) and VCV ``Cl`` (k×k, m²), for the
    filter update that must not see the hybrid LSE (kalman.md §10.3, A10)."""

    A: np.ndarray
    omc_m: np.ndarray
    Cl: np.ndarray
    x_ref: np.ndarray
    slots: tuple[int, ...]


@dataclass(frozen=True, slots=True)
class _Station:
    obs: ManualObservation
    x_m: float
    y_m: float


class _Model:
    """The linearisation callback for the adjustment core (A5.9–A5.27), built once per fix."""

    def __init__(
        self,
        grid: TMGrid,
        geodesic: GeodesicSolver,
        gps: GpsFix | None,
        prior: PositionPrior | None,
        decca: DeccaReading | None,
        decca_obs: list[float],
        stations: Sequence[_Station],
    ) -> None:
        self.grid = grid
        self.geodesic = geodesic
        self.gps = gps
        self.prior = prior
        self.decca = decca
        self.decca_obs = decca_obs
        self.stations = stations
        self.last_geometry: DeccaGeometry | None = None

    def __call__(self, x: np.ndarray) -> Linearisation:
        """Design matrix, O − C (m) and a priori VCV (m²) at grid point ``x`` = (E, N).

        Rows and misclosures are assembled as Python floats and converted once; C_l starts
        as the identity (unused slots: variance 1, Pg 821) with the system blocks written in.
        """
        A = [0.0] * (2 * N_SLOTS)  # row-major (N_SLOTS, 2): ∂/∂x, ∂/∂y of each slot
        b = [0.0] * N_SLOTS
        Cl = np.eye(N_SLOTS)
        x0, y0 = x.tolist() if isinstance(x, np.ndarray) else (float(x[0]), float(x[1]))
        if self.gps is not None:
            g = self.gps
            _set_row(A, SLOT_GPS_LAT, 0.0, 1.0)
            _set_row(A, SLOT_GPS_LON, 1.0, 0.0)
            b[SLOT_GPS_LAT] = g.y_m + g.corr_north_m - y0
            b[SLOT_GPS_LON] = g.x_m + g.corr_east_m - x0
            Cl[SLOT_GPS_LAT, SLOT_GPS_LAT] = g.var_m2
            Cl[SLOT_GPS_LON, SLOT_GPS_LON] = g.var_m2
        elif self.prior is not None:
            p = self.prior
            _set_row(A, SLOT_GPS_LAT, 0.0, 1.0)
            _set_row(A, SLOT_GPS_LON, 1.0, 0.0)
            b[SLOT_GPS_LAT] = p.y_m - y0
            b[SLOT_GPS_LON] = p.x_m - x0
            Cl[0:2, 0:2] = p.cov[::-1, ::-1]  # slot order (y, x) against the prior's (x, y)
        if self.decca is not None:
            geom = decca_geometry(self.decca.placed, x0, y0, self.geodesic)
            self.last_geometry = geom
            k = geom.metres_per_lane.tolist()
            rows = geom.row.tolist()
            n_calc = geom.n_calc.tolist()
            for j, obs in enumerate(self.decca_obs):
                if obs == obs:  # a reading (NaN: none); A5.9–A5.12 in metres across the LOP
                    kj = k[j]
                    _set_row(A, SLOT_DECCA[j], rows[j][0] * kj, rows[j][1] * kj)
                    b[SLOT_DECCA[j]] = (obs - n_calc[j]) * kj
            s = slice(SLOT_DECCA[0], SLOT_DECCA[-1] + 1)
            Cl[s, s] = decca_vcv_m2(geom, self.decca.cf)
        if self.stations:
            lat0, lon0 = self.grid.inverse(x0, y0)
            for i, st in enumerate(self.stations):
                slot = SLOT_BRR0 + i
                dxs, dys = x0 - st.x_m, y0 - st.y_m
                d0 = math.hypot(dxs, dys)
                o = st.obs
                if o.kind == "bearing":
                    az, _ = self.geodesic.azimuth_distance(lat0, lon0, o.lat_deg, o.lon_deg)
                    _set_row(A, slot, dys / d0, -dxs / d0)
                    b[slot] = d0 * wrap_pi(math.radians(o.value - az))
                    Cl[slot, slot] = (math.radians(o.sigma) * d0) ** 2
                else:
                    rm2 = mean_radius_sq(self.grid.ellipsoid, lat0, o.lat_deg)
                    _set_row(A, slot, dxs / d0, dys / d0)
                    b[slot] = o.value - d0 / line_scale_factor(x0, st.x_m, rm2)
                    Cl[slot, slot] = o.sigma**2
        return Linearisation(A=np.array(A).reshape(N_SLOTS, 2), b=np.array(b), Cl=Cl)


def _set_row(rows: list[float], slot: int, d_dx: float, d_dy: float) -> None:
    """Put the design-matrix row (∂/∂x, ∂/∂y) of ``slot`` into the row-major flat ``rows``."""
    rows[2 * slot] = d_dx
    rows[2 * slot + 1] = d_dy


def _lop_azimuth_deg(row: Sequence[float]) -> float:
    """Azimuth of an LOP whose metric gradient is ``row`` = (∂/∂x, ∂/∂y): gradient + 90°."""
    return (math.degrees(math.atan2(row[0], row[1])) + 90.0) % 360.0


_EVAL_ERRORS = (ValueError, ArithmeticError, np.linalg.LinAlgError)
"""What the geodesy and lane model raise for points where they cannot be evaluated (e.g. an
OverflowError of the TM inverse far off the grid)."""


def compute_fix(
    grid: TMGrid,
    geodesic: GeodesicSolver,
    x0: tuple[float, float],
    *,
    gps: GpsFix | None = None,
    decca: DeccaReading | None = None,
    manual: Sequence[ManualObservation] = (),
    prior: PositionPrior | None = None,
    settings: LsqSettings = LsqSettings(),
    excluded_slots: Sequence[int] = (),
) -> FixResult:
    """Compute the LSE from the available LOPs, starting at provisional grid point ``x0`` (m).

    The rejection policy, tests and estimator follow ``settings`` (lsq.md §8; with a robust
    estimator nothing is rejected and there is no candidate); ``excluded_slots`` are slots the
    operator discarded (LOPReject 'A'). ``prior`` (the filter's prediction) is used as two
    position LOPs only when GPS is absent (table 5.1 category I, lsq.md §4.8); that hybrid fix
    is always plain LSQ with policy 'N'.

    Never raises for bad geometry or data (a non-finite or far-off ``x0``, nearly parallel
    LOPs, a point where the models cannot be evaluated): a failed fix has ``ok=False`` and a
    reason. Besides the core's checks (engine.lsq.adjustment: scaled condition number, axis ratio),
    a fix whose standard semi-major axis reaches the nearest station of a used bearing,
    distance or Decca LOP is refused: each such LOP curves around its station (a circle, a
    ray ending there, a hyperbola with the station as focus), so the linearised model and its
    VCV do not describe an ellipse that large (not applied to the hybrid fix, whose LOPs the
    filter linearises itself). ValueError only for invalid ``settings`` (programming errors).
    """
    if len(manual) > MAX_BRR:
        manual = manual[:MAX_BRR]
    messages: list[str] = []
    if not (math.isfinite(x0[0]) and math.isfinite(x0[1])):
        return _no_fix(grid, x0, "provisional position not finite", 0)
    try:
        stations = [_Station(o, *grid.forward(o.lat_deg, o.lon_deg)) for o in manual]
    except _EVAL_ERRORS as exc:
        return _no_fix(grid, x0, f"station position cannot be projected: {exc}", 0)
    used = [False] * N_SLOTS
    if gps is not None:
        used[SLOT_GPS_LAT] = used[SLOT_GPS_LON] = True
    decca_obs = [math.nan] * 3
    decca_raw: list[float | None] = [None, None, None]
    if decca is not None:
        geom0 = None
        for i, pattern in enumerate(PATTERNS):
            frac, zl = decca.fractions[i], decca.zone_lane[i]
            if decca.totals is not None:
                if decca.totals[i] is None or frac is None:
                    continue
                total = float(decca.totals[i])  # type: ignore[arg-type]
            else:
                if frac is None or zl is None:
                    continue
                try:
                    if geom0 is None:
                        geom0 = decca_geometry(decca.placed, x0[0], x0[1], geodesic)
                    res = resolve_total_lanes(zl[0], zl[1], frac, pattern,
                                              float(geom0.n_calc[i]))
                except _EVAL_ERRORS as exc:
                    return _no_fix(grid, x0, "Decca lane count not resolved at the provisional "
                                   f"position: {exc}", 0, messages=messages)
                total = res.total
                if res.warning is not None:
                    messages.append(res.warning)
            decca_raw[i] = total
            decca_obs[i] = total + decca.corrections_lanes[i]
            used[SLOT_DECCA[i]] = decca.selected[i]
    for i in range(len(stations)):
        used[SLOT_BRR0 + i] = True
    for slot in excluded_slots:
        used[slot] = False
    uses_prior = False
    if gps is None and prior is not None and 0 < sum(used) < 2:
        used[SLOT_GPS_LAT] = used[SLOT_GPS_LON] = True
        uses_prior = True
    model = _Model(grid, geodesic, gps, prior if uses_prior else None, decca, decca_obs, stations)
    x_start = np.array(x0, dtype=float)
    n_avail = sum(used)
    alpha = settings.reliab_interval / 100.0
    if n_avail < 2:
        return _no_fix(grid, x0, f"Not enough LOPs for a fix ! ({n_avail})", n_avail,
                       messages=messages)
    tested = adjust_with_testing(
        model,
        x_start,
        used,
        policy="N" if uses_prior else settings.lop_reject,
        alpha=alpha,
        epsilon=settings.epsilon_m,
        max_iter=settings.max_iter,
        s02=settings.s02,
        scale_vcv=settings.scale_vcv,
        estimator="lsq" if uses_prior else settings.estimator,
        lop_name=lambda slot: lop_name(slot, system="KF" if uses_prior else "GPS",
                                       manual=manual),
    )
    messages.extend(tested.messages)
    adj = tested.adjustment
    if not adj.ok:
        return _no_fix(grid, x0, adj.reason or "no fix", adj.n_used, tested, messages)
    x_hat = adj.x
    try:
        xe, yn = x_hat.tolist()
        lat, lon = grid.inverse(xe, yn)
        geom = (
            decca_geometry(decca.placed, xe, yn, geodesic, (lat, lon))
            if decca is not None
            else None
        )
        ellipse = error_ellipse(adj.cov_x)
        if not uses_prior:
            problem = _beyond_linear_range(adj, stations, geom)
            if problem is not None:
                return _no_fix(grid, x0, problem, adj.n_used, tested, messages)
        raw = None
        if uses_prior:
            lin0 = model(x_start)
            idx = np.flatnonzero(adj.used)
            idx = idx[idx >= 2]
            raw = RawLops(lin0.A[idx], lin0.b[idx], lin0.Cl[np.ix_(idx, idx)], x_start,
                          tuple(int(i) for i in idx))
        lops = _lop_rows(grid, geodesic, adj, gps, prior if uses_prior else None, decca,
                         decca_obs, decca_raw, geom, stations, lat, lon, alpha)
    except _EVAL_ERRORS as exc:
        return _no_fix(grid, x0, f"model evaluation failed at the estimate: {exc}", adj.n_used,
                       tested, messages)
    return FixResult(
        ok=True,
        reason=None,
        x_m=xe,
        y_m=yn,
        lat_deg=lat,
        lon_deg=lon,
        cov=adj.cov_x,
        ellipse=ellipse,
        category=adj.category,
        n_used=adj.n_used,
        rms_m=adj.rms_m,
        s2=adj.s2,
        lops=tuple(lops),
        tested=tested,
        decca_observed=(decca_raw[0], decca_raw[1], decca_raw[2]),
        decca_geometry=geom,
        rejected_slots=tuple(s for s, _w in tested.rejected),
        candidate_slot=tested.candidate,
        uses_prior=uses_prior,
        messages=tuple(messages),
        raw_lops=raw,
    )


def _beyond_linear_range(
    adj: Adjustment, stations: Sequence[_Station], geom: DeccaGeometry | None
) -> str | None:
    """The "no fix" reason when the standard semi-major axis (a priori C_x̂) reaches the nearest
    station of a used bearing/distance/Decca LOP (see :func:`compute_fix`), else None."""
    near = math.inf
    x_hat, y_hat = adj.x[:2].tolist()
    used = adj.used.tolist()
    for i, st in enumerate(stations):
        if used[SLOT_BRR0 + i]:
            near = min(near, math.hypot(x_hat - st.x_m, y_hat - st.y_m))
    if geom is not None:
        d_slave = geom.d_slave_m.tolist()
        for i, slot in enumerate(SLOT_DECCA):
            if used[slot]:
                near = min(near, geom.d_master_m, d_slave[i])
    if near == math.inf:
        return None
    (sxx, sxy), (_, syy) = adj.cov_x_apriori[:2, :2].tolist()
    a = math.sqrt(max(eigenvalues_2x2(sxx, sxy, syy)[0], 0.0))
    if a < near:
        return None
    return (f"ill-conditioned geometry: the error ellipse's semi-major axis {a / 1000:.3g} km "
            f"reaches the nearest station ({near / 1000:.3g} km; the linearised model does not "
            "hold)")


def _no_fix(
    grid: TMGrid,
    x0: tuple[float, float],
    reason: str,
    n_used: int,
    tested: TestedAdjustment | None = None,
    messages: Sequence[str] = (),
) -> FixResult:
    """A failed fix at the provisional point; its geodetic position is NaN where the grid
    cannot be inverted there (non-finite or far-off ``x0``)."""
    try:
        lat, lon = grid.inverse(float(x0[0]), float(x0[1]))
    except _EVAL_ERRORS:
        lat = lon = math.nan
    return FixResult(
        ok=False,
        reason=reason,
        x_m=float(x0[0]),
        y_m=float(x0[1]),
        lat_deg=lat,
        lon_deg=lon,
        cov=np.full((2, 2), np.nan),
        ellipse=None,
        category="I",
        n_used=n_used,
        rms_m=math.nan,
        s2=None,
        lops=(),
        tested=tested,
        messages=tuple(messages),
    )


def _lop_rows(
    grid: TMGrid,
    geodesic: GeodesicSolver,
    adj: Adjustment,
    gps: GpsFix | None,
    prior: PositionPrior | None,
    decca: DeccaReading | None,
    decca_obs: list[float],
    decca_raw: list[float | None],
    geom: DeccaGeometry | None,
    stations: Sequence[_Station],
    lat: float,
    lon: float,
    alpha: float,
) -> list[LopRow]:
    """Assemble the Pg 631/633 table rows from the final adjustment."""
    a = adj
    rows: list[LopRow] = []
    sigma_d, w_all, tau, vf = a.stats_block[:4].tolist()
    used = a.used.tolist()
    v = a.v.tolist()

    def lop(slot: int, system: str, pattern: str, read: float, correction: float, calc: float,
            az_deg: float) -> LopRow:
        w = w_all[slot]
        return LopRow(slot, system, pattern, read, correction, calc, v[slot], az_deg,
                      used[slot], sigma_d[slot], w, tau[slot], vf[slot], classify_w(w, alpha))

    if gps is not None or prior is not None:
        system = "GPS" if gps is not None else "KF"
        if gps is not None:
            read_lat, read_lon = gps.lat_deg, gps.lon_deg
            corr_n, corr_e = gps.corr_north_m, gps.corr_east_m
        else:
            read_lat, read_lon = grid.inverse(prior.x_m, prior.y_m)
            corr_n = corr_e = 0.0
        rows.append(lop(SLOT_GPS_LAT, system, "Lat", read_lat, corr_n, lat, 90.0))
        rows.append(lop(SLOT_GPS_LON, system, "Lon", read_lon, corr_e, lon, 180.0))
    if decca is not None and geom is not None:
        names = DECCA_PATTERN_NAMES
        n_calc = geom.n_calc.tolist()
        lop_az = geom.lop_azimuth_rad.tolist()
        for i, slot in enumerate(SLOT_DECCA):
            raw = decca_raw[i]
            if raw is None:
                continue
            rows.append(lop(slot, "Decca", names[i], raw, decca.corrections_lanes[i], n_calc[i],
                            math.degrees(lop_az[i])))
    x_hat, y_hat = a.x[:2].tolist()
    for i, st in enumerate(stations):
        slot = SLOT_BRR0 + i
        o = st.obs
        if o.kind == "bearing":
            calc, _ = geodesic.azimuth_distance(lat, lon, o.lat_deg, o.lon_deg)
            gradient = (y_hat - st.y_m, -(x_hat - st.x_m))
            pattern = "Brg"
        else:
            rm2 = mean_radius_sq(grid.ellipsoid, lat, o.lat_deg)
            calc = math.hypot(x_hat - st.x_m, y_hat - st.y_m) / line_scale_factor(
                x_hat, st.x_m, rm2
            )
            gradient = (x_hat - st.x_m, y_hat - st.y_m)
            pattern = "Dist"
        rows.append(lop(slot, o.sensor or o.kind, pattern, o.value, 0.0, calc,
                        _lop_azimuth_deg(gradient)))
    return rows

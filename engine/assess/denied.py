"""GPS-denied experiment: hide the position fixes of a recorded run for a window, dead-reckon
through it with the navigation filter, and measure how the error grows (issue 13, "Proof on
real data"; docs/REALDATA.md).

**Windows.** A window starts at a record that has a GNSS fix (the *last fix*, time t₀, kept)
and hides every later record with t₀ < t ≤ t₀ + L: its GNSS position, HDOP, quality,
satellites, course and speed over ground (a receiver that has lost the satellites has lost its
COG/SOG too) and its Decca lane fractions, so no position system reaches the fix
(``dataclasses.replace`` on each :class:`~engine.io.runfile.RunRecord`). Heading and water
speed (gyro/compass and log) are not GNSS and stay, unless the caller says they were derived
from COG/SOG (``hide_heading_speed``). The records inside a window are processed by the
engine's own cycle (:func:`engine.run.cycle.step`, the same code as ``uvnav replay``) from the
navigation state the full replay had at t₀, so each window costs only its own epochs.

**Reference.** The error at time t of a window is measured against the record's hidden fix
(geodetic WGS84) or, when a truth is given (simulated runs), against the true position. A
checkpoint T (seconds after t₀) is taken at the first record with t ≥ t₀ + T that has a
reference, at most ``tolerance_s`` later; the error is then reported at that record's elapsed
time.

**Estimators at each checkpoint** (all positions geodetic WGS84, distances on the WGS84
ellipsoid with :meth:`pyproj.Geod.inv`):

* ``filter``: the cycle's MPP (the filter's dead-reckoned position with its 95 % ellipse, as
  the console shows it), converted from the working datum to WGS84 when they differ. Whether
  the reference lies inside the 95 % ellipse is eᵀC⁻¹e ≤ −2 ln 0.05 = 5.991, with e the
  reference minus the MPP on the cycle's TM grid (working datum) and C the MPP's 2×2 grid VCV
  (m²); the reference's own error (a few metres for a GNSS fix) is not in C.
* ``cogsog``: the last fix moved straight along the course over ground by SOG × (t − t₀)
  (:meth:`pyproj.Geod.fwd`). COG/SOG are the last-fix record's (NMEA RMC/VTG); a record
  without them (a 1993 ``.RUN``) gets them from the fixes ``cog_span_s`` apart ending at the
  last fix.
* ``hdgstw``: dead reckoning from the last fix with each record's heading (true) and water
  speed, no current (the classic DR plot); only when the run has heading and water speed.

Pure functions and frozen dataclasses; nothing is printed or written (``uvnav denied`` prints).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, replace
from datetime import UTC, datetime, timedelta

import numpy as np
from pyproj import Geod

from engine.assess.accuracy import Truth
from engine.geodesy.ellipsoid import WGS84
from engine.geodesy.ellipsoidal import DatumShift, datum_shift
from engine.io.datumfile import DatumFile
from engine.io.deccafile import DeccaChain
from engine.io.nmea_log import NmeaLog, open_records
from engine.io.runfile import BadRecord, RunRecord
from engine.run.config import RunConfig
from engine.run.cycle import CycleResult, NavState, RunContext, build_context, initial_state, step
from engine.run.session import check_config
from engine.systems.sensors import KNOT_MS

__all__ = [
    "CHECKPOINTS_S",
    "K95_SQ",
    "CheckpointError",
    "DeniedReport",
    "DeniedRow",
    "Reference",
    "WindowRun",
    "clean_records",
    "denied_experiment",
    "hide_positions",
    "run_records",
    "summarise",
    "truth_reference",
    "window_starts",
]

CHECKPOINTS_S: tuple[float, ...] = (60.0, 300.0, 600.0, 1800.0)
"""Default checkpoints: 1, 5, 10 and 30 minutes after the last fix [s]."""
K95_SQ = -2.0 * math.log(0.05)
"""k² of the 2-D 95 % ellipse: a point is inside when eᵀC⁻¹e ≤ k² = 5.991."""
_GEOD = Geod(ellps="WGS84")

Reference = Mapping[datetime, tuple[float, float]]
"""Reference positions by record time: (latitude, longitude) geodetic WGS84 degrees."""


def hide_positions(rec: RunRecord, *, hide_heading_speed: bool = False) -> RunRecord:
    """``rec`` with every position-fixing input removed (module docstring): GNSS position,
    HDOP, quality, satellites, COG/SOG and the Decca lane fractions; with
    ``hide_heading_speed`` also heading and water speed (when they stand in for COG/SOG)."""
    out = replace(rec, gps_lat_deg=None, gps_lon_deg=None, gps_hdop=None, gps_quality=None,
                  gps_sats=None, cog_deg=None, sog_kn=None, decca=(None, None, None))
    if hide_heading_speed:
        out = replace(out, heading_deg=None, speed_kn=None)
    return out


@dataclass(frozen=True)
class CheckpointError:
    """The errors at one checkpoint of one window (metres; ``nan`` where not available).

    ``elapsed_s``: time since the last fix [s] of the record used; ``filter_nees`` eᵀC⁻¹e of
    the MPP (2 dof); ``filter_a95_m`` semi-major axis of the MPP's 95 % ellipse [m];
    ``mpp_source`` the MPP's source ("KF" filter, "DR", "LSE", …)."""

    checkpoint_s: float
    elapsed_s: float
    filter_error_m: float
    filter_inside95: bool
    filter_nees: float
    filter_a95_m: float
    cogsog_error_m: float
    hdgstw_error_m: float
    mpp_source: str


@dataclass(frozen=True)
class WindowRun:
    """One window: its last fix (time t₀, WGS84 degrees), the COG/SOG used by the straight
    extrapolation and where they came from ("log" or "fixes"), the longest window length run
    [s] and the checkpoints reached."""

    start: datetime
    last_fix_lat_deg: float
    last_fix_lon_deg: float
    cog_deg: float
    sog_kn: float
    cogsog_source: str
    length_s: float
    points: tuple[CheckpointError, ...]


@dataclass(frozen=True)
class DeniedRow:
    """Statistics over windows of one checkpoint for one window length: ``n`` windows with a
    reference at the checkpoint; per estimator (median, 90th percentile, maximum) of the
    horizontal error [m] (linear interpolation, :func:`numpy.percentile`); ``coverage`` the
    fraction of windows whose reference lay in the MPP's 95 % ellipse; ``a95_median_m`` the
    median semi-major axis of that ellipse [m]."""

    window_s: float
    checkpoint_s: float
    n: int
    filter_m: tuple[float, float, float]
    cogsog_m: tuple[float, float, float]
    hdgstw_m: tuple[float, float, float]
    coverage: float
    a95_median_m: float


@dataclass(frozen=True)
class DeniedReport:
    """The whole experiment: the windows run, the rows per (window length, checkpoint), how
    many records were used and skipped (bad or not advancing in time), whether the run has
    heading and water speed, and the first and last record times."""

    windows: tuple[WindowRun, ...]
    rows: tuple[DeniedRow, ...]
    window_lengths_s: tuple[float, ...]
    records: int
    skipped_records: int
    has_heading_speed: bool
    first_time: datetime | None
    last_time: datetime | None
    reference: str


def run_records(config: RunConfig) -> Iterator[RunRecord | BadRecord]:
    """The records of ``config``'s run file as :class:`engine.run.session.Session` reads them:
    a ``.RUN`` or an NMEA 0183 log (an :class:`~engine.io.nmea_log.NmeaLog`, whose ``stats``
    count the sentences used and skipped once it has been read), by content."""
    return open_records(config.run_path, config.nmea.options)


def truth_reference(truth: Truth, datums: DatumFile) -> Reference:
    """A simulator truth (:func:`engine.assess.accuracy.read_truth`: geodetic degrees on its
    working datum) as reference positions in geodetic WGS84 degrees by time (h = 0 on the
    working datum; the height's effect on latitude and longitude is below 1 mm)."""
    shift = None
    if truth.datum is not None and truth.datum.upper() != WGS84.name:
        shift = datum_shift(datums.datum(truth.datum), WGS84)
    out: dict[datetime, tuple[float, float]] = {}
    for t_ms, lat, lon in zip(truth.t_ms.tolist(), truth.lat_deg.tolist(),
                              truth.lon_deg.tolist(), strict=True):
        t = datetime.fromtimestamp(t_ms / 1000.0, UTC)
        out[t] = (lat, lon) if shift is None else shift.transform(lat, lon, 0.0)[:2]
    return out


# --------------------------------------------------------------------------------------------
# Helpers


def _wgs84_shifts(ctx: RunContext) -> tuple[DatumShift | None, DatumShift | None]:
    """(working → WGS84, WGS84 → working), None where the working datum is WGS84."""
    if ctx.working.name.upper() == WGS84.name:
        return None, None
    return datum_shift(ctx.working, WGS84), datum_shift(WGS84, ctx.working)


def _fix_wgs84(ctx: RunContext, rec: RunRecord) -> tuple[float, float] | None:
    """The record's GNSS fix as geodetic WGS84 degrees (None without one)."""
    if rec.gps_lat_deg is None or rec.gps_lon_deg is None:
        return None
    if ctx.gps_to_wgs84 is None:
        return rec.gps_lat_deg, rec.gps_lon_deg
    lat, lon, _h = ctx.gps_to_wgs84.transform(rec.gps_lat_deg, rec.gps_lon_deg, 0.0)
    return lat, lon


def _distance_m(a: tuple[float, float], b: tuple[float, float]) -> float:
    """Geodesic distance on WGS84 between two (lat, lon) points [m]."""
    _az1, _az2, d = _GEOD.inv(a[1], a[0], b[1], b[0])
    return float(d)


def _forward(p: tuple[float, float], azimuth_deg: float, distance_m: float) -> tuple[float, float]:
    """The point ``distance_m`` from ``p`` (lat, lon WGS84) along the geodesic of initial
    true azimuth ``azimuth_deg``."""
    lon, lat, _az = _GEOD.fwd(p[1], p[0], azimuth_deg, distance_m)
    return float(lat), float(lon)


def window_starts(times: Sequence[datetime], length_s: float, *, every_s: float = 300.0,
                  warmup_s: float = 300.0) -> list[datetime]:
    """Nominal window start times: from the first record + ``warmup_s`` every ``every_s``
    seconds, as long as the window of ``length_s`` seconds ends by the last record."""
    if not times:
        return []
    first, last = times[0], times[-1]
    out = []
    k = 0
    while True:
        t = first + timedelta(seconds=warmup_s + k * every_s)
        if t + timedelta(seconds=length_s) > last:
            return out
        out.append(t)
        k += 1


def clean_records(records: Iterable[RunRecord | BadRecord]) -> tuple[list[RunRecord], int]:
    """The good records in time order and the number skipped, reading ``records`` once and
    keeping only the good ones (memory in the run's length, never in its damage): a bad record
    is counted, not kept, and so is a record whose time does not advance past the previous one
    (as :class:`engine.run.session.Session` skips it). For an NMEA log the damaged lines it
    counted without returning them (:attr:`~engine.io.nmea_epochs.NmeaStats.bad_unlisted`)
    are in the count too."""
    out: list[RunRecord] = []
    skipped = 0
    for r in records:
        if isinstance(r, BadRecord) or (out and r.time <= out[-1].time):
            skipped += 1
            continue
        out.append(r)
    if isinstance(records, NmeaLog):
        skipped += records.stats.bad_unlisted
    return out, skipped


def _cog_sog(ctx: RunContext, recs: Sequence[RunRecord], i0: int,
             span_s: float) -> tuple[float, float, str] | None:
    """COG [deg true], SOG [kn] and their source at the last fix ``recs[i0]``: the record's own
    (NMEA RMC/VTG), else from the fixes ``span_s`` seconds apart ending there (geodesic)."""
    r0 = recs[i0]
    if r0.cog_deg is not None and r0.sog_kn is not None:
        return r0.cog_deg, r0.sog_kn, "log"
    p1 = _fix_wgs84(ctx, r0)
    if p1 is None:
        return None
    t_from = r0.time - timedelta(seconds=span_s)
    j = i0 - 1
    while j >= 0 and recs[j].time > t_from:
        j -= 1
    while j >= 0 and _fix_wgs84(ctx, recs[j]) is None:
        j -= 1
    if j < 0:
        return None
    p0 = _fix_wgs84(ctx, recs[j])
    assert p0 is not None
    dt = (r0.time - recs[j].time).total_seconds()
    az, _baz, d = _GEOD.inv(p0[1], p0[0], p1[1], p1[0])
    return float(az) % 360.0, float(d) / dt / KNOT_MS, "fixes"


def _hdgstw_track(recs: Sequence[RunRecord], i0: int, i_end: int,
                  p0: tuple[float, float]) -> dict[int, tuple[float, float]] | None:
    """Dead reckoning with heading (true) and water speed from ``p0`` at ``recs[i0]`` through
    ``recs[i_end]``: each step of dt uses the heading and speed of the step's first record
    (the last known value when a record lacks one). None when there is neither at the start."""
    hdg = spd = None
    for j in range(i0, -1, -1):  # the latest known values at the last fix
        if hdg is None and recs[j].heading_deg is not None:
            hdg = recs[j].heading_deg
        if spd is None and recs[j].speed_kn is not None:
            spd = recs[j].speed_kn
        if (hdg is not None and spd is not None) or i0 - j > 60:
            break
    if hdg is None or spd is None:
        return None
    out = {i0: p0}
    p = p0
    for j in range(i0 + 1, i_end + 1):
        prev = recs[j - 1]
        if prev.heading_deg is not None:
            hdg = prev.heading_deg
        if prev.speed_kn is not None:
            spd = prev.speed_kn
        dt = (recs[j].time - prev.time).total_seconds()
        p = _forward(p, hdg, spd * KNOT_MS * dt)
        out[j] = p
    return out


def _nees(ctx: RunContext, res: CycleResult, ref_working: tuple[float, float]) -> float:
    """eᵀC⁻¹e of the reference (working-datum degrees) against the cycle's MPP on its grid."""
    cov = res.mpp.cov
    if not np.isfinite(cov).all():
        return math.nan
    x, y = ctx.grid(res.cm_deg).forward(*ref_working)
    e = np.array([x - res.mpp.x_m, y - res.mpp.y_m])
    try:
        return float(e @ np.linalg.solve(cov, e))
    except np.linalg.LinAlgError:
        return math.nan


# --------------------------------------------------------------------------------------------
# The experiment


def denied_experiment(
    config: RunConfig,
    data: tuple[DatumFile, dict[str, DeccaChain]],
    records: Iterable[RunRecord | BadRecord],
    window_lengths_s: Sequence[float],
    *,
    starts: Sequence[datetime] | None = None,
    every_s: float = 300.0,
    warmup_s: float = 300.0,
    checkpoints_s: Sequence[float] = CHECKPOINTS_S,
    tolerance_s: float = 5.0,
    cog_span_s: float = 60.0,
    truth: Reference | None = None,
    hide_heading_speed: bool = False,
    progress: Callable[[int, int], None] | None = None,
    skipped: int = 0,
) -> DeniedReport:
    """Run the GPS-denied experiment (module docstring) on ``records`` with ``config`` and the
    data files ``data`` = (datums, chains) of :func:`engine.run.session.load_data`.

    Windows start at ``starts`` (nominal times; each snaps to the first record at or after it
    that has a fix) or, by default, every ``every_s`` s after ``warmup_s`` s
    (:func:`window_starts`) for each length of ``window_lengths_s`` [s]. For a start, the
    longest length that fits is run once: the first L seconds of a longer window hide exactly
    what a window of length L hides, so shorter lengths read their checkpoints from it.
    ``truth`` replaces the hidden fixes as the reference (WGS84 degrees by record time).
    ``progress(done, total)`` is called after each window. Every record is processed
    (``demo.delta_t_s`` is not applied) and records that do not advance in time are skipped.
    ``records`` is read once and only its good records are kept (:func:`clean_records`; a
    caller that cleaned them already passes the count it skipped as ``skipped``).
    """
    datums, chains = data
    check_config(config, datums, chains)
    ctx = build_context(config, datums, chains)
    recs, n_skipped = clean_records(records)
    skipped += n_skipped
    lengths = tuple(sorted({float(v) for v in window_lengths_s}))
    times = [r.time for r in recs]
    has_hs = any(r.heading_deg is not None for r in recs) and any(
        r.speed_kn is not None for r in recs)
    to_wgs, from_wgs = _wgs84_shifts(ctx)

    def reference(i: int) -> tuple[float, float] | None:
        if truth is not None:
            return truth.get(recs[i].time)
        return _fix_wgs84(ctx, recs[i])

    # Window starts (record index of the last fix) → the longest length that fits.
    plan: dict[int, float] = {}
    for length in lengths:
        nominal = starts if starts is not None else window_starts(
            times, length, every_s=every_s, warmup_s=warmup_s)
        for t in nominal:
            i0 = _first_fix_at_or_after(ctx, recs, times, t)
            if i0 is None or times[i0] + timedelta(seconds=length) > times[-1]:
                continue
            plan[i0] = max(plan.get(i0, 0.0), length)

    snapshots = _replay_to(ctx, config, recs, sorted(plan))
    windows: list[WindowRun] = []
    for k, i0 in enumerate(sorted(plan)):
        w = _run_window(ctx, recs, i0, plan[i0], snapshots[i0], checkpoints_s, tolerance_s,
                        cog_span_s, reference, to_wgs, from_wgs, hide_heading_speed)
        if w is not None:
            windows.append(w)
        if progress is not None:
            progress(k + 1, len(plan))
    return DeniedReport(
        windows=tuple(windows),
        rows=summarise(windows, lengths, checkpoints_s),
        window_lengths_s=lengths,
        records=len(recs),
        skipped_records=skipped,
        has_heading_speed=has_hs,
        first_time=times[0] if times else None,
        last_time=times[-1] if times else None,
        reference="truth" if truth is not None else "hidden GNSS fixes",
    )


def _first_fix_at_or_after(ctx: RunContext, recs: Sequence[RunRecord],
                           times: Sequence[datetime], t: datetime) -> int | None:
    """Index of the first record at or after ``t`` with a GNSS fix (None if there is none)."""
    i = bisect.bisect_left(times, t)
    while i < len(recs):
        if _fix_wgs84(ctx, recs[i]) is not None:
            return i
        i += 1
    return None


def _replay_to(ctx: RunContext, config: RunConfig, recs: Sequence[RunRecord],
               indices: Sequence[int]) -> dict[int, NavState]:
    """Replay the records with every fix and keep the navigation state just after each record
    of ``indices`` (the last fix of a window has been processed)."""
    want = set(indices)
    out: dict[int, NavState] = {}
    if not want:
        return out
    last = max(want)
    nav = initial_state(config)
    for i, rec in enumerate(recs):
        nav, _res = step(ctx, nav, rec)
        if i in want:
            out[i] = nav
        if i >= last:
            break
    return out


def _run_window(
    ctx: RunContext, recs: Sequence[RunRecord], i0: int, length_s: float, nav: NavState,
    checkpoints_s: Sequence[float], tolerance_s: float, cog_span_s: float,
    reference: Callable[[int], tuple[float, float] | None],
    to_wgs: DatumShift | None, from_wgs: DatumShift | None, hide_heading_speed: bool,
) -> WindowRun | None:
    """One window from the state after the last fix ``recs[i0]`` (module docstring)."""
    t0 = recs[i0].time
    p0 = _fix_wgs84(ctx, recs[i0])
    cs = _cog_sog(ctx, recs, i0, cog_span_s)
    if p0 is None or cs is None:
        return None
    cog, sog, cs_source = cs
    end = t0 + timedelta(seconds=length_s)
    i_end = i0
    while i_end + 1 < len(recs) and recs[i_end + 1].time <= end:
        i_end += 1
    # Checkpoint record indices: first record at/after t0 + T with a reference, within tolerance.
    targets: dict[int, float] = {}
    for cp in sorted(checkpoints_s):
        if cp > length_s:
            continue
        tc = t0 + timedelta(seconds=cp)
        for j in range(i0 + 1, i_end + 1):
            if recs[j].time < tc:
                continue
            if (recs[j].time - tc).total_seconds() > tolerance_s:
                break
            if reference(j) is not None:
                targets.setdefault(j, cp)
                break
    dr = _hdgstw_track(recs, i0, i_end, p0)
    points: list[CheckpointError] = []
    last_target = max(targets, default=i0)
    for j in range(i0 + 1, last_target + 1):
        nav, res = step(ctx, nav, hide_positions(recs[j], hide_heading_speed=hide_heading_speed))
        if j not in targets:
            continue
        ref = reference(j)
        assert ref is not None
        elapsed = (recs[j].time - t0).total_seconds()
        mpp = (res.mpp.lat_deg, res.mpp.lon_deg)
        mpp_wgs = mpp if to_wgs is None else to_wgs.transform(*mpp, 0.0)[:2]
        ref_working = ref if from_wgs is None else from_wgs.transform(*ref, 0.0)[:2]
        nees = _nees(ctx, res, ref_working)
        ell = res.mpp.ellipse
        a95 = ell.scaled(0.95)[0] if ell is not None else math.nan
        extrap = _forward(p0, cog, sog * KNOT_MS * elapsed)
        points.append(CheckpointError(
            checkpoint_s=targets[j],
            elapsed_s=elapsed,
            filter_error_m=_distance_m(mpp_wgs, ref),
            filter_inside95=bool(nees <= K95_SQ),
            filter_nees=nees,
            filter_a95_m=float(a95),
            cogsog_error_m=_distance_m(extrap, ref),
            hdgstw_error_m=math.nan if dr is None else _distance_m(dr[j], ref),
            mpp_source=res.mpp.source,
        ))
    return WindowRun(t0, p0[0], p0[1], cog, sog, cs_source, length_s, tuple(points))


def _stats(v: np.ndarray) -> tuple[float, float, float]:
    """(median, 90th percentile, maximum) of the finite values (nan when there are none)."""
    v = v[np.isfinite(v)]
    if v.size == 0:
        return (math.nan, math.nan, math.nan)
    return (float(np.median(v)), float(np.percentile(v, 90)), float(v.max()))


def summarise(windows: Sequence[WindowRun], lengths_s: Sequence[float],
              checkpoints_s: Sequence[float]) -> tuple[DeniedRow, ...]:
    """The rows of the report: per window length L and checkpoint T ≤ L, statistics over the
    windows that were run for at least L seconds and reached T (:class:`DeniedRow`)."""
    rows = []
    for length in lengths_s:
        for cp in sorted(checkpoints_s):
            if cp > length:
                continue
            pts = [p for w in windows if w.length_s >= length for p in w.points
                   if p.checkpoint_s == cp]
            if not pts:
                continue
            f = np.array([p.filter_error_m for p in pts])
            c = np.array([p.cogsog_error_m for p in pts])
            h = np.array([p.hdgstw_error_m for p in pts])
            inside = [p.filter_inside95 for p in pts if math.isfinite(p.filter_nees)]
            a95 = np.array([p.filter_a95_m for p in pts])
            a95 = a95[np.isfinite(a95)]
            rows.append(DeniedRow(
                window_s=float(length), checkpoint_s=float(cp), n=len(pts),
                filter_m=_stats(f), cogsog_m=_stats(c), hdgstw_m=_stats(h),
                coverage=float(np.mean(inside)) if inside else math.nan,
                a95_median_m=float(np.median(a95)) if a95.size else math.nan,
            ))
    return tuple(rows)

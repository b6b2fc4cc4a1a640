"""Accuracy of a replayed run against the simulator's truth (``uvnav assess``).

Inputs
  * the navigation log: the ``.OUT`` log (:func:`engine.io.outlog.read_out_log`; LSE/MPP lines carry
    the full 2×2 covariance ``cxx, cxy, cyy`` in m², TEST lines the filter's LOM statistic) or the
    JSON lines of ``uvnav replay --jsonl`` (:func:`engine.run.records.cycle_json`; only the 95 %
    ellipse ``a95, b95, az_deg`` is there, from which the covariance is rebuilt as
    C = R·diag((a95/k)², (b95/k)²)·Rᵀ, k = sqrt(−2 ln 0.05) — exact up to the printed rounding of
    a95/b95 (1 mm) and az_deg (0.01°));
  * the truth CSV of :mod:`engine.sim.simulate` (``#`` header lines state the working datum, its
    ellipsoid and the truth grid's CM; columns ``time, lat, lon, surfaced`` are required).

Frame.  Epochs are matched on their time stamp (to the millisecond).  For each cycle both the
truth's and the estimate's geodetic position (degrees, working datum) are projected on the TM grid
of *that cycle's* central meridian (:class:`engine.geodesy.tmgrid.TMGrid`, k0 = 1, working-datum
ellipsoid), the grid on which the cycle's covariance is expressed, and the error is
e = (x_est − x_true, y_est − y_true) in metres (x grid east, y grid north).  The truth's own x/y
(fixed CM) are not used, so no two grids are ever mixed.  The CM is the nearest whole degree, so
|λ − CM| ≤ 0.5° and the grid point scale differs from 1 by less than 2·10⁻⁵ at these latitudes:
a grid error of 100 m is a ground error of 100 m ± 2 mm.

Phases come from the truth's ``surfaced`` column (1 = GPS and Decca received): ``surfaced`` =
surfaced epochs before the first submerged epoch, ``submerged`` = epochs with surfaced = 0,
``after resurfacing`` = surfaced epochs after the first submerged epoch; ``all`` = every matched
epoch.  Statistics per phase and estimator (LSE, filter ``kf``, MPP): horizontal error
RMS / 95th percentile (linear interpolation) / maximum, the fraction of epochs whose truth lies in
the estimate's 95 % ellipse (eᵀC⁻¹e ≤ −2 ln 0.05), the mean NEES eᵀC⁻¹e (2 dof) and, from the
``.OUT`` TEST lines, the mean NIS of the filter's fix updates (NIS = p·T_LOM, p dof).  The 95 %
bands assume independent epochs; consecutive epochs of a filter are strongly correlated, so the
bands are optimistic (too narrow).

Pool of Errors (THEORY §10, eq. 2.1): R = a + ε·Δt (m) with a = d_rms = sqrt(trace C) of the
last LSE at or before the epoch, ε in m/h and Δt the time since that LSE.  Each dive (run of
submerged truth epochs) is sampled at its start, every ``step_min`` minutes and its end.

Everything here is pure: readers return frozen dataclasses, :func:`assess` computes; nothing is
printed or written.  The SVG plot of ``uvnav assess --svg`` is presentation and is drawn by the
console package (``uvnav_tui/cli/assess_svg.py``).
"""

from __future__ import annotations

import math
import os
import re
import sys
from array import array
from collections.abc import Mapping
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from engine.errors import InputError
from engine.geodesy.ellipsoid import Ellipsoid
from engine.geodesy.tmgrid import TMGrid
from engine.io.outlog import (
    OutCycle,
    PositionChecks,
    check_log_head,
    iter_json_objects,
    iter_out_log,
)
from engine.lsq.statistics import chi2_bounds

__all__ = [
    "ESTIMATORS",
    "ESTIMATOR_LABELS",
    "K95_SQ",
    "PHASES",
    "Assessment",
    "AssessmentSeries",
    "DiveReport",
    "ErrorStats",
    "EstimateTrack",
    "NavLog",
    "NisStats",
    "PhaseSpan",
    "PoeRow",
    "Truth",
    "assess",
    "cov_from_ellipse95",
    "read_nav_log",
    "read_truth",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

ESTIMATORS: tuple[str, ...] = ("lse", "kf", "mpp")
"""Estimates assessed: the least-squares fix, the filtered (a-posteriori) position, the MPP."""

ESTIMATOR_LABELS: Mapping[str, str] = {"lse": "LSE", "kf": "filter", "mpp": "MPP"}

PHASES: tuple[str, ...] = ("surfaced", "submerged", "after resurfacing", "all")
"""Phase names, in report order (``all`` = every matched epoch)."""

P95 = 0.95
K95_SQ = -2.0 * math.log(1.0 - P95)
"""k² of the 2-D 95 % ellipse: eᵀC⁻¹e ≤ k² = 5.991 inside it."""

REQUIRED_TRUTH_COLUMNS: tuple[str, ...] = ("time", "lat", "lon", "surfaced")

_DATUM_RE = re.compile(
    r"working datum\s+(?P<datum>\S+)\s*\(ellipsoid\s+(?P<ell>.+?),\s*a\s*=\s*(?P<a>[0-9.]+)\s*m,"
    r"\s*1/f\s*=\s*(?P<invf>[0-9.eE+-]+)\)"
)
_CM_RE = re.compile(r"cm_deg\s*=\s*(?P<cm>[-+0-9.eE]+)")


# --------------------------------------------------------------------------------------------
# Inputs


def _time_ms(text: str, file: str, line: int | None, fieldname: str) -> int:
    """ISO 8601 UTC time stamp → integer milliseconds since 1970 (InputError if malformed)."""
    try:
        t = datetime.fromisoformat(text.strip())
    except (ValueError, AttributeError):
        raise InputError("Wrong time: ISO 8601 UTC expected !", file=file, line=line,
                         field=fieldname, text=str(text)) from None
    if t.tzinfo is None:
        t = t.replace(tzinfo=UTC)
    return int(round(t.timestamp() * 1000.0))


@dataclass(frozen=True, eq=False)
class Truth:
    """The true track: times (ms since 1970, UTC), geodetic position (degrees, working datum) and
    the ``surfaced`` flag per epoch, in file order; the working datum's name and ellipsoid and the
    truth grid's CM (degrees) as stated in the header (None where the header does not say)."""

    path: str
    t_ms: IntArray
    lat_deg: FloatArray
    lon_deg: FloatArray
    surfaced: BoolArray
    datum: str | None = None
    ellipsoid: Ellipsoid | None = None
    cm_deg: float | None = None


def read_truth(path: str | os.PathLike[str]) -> Truth:
    """Read a truth CSV (``#`` comment lines, then a header row, then one row per epoch).

    Raises :class:`InputError` naming file, line and column for a missing file, a missing
    required column (``time, lat, lon, surfaced``), a bad number or time, a duplicate time or a
    file without rows.
    """
    name = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError("File not found !", file=name, field="truth") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"Cannot read the truth file: {exc} !", file=name) from None
    datum: str | None = None
    ellipsoid: Ellipsoid | None = None
    cm: float | None = None
    columns: list[str] | None = None
    header_line = 0
    t_ms: list[int] = []
    lat: list[float] = []
    lon: list[float] = []
    surf: list[bool] = []
    seen: dict[int, int] = {}
    idx: dict[str, int] = {}
    for ln, raw in enumerate(text.splitlines(), start=1):
        s = raw.strip()
        if not s:
            continue
        if s.startswith("#"):
            m = _DATUM_RE.search(s)
            if m:
                datum = m["datum"]
                ellipsoid = Ellipsoid(m["ell"].strip(), float(m["a"]), float(m["invf"]))
            c = _CM_RE.search(s)
            if c:
                cm = float(c["cm"])
            continue
        cells = [c.strip() for c in s.split(",")]
        if columns is None:
            columns, header_line = cells, ln
            idx = _truth_columns(columns, name, ln, s)
            continue
        if len(cells) != len(columns):
            raise InputError(f"Wrong number of columns: {len(columns)} expected !", file=name,
                             line=ln, text=s[:80])
        t, la, lo, surfaced = _truth_row(cells, idx, seen, name, ln)
        t_ms.append(t)
        lat.append(la)
        lon.append(lo)
        surf.append(surfaced)
    if columns is None:
        raise InputError("No header row in the truth file !", file=name)
    if not t_ms:
        raise InputError("No truth rows !", file=name, line=header_line)
    return Truth(name, np.array(t_ms, dtype=np.int64), np.array(lat), np.array(lon),
                 np.array(surf, dtype=bool), datum, ellipsoid, cm)


def _truth_columns(columns: list[str], name: str, ln: int, s: str) -> dict[str, int]:
    """Index of each required column in the header row (InputError naming a missing one)."""
    for col in REQUIRED_TRUTH_COLUMNS:
        if col not in columns:
            raise InputError(f"Truth column '{col}' missing !", file=name, line=ln,
                             field=col, text=s[:80])
    return {c: columns.index(c) for c in REQUIRED_TRUTH_COLUMNS}


def _truth_row(cells: list[str], idx: Mapping[str, int], seen: dict[int, int], name: str,
               ln: int) -> tuple[int, float, float, bool]:
    """One truth row: time [ms since the epoch, UTC], lat, lon [deg], surfaced; ``seen`` maps
    each time read so far to its line (a repeated time is an error)."""
    t = _time_ms(cells[idx["time"]], name, ln, "time")
    if t in seen:
        raise InputError(f"Duplicate time (also on line {seen[t]}) !", file=name, line=ln,
                         field="time", text=cells[idx["time"]])
    seen[t] = ln
    try:
        la = float(cells[idx["lat"]])
        lo = float(cells[idx["lon"]])
    except ValueError:
        raise InputError("Not a number !", file=name, line=ln, field="lat/lon",
                         text=f"{cells[idx['lat']]},{cells[idx['lon']]}") from None
    if not (math.isfinite(la) and math.isfinite(lo)) or abs(la) > 90.0:
        raise InputError("Not a valid position !", file=name, line=ln, field="lat/lon",
                         text=f"{cells[idx['lat']]},{cells[idx['lon']]}")
    sf = cells[idx["surfaced"]]
    if sf not in ("0", "1"):
        raise InputError("surfaced must be 0 or 1 !", file=name, line=ln, field="surfaced",
                         text=sf)
    return t, la, lo, sf == "1"


def cov_from_ellipse95(a95_m: float, b95_m: float, az_deg: float) -> FloatArray:
    """2×2 grid covariance (m², x east / y north) from the 95 % ellipse: semi-axes a95 ≥ b95 (m)
    and the major-axis azimuth (degrees clockwise from grid north).

    C = σa²·u·uᵀ + σb²·v·vᵀ with σ = (semi-axis)/k, k = sqrt(−2 ln 0.05), u = (sin Az, cos Az) the
    major and v = (cos Az, −sin Az) the minor axis direction (the inverse of
    :func:`engine.lsq.confidence.error_ellipse` followed by ``scaled(0.95)``).
    """
    sa2 = a95_m * a95_m / K95_SQ
    sb2 = b95_m * b95_m / K95_SQ
    az = math.radians(az_deg)
    s, c = math.sin(az), math.cos(az)
    cxx = sa2 * s * s + sb2 * c * c
    cyy = sa2 * c * c + sb2 * s * s
    cxy = (sa2 - sb2) * s * c
    return np.array([[cxx, cxy], [cxy, cyy]])


@dataclass(frozen=True, eq=False)
class EstimateTrack:
    """One estimate per log cycle, aligned with :attr:`NavLog.t_ms`: geodetic position (degrees,
    working datum; NaN where the cycle has none) and the 2×2 covariance (m², grid of the cycle's
    CM; NaN where unknown)."""

    name: str
    lat_deg: FloatArray
    lon_deg: FloatArray
    cov: FloatArray  # shape (n, 2, 2)

    @property
    def present(self) -> BoolArray:
        """True where the cycle has this estimate."""
        return np.isfinite(self.lat_deg) & np.isfinite(self.lon_deg)


@dataclass(frozen=True, eq=False)
class NavLog:
    """A replayed run as read back: per cycle the time (ms since 1970, UTC), the working datum,
    the grid CM (degrees), the LSE/kf/MPP estimates and, from a ``.OUT`` log, the NIS of the
    filter's fix update and its degrees of freedom (NaN / 0 where the cycle had none; ``nis`` is
    None for JSON lines, which carry no innovations).

    ``poe_rate_m_h`` is the configuration's ``[demo] poe_expansion_m_h`` when the log embeds its
    configuration (``.OUT``), else None.  ``cov_exact`` is False when covariances were rebuilt
    from the printed 95 % ellipse (JSON lines).
    """

    path: str
    kind: str  # "out" | "jsonl"
    t_ms: IntArray
    datum: tuple[str, ...]
    cm_deg: FloatArray
    tracks: Mapping[str, EstimateTrack]
    nis: FloatArray | None = None
    nis_dof: IntArray | None = None
    poe_rate_m_h: float | None = None
    cov_exact: bool = True
    notes: tuple[str, ...] = ()


def _f(v: Any) -> float:
    """A log value as float (None, text or bool → NaN)."""
    if isinstance(v, bool) or v is None:
        return math.nan
    if isinstance(v, int | float):
        return float(v)
    return math.nan


def _cov_from_fields(d: Mapping[str, Any]) -> FloatArray:
    cxx, cxy, cyy = _f(d.get("cxx")), _f(d.get("cxy")), _f(d.get("cyy"))
    if math.isfinite(cxx) and math.isfinite(cxy) and math.isfinite(cyy):
        return np.array([[cxx, cxy], [cxy, cyy]])
    a, b, az = _f(d.get("a95")), _f(d.get("b95")), _f(d.get("az_deg", d.get("az")))
    if math.isfinite(a) and math.isfinite(b) and math.isfinite(az):
        return cov_from_ellipse95(a, b, az)
    return np.full((2, 2), np.nan)


_NAN4 = (math.nan,) * 4


class _TrackBuilder:
    """Per-epoch lat, lon and 2×2 VCV of one estimate, packed as C doubles (6 × 8 bytes per
    epoch: a day at 1 Hz is 4 MB per estimate, where a list of arrays took ~40 MB)."""

    def __init__(self) -> None:
        self.lat = array("d")
        self.lon = array("d")
        self.cov = array("d")

    def add(self, d: Mapping[str, Any] | None) -> None:
        if d is None:
            self.lat.append(math.nan)
            self.lon.append(math.nan)
            self.cov.extend(_NAN4)
        else:
            self.lat.append(_f(d.get("lat")))
            self.lon.append(_f(d.get("lon")))
            self.cov.extend(_cov_from_fields(d).ravel().tolist())

    def build(self, name: str) -> EstimateTrack:
        cov = np.frombuffer(self.cov, dtype=float).copy().reshape(-1, 2, 2)
        return EstimateTrack(name, np.frombuffer(self.lat, dtype=float).copy(),
                             np.frombuffer(self.lon, dtype=float).copy(), cov)


def _read_jsonl(name: str) -> NavLog:
    t_ms = array("q")
    datum: list[str] = []
    cm = array("d")
    builders = {e: _TrackBuilder() for e in ESTIMATORS}
    notes: list[str] = []  # a last line cut short (a run interrupted), as for a cut .OUT
    for ln, obj in iter_json_objects(name, "a cycle of a --jsonl log", notes):
        if "time" not in obj:
            raise InputError("JSON line without 'time' !", file=name, line=ln, field="time")
        t_ms.append(_time_ms(str(obj["time"]), name, ln, "time"))
        datum.append(sys.intern(str(obj.get("datum", ""))))
        cm.append(_f(obj.get("cm_deg")))
        for e in ESTIMATORS:
            v = obj.get(e)
            builders[e].add(v if isinstance(v, dict) else None)
    if not t_ms:
        raise InputError("No cycles in the log !", file=name)
    return NavLog(
        path=name, kind="jsonl", t_ms=np.array(t_ms, dtype=np.int64), datum=tuple(datum),
        cm_deg=np.array(cm), tracks={e: b.build(e) for e, b in builders.items()},
        cov_exact=False,
        notes=(*notes,
               "covariances rebuilt from the printed 95 % ellipse (a95, b95 to 1 mm, az to "
               "0.01°): exact up to that rounding",
               "NIS skipped: JSON lines carry no filter innovations (use the .OUT log)"),
    )


def _poe_rate_from_config(config_text: str) -> float | None:
    if not config_text.strip():
        return None
    import tomllib

    try:
        data = tomllib.loads(config_text)
    except tomllib.TOMLDecodeError:
        return None
    demo = data.get("demo")
    v = demo.get("poe_expansion_m_h") if isinstance(demo, dict) else None
    if isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) and v >= 0:
        return float(v)
    return None


def _read_out(name: str) -> NavLog:
    """One streaming pass over the log (engine.io.outlog.iter_out_log): only the packed columns
    below grow with the run, about 200 bytes per cycle."""
    log, events = iter_out_log(name)
    t_ms = array("q")
    datum: list[str] = []
    cm = array("d")
    nis = array("d")
    dof = array("q")
    builders = {e: _TrackBuilder() for e in ESTIMATORS}
    checks = PositionChecks(name)
    for _kind, c in events:
        if not isinstance(c, OutCycle):
            continue
        f = c.fields
        t_ms.append(_time_ms(str(f.get("t")), name, c.line or None, f"CYCLE n={f.get('n')} t"))
        datum.append(sys.intern(str(f.get("datum", ""))))
        cm.append(_f(f.get("cm")))
        lse = c.first("LSE")
        builders["lse"].add(lse if lse is not None and lse.get("kind") == "lse" else None)
        mpp = c.first("MPP")
        builders["kf"].add(mpp if f.get("source") == "KF" else None)
        builders["mpp"].add(mpp)
        checks.check("LSE", lse, c.line)
        checks.check("MPP", mpp, c.line)
        # NIS of the epoch's update (fix and depth), not of the sensor update (upd=sensors).
        test = next((t for t in c.all("TEST") if t.get("upd") != "sensors"), None)
        p = test.get("dof") if test is not None else None
        lom = _f(test.get("lom")) if test is not None else math.nan
        if isinstance(p, int) and p > 0 and math.isfinite(lom):
            nis.append(lom * p)
            dof.append(p)
        else:
            nis.append(math.nan)
            dof.append(0)
    if not t_ms:
        raise InputError("No cycles in the log !", file=name)
    notes = [*log.problems, *checks.notes()]
    rate = _poe_rate_from_config("\n".join(log.config) + "\n")
    return NavLog(
        path=name, kind="out", t_ms=np.array(t_ms, dtype=np.int64), datum=tuple(datum),
        cm_deg=np.array(cm), tracks={e: b.build(e) for e, b in builders.items()},
        nis=np.array(nis), nis_dof=np.array(dof, dtype=np.int64), poe_rate_m_h=rate,
        cov_exact=True, notes=tuple(notes),
    )


def read_nav_log(path: str | os.PathLike[str]) -> NavLog:
    """Read a ``.OUT`` log or a JSON-lines file (told apart by the first non-blank character:
    ``{`` = JSON lines).  Raises :class:`InputError` for a missing, empty or malformed file."""
    name = str(path)
    p = Path(path)
    if not p.is_file():
        raise InputError("File not found !", file=name, field="log")
    try:
        with open(p, "rb") as fh:  # bytes: a line that is not UTF-8 is named by the reader
            head = fh.read(4096).lstrip()
    except OSError as exc:
        raise InputError(f"Cannot read the log: {exc.strerror or exc} !", file=name) from None
    if not head:
        raise InputError("Empty log file !", file=name)
    check_log_head(head, name)
    if head.startswith(b"{"):
        return _read_jsonl(name)
    return _read_out(name)


# --------------------------------------------------------------------------------------------
# Results


@dataclass(frozen=True)
class ErrorStats:
    """Accuracy of one estimate in one phase.

    ``n`` epochs with the estimate; horizontal error (m) RMS, 95th percentile (linear
    interpolation) and maximum (NaN when n = 0).  ``n_cov`` of them have a usable covariance:
    ``coverage`` is the fraction with the truth inside the 95 % ellipse and ``coverage_band`` the
    central 95 % binomial range of that fraction for ``n_cov`` independent epochs; ``nees`` is the
    mean of eᵀC⁻¹e (expected 2) and ``nees_band`` the central 95 % range of the mean of ``n_cov``
    independent χ²(2) values, χ²(2n)/n.  Both bands ignore the correlation between epochs and are
    optimistic.
    """

    phase: str
    estimator: str
    n: int
    rms_m: float
    p95_m: float
    max_m: float
    n_cov: int
    coverage: float
    coverage_band: tuple[float, float]
    nees: float
    nees_band: tuple[float, float]


@dataclass(frozen=True)
class NisStats:
    """Filter fix-update consistency in one phase: ``n`` updates, mean NIS (v̂ᵀS⁻¹v̂), mean degrees
    of freedom (its expectation) and the central 95 % range of the mean for independent updates,
    χ²(Σp)/n (optimistic for correlated innovations)."""

    phase: str
    n: int
    mean_nis: float
    mean_dof: float
    band: tuple[float, float]


@dataclass(frozen=True)
class PhaseSpan:
    """A phase: matched epochs ``n`` and the first/last matched time (UTC; None if empty)."""

    name: str
    n: int
    start: datetime | None
    end: datetime | None


@dataclass(frozen=True)
class PoeRow:
    """One sample of a dive: minutes since the dive started and since the last LSE, the Pool of
    Errors radius R = a + ε·Δt (m), the filter's 95 % semi-major axis (m) and the true horizontal
    errors (m) of the filter and of the MPP (NaN where absent)."""

    time: datetime
    t_dive_min: float
    dt_fix_min: float
    poe_m: float
    kf_a95_m: float
    kf_error_m: float
    mpp_error_m: float


@dataclass(frozen=True)
class DiveReport:
    """A dive (run of submerged truth epochs): start/end (UTC), the LSE the POE starts from
    (time, d_rms ``a_m`` in m; None/NaN when the log has no LSE before the dive), the samples and,
    over every matched dive epoch, the fractions with the MPP error within the POE radius and
    with the filter error within the filter's 95 % semi-major axis."""

    start: datetime
    end: datetime
    fix_time: datetime | None
    a_m: float
    rows: tuple[PoeRow, ...]
    frac_mpp_in_poe: float
    frac_kf_in_a95: float


@dataclass(frozen=True, eq=False)
class AssessmentSeries:
    """Per matched epoch (time order): time (ms since 1970), phase index into :data:`PHASES`,
    grid errors (m) per estimate as (n, 2) arrays (x east, y north; NaN where absent), NEES per
    estimate, the filter's 95 % semi-major axis (m) and the POE radius (m; NaN before any LSE)."""

    t_ms: IntArray
    phase: IntArray
    error: Mapping[str, FloatArray]
    nees: Mapping[str, FloatArray]
    kf_a95_m: FloatArray
    poe_m: FloatArray


@dataclass(frozen=True, eq=False)
class Assessment:
    """The accuracy report of one run (see the module docstring for frame and definitions)."""

    log_path: str
    log_kind: str
    truth_path: str
    datum: str
    ellipsoid: str
    frame: str
    n_log: int
    n_truth: int
    n_matched: int
    n_log_unmatched: int  # cycles on the truth's datum whose time is not in the truth
    n_log_other_datum: int
    phases: tuple[PhaseSpan, ...]
    stats: tuple[ErrorStats, ...]
    nis: tuple[NisStats, ...] | None
    poe_rate_m_h: float
    poe_rate_source: str
    dives: tuple[DiveReport, ...]
    series: AssessmentSeries
    notes: tuple[str, ...] = field(default=())

    def stat(self, phase: str, estimator: str) -> ErrorStats:
        """The statistics of ``estimator`` in ``phase`` (KeyError if not reported)."""
        for s in self.stats:
            if s.phase == phase and s.estimator == estimator:
                return s
        raise KeyError((phase, estimator))


# --------------------------------------------------------------------------------------------
# Computation


def _utc(t_ms: int) -> datetime:
    return datetime.fromtimestamp(t_ms / 1000.0, tz=UTC)


def _chi2_band(dof: int, n: int) -> tuple[float, float]:
    """Central 95 % range of a sum of χ² with ``dof`` total degrees of freedom, divided by n."""
    lo, hi = chi2_bounds(0.05, dof)
    return lo / n, hi / n


def _binom_band(n: int, p: float = P95) -> tuple[float, float]:
    from scipy.stats import binom

    return float(binom.ppf(0.025, n, p)) / n, float(binom.ppf(0.975, n, p)) / n


def _nees(e: FloatArray, cov: FloatArray) -> FloatArray:
    """eᵀC⁻¹e per row for e (n, 2) and C (n, 2, 2); NaN where C is unknown or not PD."""
    cxx, cxy, cyy = cov[:, 0, 0], cov[:, 0, 1], cov[:, 1, 1]
    det = cxx * cyy - cxy * cxy
    ok = np.isfinite(det) & (det > 0.0) & (cxx > 0.0) & np.all(np.isfinite(e), axis=1)
    ex, ey = e[:, 0], e[:, 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        q = (cyy * ex * ex - 2.0 * cxy * ex * ey + cxx * ey * ey) / det
    return np.where(ok, q, np.nan)


def _a95(cov: FloatArray) -> FloatArray:
    """95 % semi-major axis (m) per 2×2 covariance (NaN where unknown)."""
    cxx, cxy, cyy = cov[:, 0, 0], cov[:, 0, 1], cov[:, 1, 1]
    l1 = 0.5 * (cxx + cyy) + np.hypot(0.5 * (cxx - cyy), cxy)
    return math.sqrt(K95_SQ) * np.sqrt(np.clip(l1, 0.0, None))


def _error_stats(phase: str, est: str, e: FloatArray, q: FloatArray) -> ErrorStats:
    d = np.hypot(e[:, 0], e[:, 1])
    d = d[np.isfinite(d)]
    n = int(d.size)
    qq = q[np.isfinite(q)]
    nc = int(qq.size)
    nan2 = (math.nan, math.nan)
    return ErrorStats(
        phase=phase,
        estimator=est,
        n=n,
        rms_m=float(np.sqrt(np.mean(d * d))) if n else math.nan,
        p95_m=float(np.percentile(d, 95.0)) if n else math.nan,
        max_m=float(d.max()) if n else math.nan,
        n_cov=nc,
        coverage=float(np.mean(qq <= K95_SQ)) if nc else math.nan,
        coverage_band=_binom_band(nc) if nc else nan2,
        nees=float(qq.mean()) if nc else math.nan,
        nees_band=_chi2_band(2 * nc, nc) if nc else nan2,
    )


def _grid_errors(ell: Ellipsoid, cm: FloatArray, lat_t: FloatArray, lon_t: FloatArray,
                 track: EstimateTrack, sel: IntArray) -> FloatArray:
    """Grid error (n, 2) in metres of ``track`` at log cycles ``sel``: both positions projected
    on the TM grid of each cycle's CM."""
    out = np.full((sel.size, 2), np.nan)
    lat_e, lon_e = track.lat_deg[sel], track.lon_deg[sel]
    ok = np.isfinite(lat_e) & np.isfinite(lon_e)
    for c in np.unique(cm[ok]):
        m = ok & (cm == c)
        grid = TMGrid(ell, float(c))
        xe, ye = grid.forward_array(lat_e[m], lon_e[m])
        xt, yt = grid.forward_array(lat_t[m], lon_t[m])
        out[m, 0] = xe - xt
        out[m, 1] = ye - yt
    return out


def _poe_series(t_ms: IntArray, lse_ok: BoolArray, lse_drms: FloatArray,
                rate_m_h: float) -> tuple[FloatArray, IntArray]:
    """POE radius (m) per epoch from the last LSE at or before it, and that LSE's index (−1)."""
    idx = np.where(lse_ok, np.arange(t_ms.size), -1)
    last = np.maximum.accumulate(idx) if idx.size else idx
    poe = np.full(t_ms.size, np.nan)
    has = last >= 0
    dt_h = (t_ms[has] - t_ms[last[has]]) / 3.6e6
    poe[has] = lse_drms[last[has]] + rate_m_h * dt_h
    return poe, last


def assess(
    log: NavLog,
    truth: Truth,
    *,
    poe_rate_m_h: float | None = None,
    split_phases: bool = True,
    ellipsoid: Ellipsoid | None = None,
    step_min: float = 10.0,
    poe_rate_source: str = "option",
) -> Assessment:
    """Compare ``log`` with ``truth``; see the module docstring for every definition.

    ``poe_rate_m_h`` (ε, m/h) overrides the log's configured rate (default 1800 m/h) and
    ``poe_rate_source`` says where it came from;
    ``split_phases`` False reports the ``all`` phase only; ``ellipsoid`` is the working datum's
    ellipsoid when the truth header does not state it; ``step_min`` the POE sampling interval.
    Raises :class:`InputError` if the datums disagree, no ellipsoid is known or no epoch matches.
    """
    ell = truth.ellipsoid or ellipsoid
    if ell is None:
        raise InputError("The truth header does not state the working datum's ellipsoid "
                         "(give a datum file) !", file=truth.path)
    notes: list[str] = list(log.notes)
    same, datum_name = _same_datum(log, truth)
    n_other = int((~same).sum())
    if n_other:
        notes.append(f"{n_other} log cycles on another datum than {datum_name} left out")
    sel, tidx, has_truth = _match_epochs(log, truth, same, notes)
    t_ms = log.t_ms[sel]
    lat_t, lon_t = truth.lat_deg[tidx], truth.lon_deg[tidx]
    cm = log.cm_deg[sel]
    if (~np.isfinite(cm)).any():
        raise InputError("Log cycle without a central meridian !", file=log.path, field="cm")
    phase = _phases(truth, tidx, t_ms)
    errors: dict[str, FloatArray] = {}
    nees: dict[str, FloatArray] = {}
    for est in ESTIMATORS:
        tr = log.tracks[est]
        errors[est] = _grid_errors(ell, cm, lat_t, lon_t, tr, sel)
        nees[est] = _nees(errors[est], tr.cov[sel])
    masks = {"all": np.ones(sel.size, dtype=bool)}
    if split_phases:
        masks = {name: phase == i for i, name in enumerate(PHASES[:3])} | masks
    stats, spans = _phase_stats(masks, t_ms, errors, nees)
    rate, rate_src = _poe_rate(log, poe_rate_m_h, poe_rate_source)
    poe, kf_a95, dives = _pool_of_errors(log, truth, sel, t_ms, errors, rate, step_min)
    series = AssessmentSeries(t_ms, phase, errors, nees, kf_a95, poe)
    frame = (f"TM grid of each cycle's CM on {datum_name} ({ell.name}), k0 = 1: truth and "
             "estimate both projected; x east, y north")
    return Assessment(
        log_path=log.path, log_kind=log.kind, truth_path=truth.path, datum=datum_name,
        ellipsoid=ell.name, frame=frame, n_log=int(log.t_ms.size), n_truth=int(truth.t_ms.size),
        n_matched=int(sel.size), n_log_unmatched=int((same & ~has_truth).sum()),
        n_log_other_datum=n_other, phases=spans, stats=stats,
        nis=_nis_stats(log, sel, masks), poe_rate_m_h=rate,
        poe_rate_source=rate_src, dives=dives, series=series, notes=tuple(notes),
    )


def _phase_stats(
    masks: Mapping[str, BoolArray], t_ms: IntArray, errors: Mapping[str, FloatArray],
    nees: Mapping[str, FloatArray],
) -> tuple[tuple[ErrorStats, ...], tuple[PhaseSpan, ...]]:
    """Error statistics per phase and estimator, and each phase's epoch count and time span."""
    stats = tuple(
        _error_stats(ph, est, errors[est][m], nees[est][m])
        for ph, m in masks.items() for est in ESTIMATORS
    )
    spans = tuple(
        PhaseSpan(ph, int(m.sum()), _utc(int(t_ms[m][0])) if m.any() else None,
                  _utc(int(t_ms[m][-1])) if m.any() else None)
        for ph, m in masks.items()
    )
    return stats, spans


def _same_datum(log: NavLog, truth: Truth) -> tuple[BoolArray, str]:
    """Which log cycles are on the truth's working datum, and that datum's name (the log's when
    the truth does not state it). Raises InputError when none is, or the log changes datum."""
    log_datums = {d.strip().upper() for d in log.datum if d.strip()}
    if truth.datum is not None:
        tdat = truth.datum.strip().upper()
        same = np.array([d.strip().upper() in ("", tdat) for d in log.datum], dtype=bool)
        if not same.any():
            raise InputError(f"The log's datum ({', '.join(sorted(log_datums))}) is not the "
                             f"truth's working datum ({truth.datum}) !", file=log.path,
                             field="datum")
        return same, truth.datum
    if len(log_datums) > 1:
        raise InputError("The log changes datum and the truth does not state its own !",
                         file=log.path, field="datum")
    return np.ones(log.t_ms.size, dtype=bool), ", ".join(sorted(log_datums)) or "?"


def _match_epochs(
    log: NavLog, truth: Truth, same: BoolArray, notes: list[str]
) -> tuple[IntArray, IntArray, BoolArray]:
    """Match log cycles to truth epochs by time (first occurrence of a repeated log time).

    Returns the matched log indices and their truth indices, both in time order, and which log
    cycles have a truth epoch at all; a note is added for repeated log times.
    """
    order = np.argsort(truth.t_ms, kind="stable")
    tt = truth.t_ms[order]
    pos = np.searchsorted(tt, log.t_ms)
    pos_c = np.clip(pos, 0, tt.size - 1)
    has_truth = tt[pos_c] == log.t_ms
    hit = has_truth & same
    _, first = np.unique(log.t_ms, return_index=True)
    is_first = np.zeros(log.t_ms.size, dtype=bool)
    is_first[first] = True
    n_dup = int((hit & ~is_first).sum())
    if n_dup:
        notes.append(f"{n_dup} log cycles repeat an earlier time stamp: first one used")
    hit &= is_first
    sel = np.flatnonzero(hit)
    if sel.size == 0:
        raise InputError("No epochs in common: no log cycle time matches a truth time !",
                         file=log.path, field="time")
    tidx = order[pos_c[sel]]
    o = np.argsort(log.t_ms[sel], kind="stable")
    return sel[o], tidx[o], has_truth


def _phases(truth: Truth, tidx: IntArray, t_ms: IntArray) -> IntArray:
    """Phase index (into :data:`PHASES`) of each matched epoch, from the truth: 0 before the
    first submerged epoch, 1 submerged, 2 surfaced after it."""
    surfaced = truth.surfaced[tidx]
    sub_t = truth.t_ms[~truth.surfaced]
    t_first_sub = int(sub_t.min()) if sub_t.size else None
    phase = np.full(tidx.size, 0, dtype=np.int64)
    phase[~surfaced] = 1
    if t_first_sub is not None:
        phase[surfaced & (t_ms > t_first_sub)] = 2
    return phase


def _nis_stats(
    log: NavLog, sel: IntArray, masks: Mapping[str, BoolArray]
) -> tuple[NisStats, ...] | None:
    """NIS of the filter's fix updates per phase (``.OUT`` logs only, else None)."""
    if log.nis is None or log.nis_dof is None:
        return None
    v, p = log.nis[sel], log.nis_dof[sel]
    rows = []
    for ph, m in masks.items():
        mm = m & np.isfinite(v) & (p > 0)
        n = int(mm.sum())
        dof = int(p[mm].sum())
        rows.append(NisStats(ph, n, float(v[mm].mean()) if n else math.nan,
                             dof / n if n else math.nan,
                             _chi2_band(dof, n) if n else (math.nan, math.nan)))
    return tuple(rows)


def _poe_rate(log: NavLog, rate_m_h: float | None, source: str) -> tuple[float, str]:
    """POE growth rate ε [m/h] and where it came from: the option, the log, else 1800."""
    if rate_m_h is not None:
        return float(rate_m_h), source
    if log.poe_rate_m_h is not None:
        return log.poe_rate_m_h, "log configuration"
    return 1800.0, "default"


def _pool_of_errors(
    log: NavLog, truth: Truth, sel: IntArray, t_ms: IntArray, errors: Mapping[str, FloatArray],
    rate: float, step_min: float,
) -> tuple[FloatArray, FloatArray, tuple[DiveReport, ...]]:
    """POE radius [m] per matched epoch, the filter's 95 % semi-major axis [m] and the dives."""
    lse_cov = log.tracks["lse"].cov[sel]
    lse_drms = np.sqrt(lse_cov[:, 0, 0] + lse_cov[:, 1, 1])
    lse_ok = np.all(np.isfinite(errors["lse"]), axis=1) & np.isfinite(lse_drms)
    poe, last = _poe_series(t_ms, lse_ok, lse_drms, rate)
    kf_a95 = _a95(log.tracks["kf"].cov[sel])
    dives = _dives(truth, t_ms, poe, last, lse_drms, kf_a95, errors, step_min)
    return poe, kf_a95, dives


def _dives(truth: Truth, t_ms: IntArray, poe: FloatArray, last: IntArray, lse_drms: FloatArray,
           kf_a95: FloatArray, errors: Mapping[str, FloatArray],
           step_min: float) -> tuple[DiveReport, ...]:
    """One :class:`DiveReport` per run of submerged truth epochs that has matched epochs."""
    order = np.argsort(truth.t_ms, kind="stable")
    ts, sub = truth.t_ms[order], ~truth.surfaced[order]
    kf_err = np.hypot(errors["kf"][:, 0], errors["kf"][:, 1])
    mpp_err = np.hypot(errors["mpp"][:, 0], errors["mpp"][:, 1])
    out: list[DiveReport] = []
    i = 0
    n = ts.size
    step_ms = step_min * 60_000.0
    while i < n:
        if not sub[i]:
            i += 1
            continue
        j = i
        while j + 1 < n and sub[j + 1]:
            j += 1
        t0, t1 = int(ts[i]), int(ts[j])
        i = j + 1
        inside = np.flatnonzero((t_ms >= t0) & (t_ms <= t1))
        if inside.size == 0:
            continue
        k0 = int(inside[0])
        fix = int(last[k0])
        fix_time = _utc(int(t_ms[fix])) if fix >= 0 else None
        a = float(lse_drms[fix]) if fix >= 0 else math.nan
        targets = [t0 + k * step_ms for k in range(int((t1 - t0) // step_ms) + 1)]
        if targets[-1] < t1:
            targets.append(float(t1))
        rows: list[PoeRow] = []
        used: set[int] = set()
        for tg in targets:
            # the first matched dive epoch at or after the target, else the last one
            later = inside[t_ms[inside] >= tg]
            k = int(later[0]) if later.size else int(inside[-1])
            if k in used:
                continue
            used.add(k)
            f = int(last[k])
            rows.append(PoeRow(
                time=_utc(int(t_ms[k])),
                t_dive_min=(int(t_ms[k]) - t0) / 60_000.0,
                dt_fix_min=(int(t_ms[k]) - int(t_ms[f])) / 60_000.0 if f >= 0 else math.nan,
                poe_m=float(poe[k]),
                kf_a95_m=float(kf_a95[k]),
                kf_error_m=float(kf_err[k]),
                mpp_error_m=float(mpp_err[k]),
            ))
        me, pr = mpp_err[inside], poe[inside]
        okp = np.isfinite(me) & np.isfinite(pr)
        ke, ka = kf_err[inside], kf_a95[inside]
        okk = np.isfinite(ke) & np.isfinite(ka)
        out.append(DiveReport(
            start=_utc(t0), end=_utc(t1), fix_time=fix_time, a_m=a, rows=tuple(rows),
            frac_mpp_in_poe=float(np.mean(me[okp] <= pr[okp])) if okp.any() else math.nan,
            frac_kf_in_a95=float(np.mean(ke[okk] <= ka[okk])) if okk.any() else math.nan,
        ))
    return tuple(out)

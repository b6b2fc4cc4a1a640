"""Measurement rows of the filter (6.26–6.29, H of 6.33, R of 6.36; raw LOPs §10.3): the LSE
position, the sensors (pressure depth, log, gyro, inclinometer) and their stacking.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import ClassVar

import numpy as np

from engine.filter.params import DEG, FilterParams, read_only
from engine.filter.state import IDEPS, IDPSI, IDV, IEPS, IPSI, IV, IX, IY, IZ, N_NAV, FilterState


@dataclass(frozen=True, eq=False)
class Measurement:
    """Linear(ised) measurement rows: z = H x + b + v, v ~ N(0, R).

    ``z`` (p,), ``H`` (p×n_H, n_H ≤ n_state; narrower H is zero-padded), ``R`` (p×p),
    ``labels`` per row; innovations of ``angle_rows`` are wrapped to (−π, π].
    ``bias_keys`` (empty, or one entry per row): the Gauss–Markov fix-error state b added to
    that row (None for none); :func:`update` puts the 1 in the right column and, if the state
    lacks a key, adds it first with stationary VCV ``bias_cov`` (m², over the distinct keys in
    order of first appearance) and correlation times ``bias_tau_s`` (s, same order).
    """

    z: np.ndarray
    H: np.ndarray
    R: np.ndarray
    labels: tuple[str, ...]
    angle_rows: tuple[int, ...] = ()
    bias_keys: tuple[str | None, ...] = ()
    bias_cov: np.ndarray | None = None
    bias_tau_s: tuple[float, ...] = ()
    _cols: ClassVar[tuple[tuple[int, ...], ...] | None] = None
    """Set (per instance, not a field) by the constructors here whose H is an
    :func:`h_template`: the columns of the 1s of each row. None: H is a general matrix."""


@lru_cache(maxsize=128)
def h_template(cols: tuple[tuple[int, ...], ...], n: int) -> np.ndarray:
    """The read-only p×n H with a 1 in row i at each column of ``cols[i]``, 0 elsewhere (shared:
    the rows of an LSE, a sensor or a stack of them, over the nav or all n states)."""
    H = np.zeros((len(cols), n))
    for i, row in enumerate(cols):
        for c in row:
            H[i, c] = 1.0
    return read_only(H)


def _measurement(
    z: np.ndarray,
    H: np.ndarray,
    R: np.ndarray,
    labels: tuple[str, ...],
    angle_rows: tuple[int, ...] = (),
    bias_keys: tuple[str | None, ...] = (),
    bias_cov: np.ndarray | None = None,
    bias_tau_s: tuple[float, ...] = (),
    cols: tuple[tuple[int, ...], ...] | None = None,
) -> Measurement:
    """A :class:`Measurement` built without its dataclass __init__ (hot path; it has no
    __post_init__), with ``cols`` (:attr:`Measurement._cols`) when H is an :func:`h_template`."""
    m = object.__new__(Measurement)
    m.__dict__.update(z=z, H=H, R=R, labels=labels, angle_rows=angle_rows, bias_keys=bias_keys,
                      bias_cov=bias_cov, bias_tau_s=bias_tau_s)
    if cols is not None:
        m.__dict__["_cols"] = cols
    return m


_LSE_COLS = ((IX,), (IY,))
_LSE_LABELS = ("x_LSE", "y_LSE")


def lse_measurement(
    x_m: float,
    y_m: float,
    C2: np.ndarray,
    params: FilterParams | None = None,
    keys: tuple[str, str] = ("fix_e", "fix_n"),
) -> Measurement:
    """Rows 0–1 of eq. 6.26a/6.36: the LSE grid position (m) with its full 2×2 VCV C2 (m²).

    With ``params.coloured`` the rows become x + b_e, y + b_n on the Gauss–Markov states
    ``keys`` (added by :func:`update` on first use, stationary VCV frac·C2, τ = fix_tau_s) and
    R = (1 − frac)·C2, the white part (THEORY §8.2 option (a)).
    """
    C = np.asarray(C2, dtype=float)
    H = h_template(_LSE_COLS, N_NAV)
    z = np.array([x_m, y_m], dtype=float)
    if params is not None and params.coloured:
        f = params.fix_sigma_frac
        return _measurement(z, H, C * (1.0 - f), _LSE_LABELS, (), keys, C * f,
                            (params.fix_tau_s, params.fix_tau_s), _LSE_COLS)
    return _measurement(z, H, C, _LSE_LABELS, cols=_LSE_COLS)


def sensor_measurement(
    state: FilterState,
    *,
    depth_m: float | None = None,
    log_ms: float | None = None,
    gyro_grid_rad: float | None = None,
    incl_rad: float | None = None,
    params: FilterParams,
    log_sigma_ms: float | None = None,
    gyro_sigma_deg: float | None = None,
) -> Measurement:
    """Rows 2–5 (eqs. 6.26b–6.29) for the sensors that gave a value this cycle.

    Pressure depth (m, σ_p), log speed (m/s, σ = max(frac·v, floor), 4.19), gyro GRID heading
    (rad, σ 0.65°, innovation wrapped) and inclination (rad, bow-down +). ``log_sigma_ms`` /
    ``gyro_sigma_deg`` replace this cycle's σ of the speed / heading row (a COG/SOG stand-in,
    docs/GNSS_WEIGHTS.md); None: the parameters' σ.

    The rows' values, variances and layout are those of :func:`sensor_rows`.
    """
    return rows_measurement(*sensor_rows(depth_m, log_ms, gyro_grid_rad, incl_rad, params,
                                         log_sigma_ms, gyro_sigma_deg))


SensorLayout = tuple[tuple[str, ...], tuple[tuple[int, ...], ...], np.ndarray, tuple[int, ...]]
"""(labels, H columns, H template over the nav states, angle rows) of a set of sensor rows."""


def sensor_rows(
    depth_m: float | None,
    log_ms: float | None,
    gyro_grid_rad: float | None,
    incl_rad: float | None,
    params: FilterParams,
    log_sigma_ms: float | None = None,
    gyro_sigma_deg: float | None = None,
) -> tuple[list[float], list[float], SensorLayout]:
    """The values (m, m/s, rad, rad), variances of their white noise and layout (labels, H
    columns, H template over the nav states, angle rows: :func:`_sensor_layout`) of the sensor
    rows of :func:`sensor_measurement`, which :func:`rows_measurement` makes the measurement of
    and ``engine.filter.update.update_rows`` updates a state with directly."""
    zs: list[float] = []
    var: list[float] = []
    which = 0
    c = _VARIANCES.get(id(params))
    if c is None or c[0] is not params:
        c = _sensor_variances(params)
    if depth_m is not None:
        zs.append(depth_m)
        var.append(c[1])  # params.sigma_press_m**2
        which = 1
    if log_ms is not None:
        if log_sigma_ms is None:
            s2 = max(params.log_sigma_frac * abs(log_ms), params.log_sigma_floor_ms) ** 2
        else:
            s2 = log_sigma_ms**2
        zs.append(log_ms)
        var.append(s2)
        which |= 2
    if gyro_grid_rad is not None:
        zs.append(gyro_grid_rad)
        # (sd * DEG) ** 2 with sd = params.sigma_gyro_deg unless this cycle's σ is given
        var.append(c[2] if gyro_sigma_deg is None else (gyro_sigma_deg * DEG) ** 2)
        which |= 4
    if incl_rad is not None:
        zs.append(incl_rad)
        var.append(c[3])  # (params.sigma_incl_deg * DEG) ** 2
        which |= 8
    layout = _LAYOUTS.get(which)
    if layout is None:
        layout = _LAYOUTS[which] = _sensor_layout(which)
    return zs, var, layout


def depth_sensor_rows(depth_m: float,
                      params: FilterParams) -> tuple[list[float], list[float], SensorLayout]:
    """``sensor_rows(depth_m, None, None, None, params)``: the pressure depth's row alone (m,
    its variance σ_p² m² and layout), the cycle's depth update, without the other sensors'
    branches."""
    c = _VARIANCES.get(id(params))
    if c is None or c[0] is not params:
        c = _sensor_variances(params)
    layout = _LAYOUTS.get(1)
    if layout is None:
        layout = _LAYOUTS[1] = _sensor_layout(1)
    return [depth_m], [c[1]], layout


def rows_measurement(zs: list[float], var: list[float], layout: SensorLayout) -> Measurement:
    """The measurement of independent rows: values ``zs``, variances ``var`` (R diagonal) and
    the ``layout`` of :func:`sensor_rows`."""
    labels, cols_t, H, angle = layout
    p = len(zs)
    R = np.zeros((p, p))
    for i, s2 in enumerate(var):
        R[i, i] = s2
    return _measurement(np.array(zs, dtype=float), H, R, labels, angle, cols=cols_t)


_VARIANCES: dict[int, tuple[FilterParams, float, float, float]] = {}
"""id(params) → (params, σ_p², (σ_gyro·DEG)², (σ_incl·DEG)²): the sensor rows' variances that
depend only on the (frozen) parameters, computed once per parameter set by the same operations
(:func:`_sensor_variances`; the entry holds ``params``, so its id is not reused meanwhile)."""


def _sensor_variances(params: FilterParams) -> tuple[FilterParams, float, float, float]:
    """The :data:`_VARIANCES` entry of ``params`` (m², rad², rad²), made and remembered."""
    if len(_VARIANCES) >= 16:
        _VARIANCES.clear()
    c = _VARIANCES[id(params)] = (params, params.sigma_press_m**2,
                                  (params.sigma_gyro_deg * DEG) ** 2,
                                  (params.sigma_incl_deg * DEG) ** 2)
    return c


_LAYOUTS: dict[int, SensorLayout] = {}
"""Bit set of the sensors present (1 depth, 2 log, 4 gyro, 8 inclinometer) → layout."""


def _sensor_layout(which: int) -> SensorLayout:
    """(labels, H columns, H template, angle rows) of the sensor rows in bit set ``which``
    (1 depth, 2 log, 4 gyro, 8 inclinometer), in :func:`_sensor_rows`' order."""
    rows = [(label, cols) for bit, label, cols in
            ((1, "z_p", (IZ,)), (2, "v_m", (IV, IDV)), (4, "psi_m", (IPSI, IDPSI)),
             (8, "eps_m", (IEPS, IDEPS))) if which & bit]
    labels = tuple(r[0] for r in rows)
    cols_t = tuple(r[1] for r in rows)
    angle = (labels.index("psi_m"),) if "psi_m" in labels else ()
    return labels, cols_t, h_template(cols_t, N_NAV), angle


def nav_measurement(
    state: FilterState,
    params: FilterParams,
    *,
    fix_xy: tuple[float, float] | None = None,
    fix_cov: np.ndarray | None = None,
    depth_m: float | None = None,
    log_ms: float | None = None,
    gyro_grid_rad: float | None = None,
    incl_rad: float | None = None,
    fix_keys: tuple[str, str] = ("fix_e", "fix_n"),
    log_sigma_ms: float | None = None,
    gyro_sigma_deg: float | None = None,
) -> Measurement:
    """The thesis measurement vector (6.26–6.29, H of 6.33, R of 6.36) in one go: the LSE rows
    (grid m, full 2×2 VCV ``fix_cov`` m²; coloured mode as in :func:`lse_measurement`) and the
    sensor rows that are available, in the fixed order x, y, z_p, v_m, ψ_m, ε_m. ``state`` is
    not read (kept for symmetry with :func:`sensor_measurement`); H has the 11 nav columns.
    ``log_sigma_ms``/``gyro_sigma_deg`` as in :func:`sensor_measurement`."""
    zs: list[float] = []
    var: list[float] = []
    labels: list[str] = []
    cols: list[tuple[int, ...]] = []
    if fix_xy is not None:
        if fix_cov is None:
            raise ValueError("an LSE needs its 2×2 VCV fix_cov")
        zs += (float(fix_xy[0]), float(fix_xy[1]))
        var += (0.0, 0.0)
        labels += _LSE_LABELS
        cols += _LSE_COLS
    _sensor_rows(zs, var, labels, cols, params, depth_m, log_ms, gyro_grid_rad, incl_rad,
                 log_sigma_ms, gyro_sigma_deg)
    p = len(zs)
    cols_t = tuple(cols)
    H = h_template(cols_t, N_NAV)
    R = np.zeros((p, p))
    for i, s2 in enumerate(var):
        R[i, i] = s2
    zz = np.array(zs, dtype=float)
    lab = tuple(labels)
    angle = (lab.index("psi_m"),) if "psi_m" in lab else ()
    if fix_xy is not None:
        C = np.asarray(fix_cov, dtype=float)
        if params.coloured:
            f = params.fix_sigma_frac
            R[:2, :2] = C * (1.0 - f)
            keys = (fix_keys[0], fix_keys[1]) + (None,) * (p - 2)
            return _measurement(zz, H, R, lab, angle, keys, C * f,
                                (params.fix_tau_s, params.fix_tau_s), cols_t)
        R[:2, :2] = C
    return _measurement(zz, H, R, lab, angle, cols=cols_t)


def _sensor_rows(
    zs: list[float],
    var: list[float],
    labels: list[str],
    cols: list[tuple[int, ...]],
    params: FilterParams,
    depth_m: float | None,
    log_ms: float | None,
    gyro_grid_rad: float | None,
    incl_rad: float | None,
    log_sigma_ms: float | None = None,
    gyro_sigma_deg: float | None = None,
) -> None:
    """Append the rows of the sensors that gave a value (value, variance of its white noise,
    label, state columns with a 1 in H), in the order z_p, v_m, ψ_m, ε_m: pressure depth (σ_p),
    log speed + log bias (σ = max(frac·v, floor), 4.19, or ``log_sigma_ms``), gyro GRID
    heading + gyro bias (σ ``params.sigma_gyro_deg`` or ``gyro_sigma_deg``), inclination +
    inclinometer bias (eqs. 6.26b–6.29)."""
    if depth_m is not None:
        zs.append(depth_m)
        var.append(params.sigma_press_m**2)
        labels.append("z_p")
        cols.append((IZ,))
    if log_ms is not None:
        if log_sigma_ms is None:
            s2 = max(params.log_sigma_frac * abs(log_ms), params.log_sigma_floor_ms) ** 2
        else:
            s2 = log_sigma_ms**2
        zs.append(log_ms)
        var.append(s2)
        labels.append("v_m")
        cols.append((IV, IDV))
    if gyro_grid_rad is not None:
        sd = params.sigma_gyro_deg if gyro_sigma_deg is None else gyro_sigma_deg
        zs.append(gyro_grid_rad)
        var.append((sd * DEG) ** 2)
        labels.append("psi_m")
        cols.append((IPSI, IDPSI))
    if incl_rad is not None:
        zs.append(incl_rad)
        var.append((params.sigma_incl_deg * DEG) ** 2)
        labels.append("eps_m")
        cols.append((IEPS, IDEPS))


def lop_measurement(
    a_rows: np.ndarray,
    omc_m: np.ndarray,
    x_ref: np.ndarray,
    R: np.ndarray,
    fix_keys: Sequence[str | None] | None = None,
    labels: Sequence[str] | None = None,
    bias_cov: np.ndarray | None = None,
    bias_tau_s: Sequence[float] = (),
) -> Measurement:
    """Raw metric LOPs fed directly to the filter (THEORY §9.3, D20).

    Rows A (k×2, dimensionless, ∂LOP/∂(x, y)) linearised at grid ``x_ref`` (m) where O−C is
    ``omc_m`` (m); R (k×k, m², the white part if rows carry fix-error states). Innovation =
    omc − A(x̂_xy − x_ref) − b, b the Gauss–Markov state ``fix_keys[i]`` of row i (or None);
    ``bias_cov``/``bias_tau_s`` let :func:`update` add missing ones. H is the LSQ A-row padded
    with zeros.
    """
    A = np.atleast_2d(np.asarray(a_rows, dtype=float))
    k = A.shape[0]
    H = np.zeros((k, N_NAV))
    H[:, :2] = A
    z = np.asarray(omc_m, dtype=float).reshape(k) + A @ np.asarray(x_ref, dtype=float)
    lab = tuple(labels) if labels is not None else tuple(f"lop{i}" for i in range(k))
    keys = tuple(fix_keys) if fix_keys is not None and any(fix_keys) else ()
    return Measurement(z, H, np.atleast_2d(np.asarray(R, dtype=float)), lab, (), keys,
                       None if bias_cov is None else np.atleast_2d(bias_cov),
                       tuple(float(t) for t in bias_tau_s))


def distinct_keys(keys: Sequence[str | None]) -> list[str]:
    out: list[str] = []
    for k in keys:
        if k is not None and k not in out:
            out.append(k)
    return out


_DISTINCT: dict[tuple[str | None, ...], tuple[str, ...]] = {}
"""Rows' fix-error keys → :func:`distinct_keys` of them as a tuple (a handful of layouts)."""


def distinct_key_tuple(keys: Sequence[str | None]) -> tuple[str, ...]:
    """:func:`distinct_keys` as a tuple, remembered per ``keys`` tuple (hot path: every update
    with fix-error rows asks for the same few)."""
    if type(keys) is not tuple:
        return tuple(distinct_keys(keys))
    dk = _DISTINCT.get(keys)
    if dk is None:
        if len(_DISTINCT) >= 64:
            _DISTINCT.clear()
        dk = _DISTINCT[keys] = tuple(distinct_keys(keys))
    return dk


def stack_measurements(*parts: Measurement) -> Measurement:
    """Concatenate measurement blocks (R block-diagonal), e.g. LSE rows then sensor rows.

    Fix-error keys are concatenated per row; their prior VCVs block-diagonally (a key already
    given by an earlier block keeps that block's prior).
    """
    parts = tuple(p for p in parts if p.z.shape[0])
    if not parts:
        return Measurement(np.zeros(0), np.zeros((0, N_NAV)), np.zeros((0, 0)), ())
    n = p_tot = 0
    sizes: list[int] = []
    cols: list[tuple[int, ...]] | None = []
    for p in parts:
        k = p.z.shape[0]
        sizes.append(k)
        p_tot += k
        w = p.H.shape[1]
        if w > n:
            n = w
        c = p._cols
        if c is None:
            cols = None
        elif cols is not None:
            cols += c
    cols_t = None if cols is None else tuple(cols)
    H = np.zeros((p_tot, n)) if cols_t is None else h_template(cols_t, n)
    R = np.zeros((p_tot, p_tot))
    angle: list[int] = []
    keys: list[str | None] = []
    labels: list[str] = []
    with_keys = False
    prior: dict[str, tuple[int, int, float, np.ndarray]] = {}  # key -> (part, index, τ, cov)
    i = 0
    for j, p in enumerate(parts):
        k = sizes[j]
        if cols_t is None:
            H[i:i + k, :p.H.shape[1]] = p.H
        R[i:i + k, i:i + k] = p.R
        if p.angle_rows:
            angle += [i + a for a in p.angle_rows]
        labels += p.labels
        if p.bias_keys:
            keys += p.bias_keys
            with_keys = True
        else:
            keys += (None,) * k
        if p.bias_cov is not None:
            taus_p = p.bias_tau_s
            for m, key in enumerate(distinct_keys(p.bias_keys)):
                if key not in prior:
                    prior[key] = (j, m, taus_p[m] if m < len(taus_p) else float("nan"),
                                  p.bias_cov)
        i += k
    z = np.concatenate([p.z for p in parts])
    dk = distinct_keys(keys) if with_keys else []
    if not dk:
        return _measurement(z, H, R, tuple(labels), tuple(angle), cols=cols_t)
    cov = None
    taus: tuple[float, ...] = ()
    if all(k in prior for k in dk):
        src = [prior[k] for k in dk]
        m_dk = len(dk)
        first = np.asarray(src[0][3])
        j0 = src[0][0]
        if first.ndim == 2 and min(first.shape) >= m_dk and \
                all(e[0] == j0 and e[1] == a for a, e in enumerate(src)):
            # One block gives every prior, in its own order: its leading m×m block.
            cov = np.array(first[:m_dk, :m_dk], dtype=float)
        else:
            cov = np.zeros((m_dk, m_dk))
            for a_, (ja, ma, _, bc) in enumerate(src):
                for b_, (jb, mb, _, _) in enumerate(src):
                    if ja == jb:
                        cov[a_, b_] = bc[ma, mb]
        taus = tuple(e[2] for e in src)
    return _measurement(z, H, R, tuple(labels), tuple(angle), tuple(keys), cov, taus, cols_t)

"""Measurement rows of the filter (6.26–6.29, H of 6.33, R of 6.36; raw LOPs §10.3): the LSE
position, the sensors (pressure depth, log, gyro, inclinometer) and their stacking.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from engine.filter.params import DEG, FilterParams
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
    H = np.zeros((2, N_NAV))
    H[0, IX] = H[1, IY] = 1.0
    z = np.array([x_m, y_m], dtype=float)
    if params is not None and params.coloured:
        f = params.fix_sigma_frac
        return Measurement(z, H, C * (1.0 - f), ("x_LSE", "y_LSE"), (), keys, C * f,
                           (params.fix_tau_s, params.fix_tau_s))
    return Measurement(z, H, C, ("x_LSE", "y_LSE"))


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
    """
    return nav_measurement(state, params, depth_m=depth_m, log_ms=log_ms,
                           gyro_grid_rad=gyro_grid_rad, incl_rad=incl_rad,
                           log_sigma_ms=log_sigma_ms, gyro_sigma_deg=gyro_sigma_deg)


_Row = tuple[float, float, str, tuple[int, ...]]
"""One measurement row: value, variance of its white noise, label, state columns with a 1 in H."""


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
    rows: list[_Row] = []
    if fix_xy is not None:
        if fix_cov is None:
            raise ValueError("an LSE needs its 2×2 VCV fix_cov")
        rows += [(float(fix_xy[0]), 0.0, "x_LSE", (IX,)), (float(fix_xy[1]), 0.0, "y_LSE", (IY,))]
    rows += _sensor_rows(params, depth_m, log_ms, gyro_grid_rad, incl_rad, log_sigma_ms,
                         gyro_sigma_deg)
    p = len(rows)
    H = np.zeros((p, N_NAV))
    R = np.zeros((p, p))
    for i, (_, var, _, cols) in enumerate(rows):
        for c in cols:
            H[i, c] = 1.0
        R[i, i] = var
    zz = np.array([row[0] for row in rows], dtype=float)
    labels = tuple(row[2] for row in rows)
    angle = tuple(i for i, row in enumerate(rows) if row[2] == "psi_m")
    if fix_xy is not None:
        C = np.asarray(fix_cov, dtype=float)
        if params.coloured:
            f = params.fix_sigma_frac
            R[:2, :2] = C * (1.0 - f)
            keys = (fix_keys[0], fix_keys[1]) + (None,) * (p - 2)
            return Measurement(zz, H, R, labels, angle, keys, C * f,
                               (params.fix_tau_s, params.fix_tau_s))
        R[:2, :2] = C
    return Measurement(zz, H, R, labels, angle)


def _sensor_rows(
    params: FilterParams,
    depth_m: float | None,
    log_ms: float | None,
    gyro_grid_rad: float | None,
    incl_rad: float | None,
    log_sigma_ms: float | None = None,
    gyro_sigma_deg: float | None = None,
) -> list[_Row]:
    """The rows of the sensors that gave a value, in the order z_p, v_m, ψ_m, ε_m: pressure
    depth (σ_p), log speed + log bias (σ = max(frac·v, floor), 4.19, or ``log_sigma_ms``), gyro
    GRID heading + gyro bias (σ ``params.sigma_gyro_deg`` or ``gyro_sigma_deg``), inclination +
    inclinometer bias (eqs. 6.26b–6.29)."""
    out: list[_Row] = []
    if depth_m is not None:
        out.append((depth_m, params.sigma_press_m**2, "z_p", (IZ,)))
    if log_ms is not None:
        if log_sigma_ms is None:
            var = max(params.log_sigma_frac * abs(log_ms), params.log_sigma_floor_ms) ** 2
        else:
            var = log_sigma_ms**2
        out.append((log_ms, var, "v_m", (IV, IDV)))
    if gyro_grid_rad is not None:
        sd = params.sigma_gyro_deg if gyro_sigma_deg is None else gyro_sigma_deg
        out.append((gyro_grid_rad, (sd * DEG) ** 2, "psi_m", (IPSI, IDPSI)))
    if incl_rad is not None:
        out.append((incl_rad, (params.sigma_incl_deg * DEG) ** 2, "eps_m", (IEPS, IDEPS)))
    return out


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


def stack_measurements(*parts: Measurement) -> Measurement:
    """Concatenate measurement blocks (R block-diagonal), e.g. LSE rows then sensor rows.

    Fix-error keys are concatenated per row; their prior VCVs block-diagonally (a key already
    given by an earlier block keeps that block's prior).
    """
    parts = tuple(p for p in parts if p.z.shape[0])
    if not parts:
        return Measurement(np.zeros(0), np.zeros((0, N_NAV)), np.zeros((0, 0)), ())
    n = max(p.H.shape[1] for p in parts)
    p_tot = sum(p.z.shape[0] for p in parts)
    H = np.zeros((p_tot, n))
    R = np.zeros((p_tot, p_tot))
    angle: list[int] = []
    keys: list[str | None] = []
    prior: dict[str, tuple[int, int, float, np.ndarray]] = {}  # key -> (part, index, τ, cov)
    i = 0
    for j, p in enumerate(parts):
        k = p.z.shape[0]
        H[i:i + k, :p.H.shape[1]] = p.H
        R[i:i + k, i:i + k] = p.R
        angle.extend(i + a for a in p.angle_rows)
        keys.extend(p.bias_keys if p.bias_keys else (None,) * k)
        if p.bias_cov is not None:
            for m, key in enumerate(distinct_keys(p.bias_keys)):
                tau = p.bias_tau_s[m] if m < len(p.bias_tau_s) else float("nan")
                prior.setdefault(key, (j, m, tau, p.bias_cov))
        i += k
    z = np.concatenate([p.z for p in parts])
    labels = tuple(lab for p in parts for lab in p.labels)
    if not any(k is not None for k in keys):
        return Measurement(z, H, R, labels, tuple(angle))
    dk = distinct_keys(keys)
    cov = None
    if all(k in prior for k in dk):
        cov = np.zeros((len(dk), len(dk)))
        for a_, ka in enumerate(dk):
            for b_, kb in enumerate(dk):
                (ja, ma, _, bc), (jb, mb, _, _) = prior[ka], prior[kb]
                if ja == jb:
                    cov[a_, b_] = bc[ma, mb]
    taus = tuple(prior[k][2] for k in dk) if cov is not None else ()
    return Measurement(z, H, R, labels, tuple(angle), tuple(keys), cov, taus)

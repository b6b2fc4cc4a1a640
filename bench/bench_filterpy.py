"""The engine against a plain numpy + FilterPy pipeline doing the same per-epoch LSQ and EKF.

Run with ``make bench`` (or ``python -m bench.bench_filterpy``); about 2 to 3 minutes on one free
core (``--epochs N`` / ``--rounds K`` shorten it). Needs the optional ``bench`` extra
(``pip install -e '.[bench]'``: FilterPy, which also pulls in matplotlib); without FilterPy it
prints how to install it and skips.

The plain pipeline (:func:`run_pipeline`) replays the records of ``data/DEMO.RUN`` (GPS + Decca
chain 9B Red and Green, gyro, log, inclinometer, pressure depth; data/DEMO.toml) as a
competent numpy user would write it, with the engine's model and tuning (THEORY §3–§8):

* per epoch, in the timed loop: the grid heading from the gyro (convergence, THEORY D3); the
  Decca lanes tracked like a decometer, identified again from GPS after a gap of more than
  30 s and checked against GPS for slips (one lane-count evaluation at the GPS position);
  a Gauss–Newton LSQ fix on the TM grid (THEORY §4–§5) from the filter's prediction, with the
  two GPS coordinate LOPs (σ² = 2500 m² × GPS.SE_SF) and the hyperbolic Decca LOPs in lanes
  (distances to the stations by ``pyproj.Geod.inv`` at ``pyproj`` inverse-TM positions,
  gradients from the grid geometry, A4.1–A4.3 VCV), iterated to |δx̂| < 1 m; then the unit
  variance S², its χ² test, the w-test, redundancy number and MDB of every LOP (Baarda, with
  the full C_l), the VCV scaled by S² when the fix fails its tests (as the engine's
  ``fix_fit``), the 95 % error ellipse (``numpy.linalg.eigh``) and the geodetic position;
* a FilterPy ``ExtendedKalmanFilter`` with the engine's 13 states (11 navigation states,
  THEORY §8.6, plus two Gauss–Markov fix-error states, §8.2): an update with the gyro, log and
  inclinometer (heading innovation wrapped), the non-linear prediction (overridden
  ``predict_x``) with Φ = I + FΔt and the exact (Van Loan, F² = 0) process noise, then one
  update with the LSE (coloured: R = 5 % of C_LSE, 95 % in the fix-error states) and the
  pressure depth behind the engine's 30 σ gross-error gate, its LOM (NIS) test; the first LSE
  initialises the position (THEORY D22);
* the MPP's geodetic position and 95 % ellipse, and one log line per epoch (24 numbers as
  ``repr``, like the ``.OUT``'s floats) written and flushed to a file.

Not in the timed loop: parsing ``DEMO.RUN`` (the engine's parser), the GPS datum shift and
grid projection (one vectorised ``pyproj`` call), pressure → depth, the chain's stations on the
grid and the χ² / normal quantiles; :func:`prepare` does them and its time is printed
separately. The engine's time includes all of that (it parses and converts per record) and
more that the plain pipeline does not do (the LOP tables with τ, VF and external reliability,
data snooping, the RTS smoother link, operator messages, the ``.OUT`` block with every
statistic), so the ratio engine/FilterPy is conservative.

Timing: CPU time (``time.process_time``) of the whole demo, each pipeline in a fresh process
(warm-up of 50 epochs first), alternating, median of ``ROUNDS``. Correctness (not timed): the
plain pipeline's MPP and LSE against the engine's, epoch by epoch (median / 95 % / max of the
horizontal difference in metres); :data:`AGREE_MEDIAN_M` / :data:`AGREE_P95_M` state the
tolerance, which ``tests/bench/test_filterpy_pipeline.py`` checks.
"""

from __future__ import annotations

import argparse
import math
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from itertools import islice
from pathlib import Path

import numpy as np

from engine.io.runfile import RunRecord, iter_run_file
from engine.run.config import RunConfig, load_config
from engine.run.session import Session

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "data" / "DEMO.toml"
ROUNDS = 5
WARMUP = 50
TARGET_RATIO = 2.0
AGREE_MEDIAN_M = 2.0
"""Tolerance on the median horizontal distance (m) between the plain pipeline's and the
engine's MPP (and LSE) over the demo."""
AGREE_P95_M = 10.0
"""Tolerance on the 95th percentile of that distance (m)."""
INSTALL_HINT = ("FilterPy is not installed: pip install -e '.[bench]' (or `make bench`, which "
                "does it; FilterPy pulls in matplotlib)")

KNOT_MS = 1852.0 / 3600.0
DEG = math.pi / 180.0
GPS_VAR_CA_M2 = 2500.0  # C/A coordinate variance (thesis L5564), times GPS.SE_SF
LANE_GAP_S = 30.0  # lane tracked over at most this gap, else identified again from GPS
LANE_SIGMA_MAX = 0.5 / 3.0  # GPS settles the integer lane when 3σ along the gradient < 0.5
GROSS_GATE_SIGMA = 30.0
N_STATES = 13  # x y z v ψ ε vcx vcy Δv Δψ Δε, fix-error b_e b_n (THEORY §8.6, §8.2)
MASTER_MULT = np.array([4.0, 3.0])  # f_c / f_master, Red and Green (A4.1)
SLAVE_MULT = np.array([3.0, 2.0])  # f_c / f_slave (thesis L774)
SYNC_SIGMA = np.array([0.012, 0.009])  # lanes (thesis L8338)
PSI_PA, F0_HZ, A_PSI, B_PSI = 6894.757, 40_000.0, 9750.0, 5000.0  # crystal, eq. 3.2
BETA_M_PA = 1.0 / (1000.0 * 9.80665)  # eq. 3.3


@dataclass
class Inputs:
    """What :func:`prepare` computes before the timed loop: per record (arrays of n) the time
    (s), the GPS grid position (m; NaN: none), the Red/Green fractions (lanes; NaN: none),
    gyro heading (deg), log speed (kn), inclination (deg), pressure depth (m); and the chain,
    grid, parameters and quantiles of the run."""

    t: np.ndarray
    gps_xy: np.ndarray
    frac: np.ndarray
    heading: np.ndarray
    speed: np.ndarray
    incl: np.ndarray
    depth: np.ndarray
    cm_deg: float
    proj: str
    geod_args: dict[str, float]
    st_lonlat: np.ndarray  # master, red, green (deg)
    st_xy: np.ndarray  # master, red, green (grid m)
    baseline: np.ndarray  # master–red, master–green (m)
    wavelength: np.ndarray  # λc of Red, Green (m)
    min_lanes: np.ndarray
    decca_cf: float
    gps_var: float
    dr_xy: tuple[float, float]
    current: tuple[float, float]  # set (deg), speed (kn)
    params: dict[str, float]
    chi2: dict[int, tuple[float, float]]  # dof → (α/2, 1 − α/2) quantiles
    chi2_2_95: float  # 95 % ellipse scale²
    w_crit: float
    delta0: float


def _crystal_pa(f: np.ndarray | float) -> np.ndarray | float:
    u = 1.0 - f / F0_HZ
    return PSI_PA * (A_PSI * u - B_PSI * u * u)


def prepare(cfg: RunConfig, n: int) -> Inputs:
    """Parse the first ``n`` records and precompute the shared inputs (not timed)."""
    from pyproj import Geod, Transformer
    from scipy.stats import chi2, norm

    from engine.api import load_data

    recs = [r for r in islice(iter_run_file(cfg.run_path), n) if isinstance(r, RunRecord)]
    datums, chains = load_data(cfg)
    d = datums.datum(cfg.datum)
    ell = d.ellipsoid
    chain = chains[cfg.decca.chain]
    t0 = recs[0].time

    def col(get: object) -> np.ndarray:
        return np.array([math.nan if (v := get(r)) is None else v for r in recs], float)

    cm = math.copysign(math.floor(abs(cfg.dr_lon_deg) + 0.5), cfg.dr_lon_deg)
    proj = (f"+proj=tmerc +lat_0=0 +lon_0={cm} +k=1 +x_0=0 +y_0=0 +a={ell.a_m} "
            f"+rf={ell.inv_f} +towgs84={d.dx_m},{d.dy_m},{d.dz_m} +units=m +no_defs")
    to_grid = Transformer.from_crs("+proj=longlat +datum=WGS84 +no_defs", proj, always_xy=True)
    gx, gy = to_grid.transform(col(lambda r: r.gps_lon_deg), col(lambda r: r.gps_lat_deg))
    grid = (f"+proj=tmerc +lat_0=0 +lon_0={cm} +k=1 +x_0=0 +y_0=0 +a={ell.a_m} "
            f"+rf={ell.inv_f} +units=m +no_defs")
    ll_to_grid = Transformer.from_crs(f"+proj=longlat +a={ell.a_m} +rf={ell.inv_f} +no_defs",
                                      grid, always_xy=True)
    stations = (chain.master, chain.red, chain.green)
    st_lonlat = np.array([[s.lon_deg, s.lat_deg] for s in stations])
    st_xy = np.array(ll_to_grid.transform(st_lonlat[:, 0], st_lonlat[:, 1])).T
    geod_args = {"a": ell.a_m, "rf": ell.inv_f}
    _, _, base = Geod(**geod_args).inv(st_lonlat[[0, 0], 0], st_lonlat[[0, 0], 1],
                                       st_lonlat[1:, 0], st_lonlat[1:, 1])
    wavelength = np.array([chain.speed_km_s / (m * s.freq_khz)
                           for m, s in zip(SLAVE_MULT, stations[1:], strict=True)])
    press = col(lambda r: r.press_freq_hz)
    p_ref = _crystal_pa(cfg.demo.press_ref_freq_hz)
    depth = BETA_M_PA / cfg.demo.s_weight * (_crystal_pa(press) - p_ref)
    fp = Session(cfg, history=1).context.filter_params  # the engine's tuning, read once
    params = {k: float(getattr(fp, k)) for k in (
        "sigma_a2", "sigma_current2", "turn_rate_max_deg_s", "pitch_rate_max_deg_s",
        "sigma_gyro_deg", "sigma_incl_deg", "sigma_press_m", "log_sigma_frac",
        "log_sigma_floor_ms", "fix_tau_s", "fix_sigma_frac", "bias_rw_log_ms_sqrth",
        "bias_rw_gyro_deg_sqrth", "bias_rw_incl_deg_sqrth", "dr_pos_sigma_m",
        "p0_current_sigma_ms", "p0_log_bias_ms", "p0_gyro_bias_deg", "p0_incl_bias_deg",
        "alpha")}
    alpha = cfg.lsq.reliab_interval_pct / 100.0
    return Inputs(
        t=np.array([(r.time - t0).total_seconds() for r in recs]),
        gps_xy=np.column_stack([gx, gy]),
        frac=np.column_stack([col(lambda r: r.decca[0]), col(lambda r: r.decca[1])]),
        heading=col(lambda r: r.heading_deg), speed=col(lambda r: r.speed_kn),
        incl=col(lambda r: r.incl_deg), depth=depth,
        cm_deg=cm, proj=grid, geod_args=geod_args,
        st_lonlat=st_lonlat, st_xy=st_xy, baseline=np.asarray(base), wavelength=wavelength,
        min_lanes=np.array(chain.min_lanes[:2], float), decca_cf=cfg.lsq.decca_cf,
        gps_var=GPS_VAR_CA_M2 * cfg.lsq.gps_se_sf,
        dr_xy=tuple(ll_to_grid.transform(cfg.dr_lon_deg, cfg.dr_lat_deg)),
        current=(cfg.current_set_deg, cfg.current_speed_kn), params=params,
        chi2={k: (float(chi2.ppf(params["alpha"] / 2, k)),
                  float(chi2.ppf(1 - params["alpha"] / 2, k))) for k in range(1, 11)},
        chi2_2_95=float(chi2.ppf(0.95, 2)),
        w_crit=float(norm.ppf(1 - alpha / 2)),
        delta0=float(norm.ppf(1 - alpha / 2) + norm.ppf(0.80)),
    )


def _sigma_path(d_m: np.ndarray) -> np.ndarray:
    """Sky-wave phase σ (lanes) of a path of d metres (A4.3a)."""
    h = d_m * 1e-5
    return (2.407 * h * h - 2.273 * h + 4.240) * 1e-3


def _wrap_pi(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def _nearest(n_calc: float, frac: float) -> float:
    """The total lane count with fraction ``frac`` nearest to ``n_calc``."""
    d = frac - (n_calc - math.floor(n_calc))
    return n_calc + d - math.floor(d + 0.5)


def run_pipeline(inp: Inputs, out_path: Path, start: int = 0, stop: int | None = None,
                 keep: list[tuple[float, ...]] | None = None) -> int:
    """The plain numpy + FilterPy replay of records ``start:stop`` of ``inp``, one log line per
    epoch to ``out_path``; returns the number of epochs. ``keep`` collects (LSE lat, lon, MPP
    lat, lon) per epoch (NaN: no LSE) for the agreement check."""
    from filterpy.kalman import ExtendedKalmanFilter
    from pyproj import Geod, Transformer

    p = inp.params
    geod = Geod(**inp.geod_args)
    to_ll = Transformer.from_crs(inp.proj, f"+proj=longlat +a={inp.geod_args['a']} "
                                 f"+rf={inp.geod_args['rf']} +no_defs", always_xy=True)
    st_lon = inp.st_lonlat[:, 0]
    st_lat = inp.st_lonlat[:, 1]
    st_x, st_y = inp.st_xy[:, 0], inp.st_xy[:, 1]
    lam, base, kmin, cf = inp.wavelength, inp.baseline, inp.min_lanes, inp.decca_cf
    tau, frac_c = p["fix_tau_s"], p["fix_sigma_frac"]
    # Process noise PSD of the 8 inputs driving states 3–10 (eq. 6.34, THEORY D24/D29).
    q = np.array([p["sigma_a2"], (0.5 * p["turn_rate_max_deg_s"] * DEG) ** 2,
                  (0.5 * p["pitch_rate_max_deg_s"] * DEG) ** 2, p["sigma_current2"],
                  p["sigma_current2"], p["bias_rw_log_ms_sqrth"] ** 2 / 3600.0,
                  (p["bias_rw_gyro_deg_sqrth"] * DEG) ** 2 / 3600.0,
                  (p["bias_rw_incl_deg_sqrth"] * DEG) ** 2 / 3600.0])
    M = np.zeros((11, 11))
    M[3:, 3:] = np.diag(q)
    R_gyro, R_incl = (p["sigma_gyro_deg"] * DEG) ** 2, (p["sigma_incl_deg"] * DEG) ** 2
    R_press = p["sigma_press_m"] ** 2
    H_sens = np.zeros((3, N_STATES))
    H_sens[0, 3] = H_sens[0, 8] = H_sens[1, 4] = H_sens[1, 9] = H_sens[2, 5] = H_sens[2, 10] = 1
    H_fix = np.zeros((3, N_STATES))
    H_fix[0, 0] = H_fix[0, 11] = H_fix[1, 1] = H_fix[1, 12] = H_fix[2, 2] = 1.0
    H_depth = H_fix[2:3]

    class Ekf(ExtendedKalmanFilter):
        """FilterPy's EKF with the non-linear dead-reckoning mean (eq. 6.30)."""

        dt = 1.0
        decay = 1.0

        def predict_x(self, u: object = 0) -> None:
            x, dt = self.x, self.dt
            v, psi, eps = x[3, 0], x[4, 0], x[5, 0]
            vc = v * math.cos(eps)
            x[0, 0] += (vc * math.sin(psi) + x[6, 0]) * dt
            x[1, 0] += (vc * math.cos(psi) + x[7, 0]) * dt
            x[2, 0] += v * math.sin(eps) * dt
            x[11:, 0] *= self.decay

    def h_lin(H: np.ndarray) -> tuple[object, object]:
        return (lambda x: H), (lambda x: H @ x)

    def sens_residual(z: np.ndarray, hx: np.ndarray) -> np.ndarray:
        y = z - hx
        y[1, 0] = _wrap_pi(y[1, 0])
        return y

    sens_h, sens_hx = h_lin(H_sens)
    fix_h, fix_hx = h_lin(H_fix)
    dep_h, dep_hx = h_lin(H_depth)
    kf = Ekf(dim_x=N_STATES, dim_z=3)
    fix_cov = np.zeros((2, 2))
    has_filter = has_fix = False
    track: list[tuple[float, float] | None] = [None, None]
    mpp_xy = inp.dr_xy
    lat_mpp = lon_mpp = math.nan
    stop = len(inp.t) if stop is None else stop
    t_prev = None
    with open(out_path, "w") as out:
        for k in range(start, stop):
            t = float(inp.t[k])
            dt = 1.0 if t_prev is None else t - t_prev
            t_prev = t
            # ---- sensors: grid heading (convergence at the last MPP, THEORY D3), speed, ε
            if lat_mpp == lat_mpp:
                dl = math.radians(lon_mpp - inp.cm_deg)
                gamma = math.degrees(math.atan(math.tan(dl) * math.sin(math.radians(lat_mpp))))
            else:
                gamma = 0.0
            psi = math.radians(float(inp.heading[k]) - gamma)
            v = float(inp.speed[k]) * KNOT_MS
            eps = math.radians(float(inp.incl[k]))
            depth = float(inp.depth[k])
            sv = max(p["log_sigma_frac"] * abs(v), p["log_sigma_floor_ms"])
            if not has_filter:  # start from the DR position, this record's sensors (D26 P0)
                vc = inp.current[1] * KNOT_MS
                st = math.radians(inp.current[0] - gamma)
                kf.x = np.array([[mpp_xy[0], mpp_xy[1], 0.0, v, psi % (2 * math.pi), eps,
                                  vc * math.sin(st), vc * math.cos(st), 0, 0, 0, 0, 0]], float).T
                P = np.diag([p["dr_pos_sigma_m"] ** 2, p["dr_pos_sigma_m"] ** 2, R_press,
                             sv * sv, R_gyro, R_incl, p["p0_current_sigma_ms"] ** 2,
                             p["p0_current_sigma_ms"] ** 2, p["p0_log_bias_ms"] ** 2,
                             (p["p0_gyro_bias_deg"] * DEG) ** 2,
                             (p["p0_incl_bias_deg"] * DEG) ** 2, 1.0, 1.0])
                for i, b in ((3, 8), (4, 9), (5, 10)):
                    P[i, i] += P[b, b]
                    P[i, b] = P[b, i] = -P[b, b]
                kf.P = P
                has_filter = True
            else:  # gyro, log, inclinometer update (eqs. 6.27–6.29)
                kf.update(np.array([[v], [psi], [eps]]), sens_h, sens_hx,
                          R=np.diag([sv * sv, R_gyro, R_incl]), residual=sens_residual)
                kf.x[4, 0] %= 2 * math.pi
            # ---- prediction (6.20): Φ = I + FΔt, Q exact for F² = 0 (Van Loan)
            x = kf.x[:, 0]
            vv, ps, ep = x[3], x[4], x[5]
            ce, se, cp, sp = math.cos(ep), math.sin(ep), math.cos(ps), math.sin(ps)
            F = np.zeros((11, 11))
            F[0, 3], F[0, 4], F[0, 5] = ce * sp, vv * ce * cp, -vv * se * sp
            F[1, 3], F[1, 4], F[1, 5] = ce * cp, -vv * ce * sp, -vv * se * cp
            F[2, 3], F[2, 5] = se, vv * ce
            F[0, 6] = F[1, 7] = 1.0
            FM = F @ M
            Qn = M * dt + (FM + FM.T) * (dt * dt / 2) + FM @ F.T * (dt ** 3 / 3)
            d = math.exp(-dt / tau)
            Phi = np.eye(N_STATES)
            Phi[:11, :11] += F * dt
            Phi[11, 11] = Phi[12, 12] = d
            Q = np.zeros((N_STATES, N_STATES))
            Q[:11, :11] = Qn
            Q[11:, 11:] = fix_cov * (1.0 - d * d)
            kf.F, kf.Q, kf.dt, kf.decay = Phi, Q, dt, d
            kf.predict()
            xp, yp = float(kf.x[0, 0]), float(kf.x[1, 0])
            # ---- Decca lanes: tracked; identified and slip-checked against GPS
            gxy = inp.gps_xy[k]
            have_gps = gxy[0] == gxy[0]
            fr = inp.frac[k]
            totals: list[float] = []
            pat: list[int] = []
            if fr[0] == fr[0] or fr[1] == fr[1]:
                n_gps = None
                if have_gps:
                    glon, glat = to_ll.transform(gxy[0], gxy[1])
                    _, _, dg = geod.inv(np.full(3, glon), np.full(3, glat), st_lon, st_lat)
                    n_gps = (dg[0] - dg[1:] + base) / lam + kmin
                    ch = np.hypot(gxy[0] - st_x, gxy[1] - st_y)
                    ux, uy = (gxy[0] - st_x) / ch, (gxy[1] - st_y) / ch
                    g_sig = np.hypot(ux[0] - ux[1:], uy[0] - uy[1:]) / lam * math.sqrt(inp.gps_var)
                for i in (0, 1):
                    f = float(fr[i])
                    if f != f:
                        continue
                    prev = track[i]
                    total: float | None = None
                    if prev is not None and t - prev[1] <= LANE_GAP_S:
                        total = _nearest(prev[0], f)
                    if n_gps is not None and g_sig[i] <= LANE_SIGMA_MAX:
                        expected = _nearest(float(n_gps[i]), f)
                        if total is None or round(total - expected) != 0:
                            total = expected
                    if total is None:
                        continue
                    track[i] = (total, t)
                    totals.append(total)
                    pat.append(i)
            # ---- LSQ fix: Gauss–Newton from the prediction (5.1a–g)
            m = 2 * have_gps + len(pat)
            lse = None
            if m >= 2:
                pat_a = np.array(pat, int)
                tot = np.array(totals)
                xe = np.array([xp, yp])
                for _ in range(10):
                    A = np.zeros((m, 2))
                    b = np.zeros(m)
                    Cl = np.zeros((m, m))
                    j = 0
                    if have_gps:
                        A[0, 1] = A[1, 0] = 1.0
                        b[0], b[1] = gxy[1] - xe[1], gxy[0] - xe[0]
                        Cl[0, 0] = Cl[1, 1] = inp.gps_var
                        j = 2
                    if pat:
                        lon, lat = to_ll.transform(xe[0], xe[1])
                        _, _, dd = geod.inv(np.full(3, lon), np.full(3, lat), st_lon, st_lat)
                        n_calc = (dd[0] - dd[1:] + base) / lam + kmin
                        ch = np.hypot(xe[0] - st_x, xe[1] - st_y)
                        ux, uy = (xe[0] - st_x) / ch, (xe[1] - st_y) / ch
                        A[j:, 0] = ((ux[0] - ux[1:]) / lam)[pat_a]
                        A[j:, 1] = ((uy[0] - uy[1:]) / lam)[pat_a]
                        b[j:] = tot - n_calc[pat_a]
                        s_n2 = _sigma_path(dd[0:1])[0] ** 2  # A4.1–A4.3, lanes²
                        C = np.outer(MASTER_MULT, MASTER_MULT) * (s_n2 / cf)
                        C[np.diag_indices(2)] = (MASTER_MULT ** 2 * (s_n2 + _sigma_path(base) ** 2)
                                                 + SLAVE_MULT ** 2 * _sigma_path(dd[1:]) ** 2
                                                 ) / cf + SYNC_SIGMA ** 2
                        Cl[j:, j:] = C[np.ix_(pat_a, pat_a)]
                    W = np.linalg.inv(Cl)
                    AtW = A.T @ W
                    Cx = np.linalg.inv(AtW @ A)
                    dx = Cx @ (AtW @ b)
                    xe = xe + dx
                    if np.abs(dx).max() < 1.0:
                        break
                r = m - 2
                vres = A @ dx - b
                Wv = W @ vres
                s2 = float(vres @ Wv) / r if r > 0 else math.nan
                Cv = Cl - A @ Cx @ A.T
                WCvW = W @ Cv @ W
                qd = np.sqrt(np.clip(np.diag(WCvW), 1e-300, None))
                w = Wv / qd if r > 0 else np.full(m, math.nan)
                red_num = np.diag(Cv @ W)
                mdb = inp.delta0 / qd
                scale = 1.0
                if r > 0:
                    lo, hi = inp.chi2[r]
                    fails = s2 > hi / r or bool(np.all(np.abs(w) > 2.576))
                    if fails and s2 > 1.0:
                        scale = s2
                Cf = Cx * scale
                ev, evec = np.linalg.eigh(Cf)
                ell = (math.sqrt(inp.chi2_2_95 * ev[1]), math.sqrt(inp.chi2_2_95 * ev[0]),
                       math.degrees(math.atan2(evec[0, 1], evec[1, 1])) % 180.0)
                lon_e, lat_e = to_ll.transform(xe[0], xe[1])
                lse = (float(xe[0]), float(xe[1]), Cf, lat_e, lon_e, s2, ell, w, red_num, mdb)
            # ---- filter updates: first LSE sets the position, then LSE + depth, gated
            nis = math.nan
            if lse is not None and not has_fix:
                x = kf.x
                x[0, 0], x[1, 0] = lse[0], lse[1]
                x[11:, 0] = 0.0
                P = kf.P
                P[[0, 1, 11, 12], :] = 0.0
                P[:, [0, 1, 11, 12]] = 0.0
                P[:2, :2] = lse[2]
                P[11:, 11:] = frac_c * lse[2]
                fix_cov = frac_c * lse[2]
                has_fix = True
                kf.update(np.array([[depth]]), dep_h, dep_hx, R=np.array([[R_press]]))
            elif lse is not None:
                Rf = np.zeros((3, 3))
                Rf[:2, :2] = (1.0 - frac_c) * lse[2]
                Rf[2, 2] = R_press
                yf = np.array([lse[0], lse[1]]) - (H_fix[:2] @ kf.x)[:, 0]
                Sf = H_fix[:2] @ kf.P @ H_fix[:2].T + Rf[:2, :2]
                if math.sqrt(float(yf @ np.linalg.solve(Sf, yf))) <= GROSS_GATE_SIGMA:
                    fix_cov = frac_c * lse[2]
                    kf.update(np.array([[lse[0]], [lse[1]], [depth]]), fix_h, fix_hx, R=Rf)
                    nis = (kf.y.T @ kf.SI @ kf.y).item() / 3  # LOM test (6.38–6.40)
                else:
                    kf.update(np.array([[depth]]), dep_h, dep_hx, R=np.array([[R_press]]))
            else:
                kf.update(np.array([[depth]]), dep_h, dep_hx, R=np.array([[R_press]]))
            kf.x[4, 0] %= 2 * math.pi
            lom = "" if nis != nis else (
                "reject" if nis > inp.chi2[3][1] / 3 else "accept")
            # ---- MPP: the filter's position, geodetic, with its 95 % ellipse
            xk = kf.x[:, 0]
            mpp_xy = (float(xk[0]), float(xk[1]))
            lon_mpp, lat_mpp = to_ll.transform(mpp_xy[0], mpp_xy[1])
            ev, evec = np.linalg.eigh(kf.P[:2, :2])
            a_k, b_k = math.sqrt(inp.chi2_2_95 * ev[1]), math.sqrt(inp.chi2_2_95 * ev[0])
            th_k = math.degrees(math.atan2(evec[0, 1], evec[1, 1])) % 180.0
            if lse is None:
                fields = [math.nan] * 9
            else:
                wv = list(lse[7]) + [math.nan] * (4 - m)
                fields = [lse[3], lse[4], *lse[6][:2], lse[5], *wv]
            out.write(" ".join([f"{t!r}", *(repr(float(z)) for z in (
                *fields, lat_mpp, lon_mpp, a_k, b_k, th_k, *xk[2:11])), lom]) + "\n")
            out.flush()
            if keep is not None:
                keep.append((math.nan, math.nan) if lse is None else (lse[3], lse[4]))
                keep[-1] += (lat_mpp, lon_mpp)
    return stop - start


# -------------------------------------------------------------------------------------------
# the engine side and the agreement check (not timed)

def engine_positions(cfg: RunConfig, n: int) -> np.ndarray:
    """(LSE lat, lon, MPP lat, lon) per epoch of the engine's replay of ``n`` epochs (NaN: no
    usable LSE), degrees on the working datum."""
    rows = []
    s = Session(cfg, history=1)
    try:
        for _ in range(n):
            r = s.step()
            if r is None:
                break
            fix = r.fix
            ok = fix is not None and fix.lse_ok
            rows.append((fix.lat_deg if ok else math.nan, fix.lon_deg if ok else math.nan,
                         r.mpp.lat_deg, r.mpp.lon_deg))
    finally:
        s.close()
    return np.array(rows)


def plain_positions(cfg: RunConfig, n: int) -> np.ndarray:
    """The same from :func:`run_pipeline` (its log to a temporary file)."""
    inp = prepare(cfg, n)
    keep: list[tuple[float, ...]] = []
    with tempfile.TemporaryDirectory() as tmp:
        run_pipeline(inp, Path(tmp) / "plain.log", keep=keep)
    return np.array(keep)


def horizontal_m(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance (m, local flat Earth) between (lat, lon) rows ``a`` and ``b`` (degrees)."""
    r = 6_371_000.0
    dlat = np.radians(a[:, 0] - b[:, 0])
    dlon = np.radians(a[:, 1] - b[:, 1]) * np.cos(np.radians(a[:, 0]))
    return r * np.hypot(dlat, dlon)


def agreement(cfg: RunConfig, n: int) -> dict[str, tuple[float, float, float, int]]:
    """Per estimate ("MPP", "LSE"): median, 95th percentile and maximum of the horizontal
    difference (m) between the plain pipeline and the engine, and the epochs compared."""
    eng, plain = engine_positions(cfg, n), plain_positions(cfg, n)
    k = min(len(eng), len(plain))
    out = {}
    for name, cols in (("MPP", slice(2, 4)), ("LSE", slice(0, 2))):
        d = horizontal_m(eng[:k, cols], plain[:k, cols])
        d = d[np.isfinite(d)]
        out[name] = (float(np.median(d)), float(np.percentile(d, 95)), float(d.max()), d.size)
    return out


# -------------------------------------------------------------------------------------------
# timing in fresh processes

def _child(kind: str, n: int) -> None:
    """Print the CPU seconds of one replay of ``n`` epochs by ``kind`` (after a warm-up); for
    "filterpy" also the CPU seconds of :func:`prepare`."""
    cfg = load_config(CONFIG)
    tmp = Path(tempfile.mkdtemp())
    if kind == "engine":
        def replay(k: int) -> None:
            s = Session(cfg, out_path=tmp / "E.OUT", force=True, history=1)
            try:
                s.run(max_cycles=k)
            finally:
                s.close()
        replay(WARMUP)
        t0 = time.process_time()
        replay(n)
        print(time.process_time() - t0, 0.0)
        return
    t0 = time.process_time()
    inp = prepare(cfg, n)
    t_prep = time.process_time() - t0
    run_pipeline(inp, tmp / "plain.log", stop=WARMUP)
    t0 = time.process_time()
    run_pipeline(inp, tmp / "plain.log")
    print(time.process_time() - t0, t_prep)


def _cpu(kind: str, n: int) -> tuple[float, float]:
    done = subprocess.run([sys.executable, "-m", "bench.bench_filterpy", "--child", kind,
                           "--epochs", str(n)], cwd=ROOT, capture_output=True, text=True,
                          check=True)
    a, b = done.stdout.split()[-2:]
    return float(a), float(b)


def _n_records(cfg: RunConfig, n: int | None) -> int:
    return sum(isinstance(r, RunRecord) for r in islice(iter_run_file(cfg.run_path), n))


def main(argv: list[str] | None = None) -> None:
    """Print epochs/s of the engine and of the plain pipeline, their ratio and the agreement."""
    ap = argparse.ArgumentParser(prog="python -m bench.bench_filterpy")
    ap.add_argument("--epochs", type=int, default=None, help="first N epochs (default: all)")
    ap.add_argument("--rounds", type=int, default=ROUNDS)
    ap.add_argument("--child", choices=("engine", "filterpy"), help=argparse.SUPPRESS)
    args = ap.parse_args(sys.argv[1:] if argv is None and __name__ == "__main__" else argv or [])
    try:
        import filterpy  # noqa: F401
    except ImportError:
        print(f"FilterPy comparison skipped: {INSTALL_HINT}")
        return
    cfg = load_config(CONFIG)
    n = _n_records(cfg, args.epochs)
    if args.child:
        _child(args.child, n)
        return
    print(f"Engine vs plain numpy + FilterPy pipeline: {n} epochs of data/DEMO.RUN "
          f"(GPS + Decca 9B + gyro/log/incl/pressure), CPU time, fresh processes alternating, "
          f"median of {args.rounds}")
    times: dict[str, list[float]] = {"engine": [], "filterpy": []}
    prep: list[float] = []
    for _ in range(args.rounds):
        for kind in times:
            t, tp = _cpu(kind, n)
            times[kind].append(t)
            if kind == "filterpy":
                prep.append(tp)
    t_eng = statistics.median(times["engine"])
    t_fp = statistics.median(times["filterpy"])
    t_prep = statistics.median(prep)
    print(f"  engine (Session.run, .OUT written)        : {n / t_eng:7.0f} epochs/s "
          f"({t_eng / n * 1e6:6.1f} µs/epoch)")
    print(f"  numpy + FilterPy (per-epoch LSQ + EKF, log): {n / t_fp:7.0f} epochs/s "
          f"({t_fp / n * 1e6:6.1f} µs/epoch; + {t_prep / n * 1e6:.1f} µs/epoch untimed "
          f"parse/geodesy)")
    ratio = t_fp / t_eng
    ratio_all = (t_fp + t_prep) / t_eng
    print(f"  ratio engine/FilterPy                     : {ratio:5.2f}  (target ≥ "
          f"{TARGET_RATIO:.0f}; {ratio_all:.2f} counting its parse/geodesy) "
          f"{'MET' if ratio >= TARGET_RATIO else 'NOT MET'}; the engine needs ≥ "
          f"{TARGET_RATIO * n / t_fp:.0f} epochs/s")
    agree = agreement(cfg, n)
    for name, (med, p95, mx, k) in agree.items():
        ok = med <= AGREE_MEDIAN_M and p95 <= AGREE_P95_M
        print(f"  {name} plain − engine over {k} epochs: median {med:.2f} m, 95 % {p95:.2f} m, "
              f"max {mx:.1f} m (tolerance {AGREE_MEDIAN_M:g} / {AGREE_P95_M:g} m: "
              f"{'ok' if ok else 'EXCEEDED'})")


if __name__ == "__main__":
    main()

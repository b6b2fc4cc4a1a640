"""The filter's per-epoch shortcuts (issue 14) give bit for bit what the code they replaced gave.

The references below are the engine's former measurement, update and prediction code, kept
verbatim apart from names (engine 9578da6): one numpy call per step, H built row by row, Φ and
Q_d built afresh every step. The hot path now builds the same arrays from cached templates
(H, Φ's constant part, Γ√q's constant rows, e^{−Δt/τ}), fewer numpy calls and bare result
instances; every BLAS/LAPACK call is the same call on the same operands, so the results must
agree to the engine's tolerance contract (tests.tolerance; bit for bit where no compiled
kernel runs), over many random cases.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import engine.filter.kalman as kf
from engine.filter.lazy_scipy import blas, lapack
from engine.filter.measurements import Measurement, distinct_keys
from engine.filter.model import _phi, propagate_mean
from engine.filter.params import FilterParams, symmetrised
from engine.filter.state import IPSI, N_NAV, FilterState, add_fix_states
from engine.filter.update import lom_bounds
from engine.geodesy.angles import wrap_2pi, wrap_pi
from tests.tolerance import close

# --------------------------------------------------------------------------- references


def ref_noise(Phi: np.ndarray, dt: float, params: FilterParams) -> np.ndarray:
    c = dt if params.q_mode == "thesis" else math.sqrt(dt)
    Gs = params._g8sq * c
    Gs[:3] = Phi[:3, 3:] * (params._sq * (0.5 * c))
    Q = Gs.dot(Gs.T)
    if params.q_mode == "vanloan":
        V = Phi[:3, 3:] * (params._sq * math.sqrt(dt / 12.0))
        Q[:3, :3] += V.dot(V.T)
    return Q


def ref_predict(state: FilterState, dt: float,
                params: FilterParams) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x, P, full Φ) of the former ``_predict(..., want_phi=True)``."""
    x, P = state.x, state.P
    Phi = _phi(x, dt)
    Qd = ref_noise(Phi, dt, params)
    xn = propagate_mean(x, dt)
    if not state.fix_states:
        Pn = Phi.dot(P).dot(Phi.T)
        Pn += Qd
        Pn = Pn + Pn.T
        Pn *= 0.5
        return xn, Pn, Phi
    n = state.n
    d = np.exp(-dt / np.asarray(state.fix_tau_s))
    dd = d[:, None] * d[None, :]
    xn[N_NAV:] = x[N_NAV:] * d
    Pn = np.empty((n, n))
    Pnn = Phi.dot(P[:N_NAV, :N_NAV]).dot(Phi.T)
    Pnn += Qd
    Pn[:N_NAV, :N_NAV] = Pnn
    Pnb = Phi.dot(P[:N_NAV, N_NAV:]) * d
    Pn[:N_NAV, N_NAV:] = Pnb
    Pn[N_NAV:, :N_NAV] = Pnb.T
    Pn[N_NAV:, N_NAV:] = P[N_NAV:, N_NAV:] * dd + state.fix_cov * (1.0 - dd)
    Pn = Pn + Pn.T
    Pn *= 0.5
    full = np.zeros((n, n))
    full[:N_NAV, :N_NAV] = Phi
    for i, di in enumerate(d.tolist(), start=N_NAV):
        full[i, i] = di
    return xn, Pn, full


def ref_with_fix_cov(state: FilterState, keys: tuple[str, ...], cov: np.ndarray) -> np.ndarray:
    """The former ``FilterState.with_fix_cov``'s new ``fix_cov``."""
    C = np.asarray(cov, dtype=float)
    C = 0.5 * (C + C.T)
    if tuple(keys) == state.fix_states:
        return C
    idx = [state.fix_states.index(k) for k in keys]
    fc = np.array(state.fix_cov)
    fc[idx, :] = 0.0
    fc[:, idx] = 0.0
    fc[np.ix_(idx, idx)] = C
    return fc


def ref_full_width(state: FilterState, rows: Measurement,
                   params: FilterParams) -> tuple[FilterState, np.ndarray]:
    if rows.bias_keys:
        keys = rows.bias_keys
        dk = distinct_keys(keys)
        missing = [i for i, k in enumerate(dk) if k not in state.fix_states]
        if missing:
            C = np.asarray(rows.bias_cov, dtype=float)[np.ix_(missing, missing)]
            taus = [rows.bias_tau_s[i] if i < len(rows.bias_tau_s) else params.fix_tau_s
                    for i in missing]
            state = add_fix_states(state, [dk[i] for i in missing], C, params, taus)
        if rows.bias_cov is not None and len(missing) < len(dk):
            fc = ref_with_fix_cov(state, tuple(dk), rows.bias_cov)
            state = FilterState(state.t, state.x, state.P, state.fix_states, state.fix_tau_s, fc)
        H = np.zeros((rows.z.shape[0], state.n))
        H[:, :rows.H.shape[1]] = rows.H
        for i, k in enumerate(keys):
            if k is not None:
                H[i, N_NAV + state.fix_states.index(k)] = 1.0
        return state, H
    H = rows.H
    if H.shape[1] < state.n:
        Hp = np.zeros((H.shape[0], state.n))
        Hp[:, :H.shape[1]] = H
        return state, Hp
    return state, H


def ref_update(state: FilterState, rows: Measurement, params: FilterParams) -> dict[str, object]:
    """The former ``update``'s outputs (LOM bounds as it computed them)."""
    p = rows.z.shape[0]
    state, H = ref_full_width(state, rows, params)
    x, P, R = state.x, state.P, rows.R
    v = rows.z - H.dot(x)
    for i in rows.angle_rows:
        v[i] = wrap_pi(v[i])
    HP = H.dot(P)
    S = HP.dot(H.T)
    S += R
    L, info = lapack.dpotrf(S, lower=1, clean=1)
    assert info == 0
    n = HP.shape[1]
    B = np.zeros((p, n + 1 + p), order="F")
    B[:, :n] = HP
    B[:, n] = v
    B[:, n + 1:] = np.eye(p)
    Y = blas.dtrsm(1.0, L, B, lower=1)
    LiHPt, w, Li = Y[:, :n].T, Y[:, n], Y[:, n + 1:]
    K = LiHPt.dot(Li)
    xn = x + LiHPt.dot(w)
    xn[IPSI] = wrap_2pi(xn[IPSI])
    if params.joseph:
        A = np.eye(n) - K.dot(H)
        Pn = A.dot(P).dot(A.T)
        Pn += K.dot(R).dot(K.T)
    else:
        Pn = P - K.dot(HP)
    Pn = Pn + Pn.T
    Pn *= 0.5
    nis = float(w.dot(w))
    lo, hi = lom_bounds(p, params.alpha)
    lt = Li.T
    t = lt.dot(w) / np.sqrt(np.add.reduce(lt * lt, axis=1))
    return {"x": xn, "P": Pn, "fix_cov": state.fix_cov, "fix_states": state.fix_states,
            "innovation": v, "S": S, "K": K, "l_inv": Li, "w": w, "ls_t": t,
            "lom": (nis / p, lo / p, hi / p)}


def ref_nav_rows(params: FilterParams, fix_xy: tuple[float, float] | None,
                 fix_cov: np.ndarray | None, sensors: dict[str, float]) -> Measurement:
    """The former ``nav_measurement`` (rows x, y, z_p, v_m, ψ_m, ε_m; H row by row)."""
    rows: list[tuple[float, float, str, tuple[int, ...]]] = []
    if fix_xy is not None:
        rows += [(float(fix_xy[0]), 0.0, "x_LSE", (kf.IX,)),
                 (float(fix_xy[1]), 0.0, "y_LSE", (kf.IY,))]
    if "depth_m" in sensors:
        rows.append((sensors["depth_m"], params.sigma_press_m**2, "z_p", (kf.IZ,)))
    if "log_ms" in sensors:
        lm = sensors["log_ms"]
        var = max(params.log_sigma_frac * abs(lm), params.log_sigma_floor_ms) ** 2
        rows.append((lm, var, "v_m", (kf.IV, kf.IDV)))
    if "gyro_grid_rad" in sensors:
        rows.append((sensors["gyro_grid_rad"], (params.sigma_gyro_deg * kf.DEG) ** 2, "psi_m",
                     (kf.IPSI, kf.IDPSI)))
    if "incl_rad" in sensors:
        rows.append((sensors["incl_rad"], (params.sigma_incl_deg * kf.DEG) ** 2, "eps_m",
                     (kf.IEPS, kf.IDEPS)))
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
            keys = ("fix_e", "fix_n") + (None,) * (p - 2)
            return Measurement(zz, H, R, labels, angle, keys, C * f,
                               (params.fix_tau_s, params.fix_tau_s))
        R[:2, :2] = C
    return Measurement(zz, H, R, labels, angle)


def ref_stack(*parts: Measurement) -> Measurement:
    """The former ``stack_measurements``."""
    parts = tuple(p for p in parts if p.z.shape[0])
    n = max(p.H.shape[1] for p in parts)
    p_tot = sum(p.z.shape[0] for p in parts)
    H = np.zeros((p_tot, n))
    R = np.zeros((p_tot, p_tot))
    angle: list[int] = []
    keys: list[str | None] = []
    prior: dict[str, tuple[int, int, float, np.ndarray]] = {}
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


# --------------------------------------------------------------------------- helpers


def same(a: object, b: object) -> bool:
    """Equal to the engine's tolerance contract (tests.tolerance: arrays by dtype and shape,
    values within 1e-9 of the array's largest entry; NaN equal to NaN): the compiled kernels
    give the former code's numbers to rounding, not bit for bit."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return not close(np.asarray(a), np.asarray(b))
    if isinstance(a, float) and isinstance(b, float):
        return not close(a, b)
    return a == b


def same_measurement(a: Measurement, b: Measurement) -> bool:
    return all(same(getattr(a, f), getattr(b, f)) for f in
               ("z", "H", "R", "labels", "angle_rows", "bias_keys", "bias_tau_s")) and \
        (a.bias_cov is None) == (b.bias_cov is None) and \
        (a.bias_cov is None or same(a.bias_cov, b.bias_cov))


def random_state(rng: np.random.Generator, params: FilterParams, fix: int) -> FilterState:
    x = np.concatenate([rng.normal(0.0, 1e3, 3), [abs(rng.normal(3.0, 2.0))],
                        [rng.uniform(0.0, 2 * math.pi)], rng.normal(0.0, 0.05, 1),
                        rng.normal(0.0, 0.3, 2), rng.normal(0.0, 0.01, 3)])
    A = rng.normal(size=(N_NAV, N_NAV)) * rng.uniform(0.01, 10.0, N_NAV)
    P = A @ A.T + np.eye(N_NAV) * 1e-3
    s = FilterState(float(rng.uniform(0, 1e4)), x, P)
    if fix:
        keys = ("fix_e", "fix_n", "lop_b")[:fix]
        B = rng.normal(size=(fix, fix)) * 5.0
        s = add_fix_states(s, keys, B @ B.T + np.eye(fix), params,
                           tuple(rng.choice([180.0, 240.0, 1800.0], fix)))
        xs = np.array(s.x)
        xs[N_NAV:] = rng.normal(0.0, 3.0, fix)
        G = rng.normal(size=(s.n, s.n))
        s = FilterState(s.t, xs, s.P + 0.01 * (G @ G.T), s.fix_states, s.fix_tau_s, s.fix_cov)
    return s


PARAMS = [FilterParams(), FilterParams(coloured=True), FilterParams(q_mode="thesis"),
          FilterParams(q_mode="psd", joseph=False, coloured=True, bias_noise=True),
          FilterParams(coloured=True, fix_tau_s=1800.0, fix_sigma_frac=0.99, p0="physical")]


# --------------------------------------------------------------------------- tests


@pytest.mark.parametrize("seed", range(40))
def test_predict_is_the_former_code_bit_for_bit(seed: int) -> None:
    rng = np.random.default_rng(seed)
    params = PARAMS[seed % len(PARAMS)]
    s = random_state(rng, params, fix=seed % 3)
    for dt in (1.0, 1.0, 0.5, float(rng.uniform(0.1, 30.0)), 1.0):  # repeats use the memo
        new, phi = kf.predict_step(s, dt, params)
        x, P, full = ref_predict(s, dt, params)
        assert same(new.x, x) and same(new.P, P) and same(phi, full)
        assert same(kf.predict(s, dt, params).P, P)
        assert same(kf.discrete_noise(s.x, dt, params), ref_noise(_phi(s.x, dt), dt, params))
        s = new


@pytest.mark.parametrize("seed", range(60))
def test_update_and_measurements_are_the_former_code_bit_for_bit(seed: int) -> None:
    rng = np.random.default_rng(1000 + seed)
    params = PARAMS[seed % len(PARAMS)]
    s = random_state(rng, params, fix=seed % 3 if params.coloured else 0)
    names = ("depth_m", "log_ms", "gyro_grid_rad", "incl_rad")
    values = {"depth_m": float(rng.normal(20.0, 5.0)), "log_ms": float(rng.normal(3.0, 1.0)),
              "gyro_grid_rad": float(rng.uniform(0.0, 2 * math.pi)),
              "incl_rad": float(rng.normal(0.0, 0.05))}
    sensors = {k: values[k] for k in names if rng.random() < 0.6}
    C = rng.normal(size=(2, 2)) * rng.uniform(1.0, 30.0)
    C = C @ C.T + np.eye(2)
    fix_xy = (float(s.x[0] + rng.normal(0, 20)), float(s.x[1] + rng.normal(0, 20)))
    cases: list[tuple[Measurement, Measurement]] = []
    if sensors:
        cases.append((kf.sensor_measurement(s, params=params, **sensors),
                      ref_nav_rows(params, None, None, sensors)))
    cases.append((kf.nav_measurement(s, params, fix_xy=fix_xy, fix_cov=C, **sensors),
                  ref_nav_rows(params, fix_xy, C, sensors)))
    lse = kf.lse_measurement(*fix_xy, C, params)
    lse_ref = ref_nav_rows(params, fix_xy, C, {})
    assert same_measurement(lse, lse_ref)
    depth = kf.sensor_measurement(s, depth_m=values["depth_m"], params=params)
    depth_ref = ref_nav_rows(params, None, None, {"depth_m": values["depth_m"]})
    cases.append((kf.stack_measurements(depth, lse), ref_stack(depth_ref, lse_ref)))
    lop = kf.lop_measurement(rng.normal(size=(3, 2)), rng.normal(0, 10, 3), s.x[:2],
                             np.diag(rng.uniform(1.0, 50.0, 3)),
                             fix_keys=("lop_b", None, "lop_b"), bias_cov=np.array([[25.0]]),
                             bias_tau_s=(180.0,))
    cases.append((kf.stack_measurements(lop, lse), ref_stack(lop, lse_ref)))
    cases.append((kf.stack_measurements(depth, lop), ref_stack(depth_ref, lop)))
    for fast, ref in cases:
        assert same_measurement(fast, ref)
        u = kf.update(s, fast, params)
        r = ref_update(s, ref, params)
        assert u.state.fix_states == r["fix_states"]
        for key, got in (("x", u.state.x), ("P", u.state.P), ("fix_cov", u.state.fix_cov),
                         ("innovation", u.innovation), ("S", u.S), ("K", u.K),
                         ("l_inv", u.ls.l_inv), ("w", u.ls.w), ("ls_t", u.ls.t)):
            assert same(got, r[key]), key
        assert same(np.array((u.lom.t, u.lom.lower, u.lom.upper)), np.array(r["lom"]))
        assert u.labels == ref.labels and u.lom.dof == ref.z.shape[0]
        assert same(kf.innovation_distance(u, slice(1, None)),
                    kf.innovation_distance(kf.UpdateResult(u.state, np.array(u.innovation),
                                                           np.array(u.S), u.K, u.labels, u.lom,
                                                           u.ls), slice(1, None)))


@pytest.mark.parametrize("seed", range(20))
def test_symmetrised_and_with_fix_cov_are_the_numpy_expressions(seed: int) -> None:
    rng = np.random.default_rng(2000 + seed)
    n = int(rng.integers(1, 16))
    P = rng.normal(size=(n, n)) * 10.0 ** rng.uniform(-8, 8, (n, n))
    expected = P + P.T
    expected *= 0.5
    assert same(symmetrised(P), expected)
    params = FilterParams(coloured=True)
    s = random_state(rng, params, fix=3)
    C = rng.normal(size=(2, 2)) * 10.0 ** rng.uniform(-3, 3, (2, 2))
    for keys in (("fix_e", "fix_n"), ("lop_b", "fix_e")):
        assert same(s.with_fix_cov(keys, C).fix_cov, ref_with_fix_cov(s, keys, C))
    s2 = FilterState(s.t, s.x[:13], s.P[:13, :13], s.fix_states[:2], s.fix_tau_s[:2],
                     s.fix_cov[:2, :2])
    new = s2.with_fix_cov(("fix_e", "fix_n"), C)
    assert same(new.fix_cov, ref_with_fix_cov(s2, ("fix_e", "fix_n"), C))
    assert new.x is s2.x and new.P is s2.P and not new.fix_cov.flags.writeable


def test_templates_are_shared_read_only_and_the_memo_is_bounded() -> None:
    p = FilterParams()
    s = kf.init_state(0.0, 0.0, 0.0, 0.0, 6.0, 0.5, 0.0, 0.0, 0.0, p)
    a = kf.sensor_measurement(s, log_ms=6.5, gyro_grid_rad=0.52, params=p)
    b = kf.sensor_measurement(s, log_ms=6.0, gyro_grid_rad=0.50, params=p)
    assert a.H is b.H and not a.H.flags.writeable
    for k in range(100):  # a log with jittering time stamps
        s = kf.predict(s, 1.0 + k * 1e-3, p)
    assert len(p._memo) <= 16
    assert p == FilterParams() and hash(p) == hash(FilterParams())

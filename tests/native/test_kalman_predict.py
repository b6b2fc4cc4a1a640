"""The compiled time update, estimate and rows (engine/native/kalman_predict.c, through
engine.fast.filter) agree with the reference (engine.filter.predict, estimate, measurements)
to the tolerance contract, on the states a replay produces and on generated ones around them;
with ``UVNAV_PURE=1`` the run takes the reference's parts and loads no kernel."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import engine.filter.estimate as est
import engine.filter.measurements as ms
import engine.filter.predict as pr
import engine.run.cycle as cycle_mod
import engine.run.session as session_mod
from engine import native
from engine.fast import filter as ff
from engine.filter.measurements import Measurement
from engine.filter.params import FilterParams
from engine.filter.state import N_NAV, FilterState
from engine.geodesy.ellipsoid import WGS84
from engine.geodesy.tmgrid import TMGrid
from engine.run.parts import REFERENCE, positional
from tests.native.replay import record_parts, replay_patched
from tests.paths import DATA, ROOT
from tests.tolerance import assert_close

KERNEL = ff.KP
needs_kernel = pytest.mark.skipif(KERNEL is None, reason=f"kernel not used: "
                                  f"{native.status('kalman_predict')}")


def _same(a: tuple[FilterState, np.ndarray], b: tuple[FilterState, np.ndarray]) -> None:
    """The same results to the tolerance contract (tests.tolerance): t, x, P, Φ (values within
    it; shapes, dtype identical), the same metadata, read-only arrays."""
    (sa, pa), (sb, pb) = a, b
    assert type(sa) is type(sb) is FilterState and sa.t == sb.t
    for u, v in ((sa.x, sb.x), (sa.P, sb.P), (pa, pb)):
        assert u.shape == v.shape and u.dtype == v.dtype == np.float64
        assert_close(u, v)
    assert sa.fix_states == sb.fix_states and sa.fix_tau_s == sb.fix_tau_s
    assert_close(sa.fix_cov, sb.fix_cov)
    assert not sa.x.flags.writeable and not sa.P.flags.writeable


@pytest.fixture(scope="module")
def replay_steps() -> list[tuple[FilterState, float, FilterParams]]:
    """(state, Δt, params) of every prediction of 200 demo epochs and the thesis sample."""
    steps: list[tuple[FilterState, float, FilterParams]] = []

    def wrap(real):  # type: ignore[no-untyped-def]
        def recording(state, dt, params, source, grid):  # type: ignore[no-untyped-def]
            steps.append((state, dt, params))
            return real(state, dt, params, source, grid)
        return recording

    for name, n in (("DEMO.toml", 200), ("920917_1.toml", None)):
        replay_patched([(session_mod, "choose_parts", record_parts(predict_estimate=wrap))], n,
                       DATA / name)
    return steps


@needs_kernel
def test_replay_predictions_agree(replay_steps):
    assert len(replay_steps) > 150
    assert {s.n for s, _, _ in replay_steps} == {11, 13}
    for state, dt, params in replay_steps:
        got = ff.predict_step(state, dt, params)
        _same(got, pr.predict_step(state, dt, params))
        assert list(vars(got[0])) == list(vars(state))
        assert got[0].fix_cov is state.fix_cov and got[0].t == state.t + dt


@needs_kernel
def test_predict_estimate_is_predict_and_estimate(replay_steps):
    """fast predict_estimate (one kernel call on a compiled grid) is the reference's time
    update and estimate; on the reference grid (no packed grid: position declines) and at
    Δt 0 too."""
    from engine.fast.geodesy import FastTMGrid

    for grid in (FastTMGrid(WGS84.ellipsoid, 3.0), TMGrid(WGS84.ellipsoid, 3.0)):
        for state, dt, params in replay_steps[:60]:
            got = ff.predict_estimate(state, dt, params, "KF", grid)
            ref = est.predict_estimate(state, dt, params, "KF", grid)
            _same(got[:2], ref[:2])
            _same_estimate(got[2], ref[2])
        state, dt, params = replay_steps[0]
        same = ff.predict_estimate(state, 0.0, params, "KF", grid)
        assert same[0] is state
        _same_estimate(same[2], est.filter_estimate("KF", grid, state))


@needs_kernel
def test_the_kernel_is_what_runs(replay_steps, monkeypatch: pytest.MonkeyPatch):
    """The kernel answers (not None) for the replay's states: the reference is not called."""
    def boom(*a: object) -> None:
        raise AssertionError("reference path taken")

    monkeypatch.setattr(pr, "predict_step", boom)
    monkeypatch.setattr(est, "filter_estimate", boom)
    from engine.fast.geodesy import FastTMGrid

    grid = FastTMGrid(WGS84.ellipsoid, 3.0)
    for state, dt, params in replay_steps[:20]:
        ff.predict_step(state, dt, params)
        ff.predict_estimate(state, dt, params, "KF", grid)


def _spd(rng_vals: list[float], n: int, sym: bool) -> np.ndarray:
    a = np.array(rng_vals[: n * n]).reshape(n, n)
    return a.dot(a.T) + np.eye(n) if sym else a


_PARAMS = {mode: [FilterParams(q_mode=mode),
                  FilterParams(q_mode=mode, bias_noise=True, hold_course=True, q_scale=2.5)]
           for mode in ("vanloan", "psd", "thesis")}


@needs_kernel
@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    m=st.sampled_from([0, 0, 1, 2, 2, 3, 5]),
    x=st.lists(st.floats(-1e4, 1e4, allow_nan=False), min_size=16, max_size=16),
    p=st.lists(st.floats(-3.0, 3.0, allow_nan=False), min_size=256, max_size=256),
    dt=st.one_of(st.just(1.0), st.floats(1e-3, 30.0)),
    mode=st.sampled_from(["vanloan", "psd", "thesis"]),
    which=st.integers(0, 1),
    sym=st.booleans(),
    fortran=st.booleans(),
    taus=st.lists(st.floats(1.0, 3600.0), min_size=5, max_size=5),
)
def test_generated_predictions_agree(m, x, p, dt, mode, which, sym, fortran, taus):
    n = N_NAV + m
    xs = np.array(x[:n])
    xs[4] = xs[4] % 6.3  # ψ, ε as angles (rad)
    xs[5] = xs[5] * 1e-4
    P = _spd(p, n, sym)
    state = FilterState(0.0, xs, P, tuple(f"k{i}" for i in range(m)), tuple(taus[:m]),
                        _spd(p[::-1], m, True) if m else np.zeros((0, 0)))
    if fortran:  # an F-ordered P
        Pf = np.asfortranarray(state.P)
        Pf.flags.writeable = False
        object.__setattr__(state, "P", Pf)
    params = _PARAMS[mode][which]
    _same(ff.predict_step(state, dt, params), pr.predict_step(state, dt, params))


@needs_kernel
def test_inputs_it_does_not_cover_go_to_the_reference():
    """More states than the kernel's stack buffers: the kernel declines (None) and the fast
    predict_step gives the reference's result."""
    m = 30
    n = N_NAV + m
    state = FilterState(0.0, np.arange(n) * 0.1, np.eye(n), tuple(f"k{i}" for i in range(m)),
                        (240.0,) * m, np.eye(m))
    params = FilterParams()
    c = pr.step_constants(params, 1.0)
    assert KERNEL.predict(state.x, state.P, c, c.fix_decay(state.fix_tau_s), state.fix_cov,
                          True) is None
    _same(ff.predict_step(state, 1.0, params), pr.predict_step(state, 1.0, params))


def test_pure_env_runs_the_reference_and_loads_no_kernel():
    """UVNAV_PURE=1: a run takes every part of the reference, and no kernel is imported."""
    code = ("import sys; from engine.run.parts import REFERENCE, choose; "
            "assert choose() == REFERENCE; "
            "assert not [m for m in sys.modules if m.startswith('engine.native.')], "
            "sorted(sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                          text=True, timeout=120, env={**__import__("os").environ,
                                                       native.PURE_ENV: "1"})
    assert done.returncode == 0, done.stderr


def test_the_filter_knows_no_kernel():
    """Importing the filter and the cycle loads neither the filter's kernels nor the fast room:
    the reference knows none (the run loop chooses its parts)."""
    code = ("import sys, engine.filter.kalman, engine.filter.estimate, engine.run.cycle; "
            "print(sorted(m for m in sys.modules if m.startswith(('engine.native.kalman', "
            "'engine.fast'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=ROOT, timeout=120)
    assert out.stdout.split() == ["[]"]


# ---- measurement rows (engine.filter.measurements): the compiled LSE rows, the same arrays ----


def _same_meas(a: Measurement, b: Measurement) -> None:
    """Same z, H, R, prior (values, shape, dtype) and the same labels, angle rows, keys, τ and
    template columns."""
    for f in ("z", "H", "R", "bias_cov"):
        u, v = getattr(a, f), getattr(b, f)
        if u is None or v is None:
            assert u is v, f
            continue
        assert u.shape == v.shape and u.dtype == v.dtype, f
        assert_close(u, v)
    for f in ("labels", "angle_rows", "bias_keys", "bias_tau_s", "_cols"):
        u, v = getattr(a, f), getattr(b, f)
        assert u == v and type(u) is type(v), (f, u, v)
    assert type(a) is type(b) and list(vars(a)) == list(vars(b))


def test_depth_sensor_rows_is_sensor_rows() -> None:
    """depth_sensor_rows(d, params) is sensor_rows(d, None, None, None, params): the same
    values, variances (bits) and the same layout object."""
    for params in (FilterParams(), FilterParams(sigma_press_m=0.37)):
        for d in (0.0, 12.5, 1e-7, 3021.25):
            got = ms.depth_sensor_rows(d, params)
            ref = ms.sensor_rows(d, None, None, None, params)
            assert got[0] == ref[0] and [v.hex() for v in got[1]] == [v.hex() for v in ref[1]]
            assert got[2] is ref[2]


_opt_float = st.one_of(st.none(), st.floats(-50.0, 50.0, allow_nan=False))


@settings(max_examples=100, deadline=None)
@given(depth=_opt_float, log=_opt_float, gyro=_opt_float, incl=_opt_float,
       log_sigma=_opt_float, gyro_sigma=_opt_float, coloured=st.booleans())
def test_sensor_rows_are_the_rows_built_one_by_one(depth, log, gyro, incl, log_sigma,
                                                   gyro_sigma, coloured):
    """sensor_measurement (remembered layouts and variances) is nav_measurement without an LSE
    (each row appended in turn)."""
    params = FilterParams(coloured=coloured)
    state = FilterState(0.0, np.zeros(11), np.eye(11))
    kw = dict(depth_m=depth, log_ms=log, gyro_grid_rad=gyro, incl_rad=incl, params=params,
              log_sigma_ms=log_sigma, gyro_sigma_deg=gyro_sigma)
    _same_meas(ms.sensor_measurement(state, **kw), ms.nav_measurement(state, **kw))


@settings(max_examples=100, deadline=None)
@given(x=st.floats(-1e7, 1e7), y=st.floats(-1e7, 1e7),
       c2=st.lists(st.floats(-1e6, 1e6), min_size=4, max_size=4), frac=st.floats(0.0, 0.99),
       coloured=st.booleans(), layout=st.sampled_from(["C", "F", "f32", "list", "np"]))
def test_lse_rows_are_the_same(x, y, c2, frac, coloured, layout):
    """The fast LSE rows (compiled where the kernel takes the inputs) are the reference's."""
    params = FilterParams(coloured=coloured, fix_sigma_frac=frac)
    C = np.array(c2).reshape(2, 2)
    C2 = {"C": C, "F": np.asfortranarray(C), "f32": C.astype(np.float32),
          "list": C.tolist(), "np": C}[layout]
    xs = (np.float64(x), np.float64(y)) if layout == "np" else (x, y)
    _same_meas(ff.lse_measurement(*xs, C2, params), ms.lse_measurement(*xs, C2, params))
    _same_meas(ff.lse_measurement(*xs, C2), ms.lse_measurement(*xs, C2))


@needs_kernel
def test_sym2_is_with_fix_cov():
    """sym2 (the fix-error VCV the fast update takes) is FilterState.with_fix_cov's array:
    the same values, read-only; anything but a float64 2×2 is declined."""
    rng = np.random.default_rng(3)
    state = FilterState(0.0, np.zeros(13), np.eye(13), ("fix_e", "fix_n"), (240.0, 240.0),
                        np.eye(2))
    for C in (rng.normal(size=(2, 2)) * 1e3, np.asfortranarray(rng.normal(size=(2, 2))),
              rng.normal(size=(4, 4))[::2, ::2], np.array([[np.inf, 1.0], [np.nan, -0.0]])):
        got = KERNEL.sym2(C)
        assert_close(got, state.with_fix_cov(("fix_e", "fix_n"), C).fix_cov)
        assert not got.flags.writeable
    for bad in (np.zeros((3, 3)), np.zeros((2, 2), dtype=np.float32), [[1.0, 0.0], [0.0, 1.0]]):
        assert KERNEL.sym2(bad) is None


# --------------------------------------------------------------------------------- estimates


def _same_estimate(a: object, b: object) -> None:
    """Two PositionEstimates with the same floats and arrays (to the tolerance contract),
    read-only VCVs and the same ellipse (or none)."""
    assert type(a) is type(b) is est.PositionEstimate
    assert a.source == b.source  # type: ignore[attr-defined]
    for f in ("lat_deg", "lon_deg", "x_m", "y_m", "depth_m"):
        assert_close(getattr(a, f), getattr(b, f), 1e-6)
    ca, cb = a.cov, b.cov  # type: ignore[attr-defined]
    assert_close(ca, cb)
    assert not ca.flags.writeable and not cb.flags.writeable
    ea, eb = a.ellipse, b.ellipse  # type: ignore[attr-defined]
    assert (ea is None) == (eb is None)
    if ea is not None:
        assert list(ea.__dict__) == list(eb.__dict__)
        for k, va in ea.__dict__.items():
            if k in ("eigenvectors", "phi_deg", "az_deg"):  # the axes' sign is free
                continue
            assert_close(va, eb.__dict__[k])
        assert not ea.eigenvectors.flags.writeable and not eb.eigenvectors.flags.writeable
        assert_close(ea.az_deg % 180.0, eb.az_deg % 180.0)


@needs_kernel
def test_fast_estimate_is_the_reference(replay_steps):
    """filter_estimate in one compiled call (kalman_predict.position through the TM and
    ellipse kernels) gives the reference's estimate: the replay's states, non-finite VCVs,
    and on the reference grid (position declines, the reference runs)."""
    from engine.fast.geodesy import FastTMGrid

    assert ff.POSITION is not None
    grids = (FastTMGrid(WGS84.ellipsoid, 3.0), TMGrid(WGS84.ellipsoid, 3.0))
    states = [s for s, _, _ in replay_steps[:80]]
    s0 = states[-1]
    for P in (np.where(np.eye(s0.n) > 0, np.inf, s0.P), np.full((s0.n, s0.n), np.nan)):
        states.append(FilterState(s0.t, s0.x, P))
    for s in states:
        for source in ("KF", "DR"):
            for grid in grids:
                _same_estimate(ff.filter_estimate(source, grid, s),
                               est.filter_estimate(source, grid, s))
    assert ff.POSITION.position("KF", None, s0.x, s0.P) is None
    assert ff.POSITION.position("KF", grids[0]._packed, np.zeros(2), np.zeros((2, 2))) is None


def test_cycle_makers_are_the_dataclasses() -> None:
    """The cycle's _Prediction / _Filtering made positionally (the compiled slots maker, or
    the class on the reference's part) equal the dataclasses' own instances, field by field."""
    from engine.fast.make import slots_maker

    state = FilterState(0.0, np.zeros(N_NAV), np.eye(N_NAV))
    link = (state, state, np.eye(N_NAV))
    p = ("est", link, "upd", True, "ground", ([5.0], [0.01], "layout"))
    assert REFERENCE.make is positional
    for make in (positional, slots_maker):
        new_prediction, new_filtering = make(cycle_mod._Prediction), make(cycle_mod._Filtering)
        got = new_prediction(state, *p)
        assert type(got) is cycle_mod._Prediction and got == cycle_mod._Prediction(state, *p)
        assert (new_prediction(None, None, None, None, False, "water", None)
                == cycle_mod._Prediction())
        f = (state, link, True, ("LSE",), 2, "N/A")
        got_f = new_filtering(*f, None, "", None)
        assert type(got_f) is cycle_mod._Filtering and got_f == cycle_mod._Filtering(*f)
        got_f.status = "ON"  # still a plain (mutable) slots instance
        assert got_f.status == "ON"

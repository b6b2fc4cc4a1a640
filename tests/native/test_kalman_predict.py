"""The compiled time update (engine/native/kalman_predict.c) gives the very bits of the Python
it mirrors (engine.filter.predict._predict_py), on the states a replay produces and on
generated ones around them; with ``UVNAV_PURE=1`` the Python runs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import engine.filter.measurements as ms
import engine.filter.predict as pr
import engine.run.cycle as cycle_mod
from engine import native
from engine.filter.measurements import Measurement
from engine.filter.params import FilterParams
from engine.filter.state import N_NAV, FilterState
from tests.native.replay import replay_patched
from tests.paths import DATA
from tests.tolerance import assert_close

KERNEL = pr._kernel()
needs_kernel = pytest.mark.skipif(KERNEL is None, reason=f"kernel not used: "
                                  f"{native.status('kalman_predict')}")


def _same(a: tuple[FilterState, np.ndarray], b: tuple[FilterState, np.ndarray]) -> None:
    """The same results to the tolerance contract (tests.tolerance): t, x, P, Φ (values within
    it; shapes, dtype, C order identical)."""
    (sa, pa), (sb, pb) = a, b
    assert sa.t == sb.t
    for u, v in ((sa.x, sb.x), (sa.P, sb.P), (pa, pb)):
        assert u.shape == v.shape and u.dtype == v.dtype == np.float64
        assert u.flags.c_contiguous and v.flags.c_contiguous
        assert_close(u, v)
    assert sa.fix_states == sb.fix_states and sa.fix_tau_s == sb.fix_tau_s
    assert not sa.x.flags.writeable and not sa.P.flags.writeable


@pytest.fixture(scope="module")
def replay_steps() -> list[tuple[FilterState, float, FilterParams]]:
    """(state, Δt, params) of every prediction of 200 demo epochs and the thesis sample."""
    steps: list[tuple[FilterState, float, FilterParams]] = []
    real = cycle_mod.predict_step

    def recording(state: FilterState, dt: float,
                  params: FilterParams) -> tuple[FilterState, np.ndarray]:
        steps.append((state, dt, params))
        return real(state, dt, params)

    real_pos = cycle_mod.predict_step_position

    def recording_pos(state: FilterState, dt: float, params: FilterParams, source: str,
                      packed: object) -> tuple[FilterState, np.ndarray, object]:
        steps.append((state, dt, params))  # the cycle's prediction with its estimate
        return real_pos(state, dt, params, source, packed)

    for name, n in (("DEMO.toml", 200), ("920917_1.toml", None)):
        replay_patched([(cycle_mod, "predict_step", recording),
                        (cycle_mod, "predict_step_position", recording_pos)], n, DATA / name)
    return steps


@needs_kernel
def test_replay_predictions_are_bit_identical(replay_steps):
    assert len(replay_steps) > 150
    assert {s.n for s, _, _ in replay_steps} == {11, 13}
    for state, dt, params in replay_steps:
        for want_phi in (True, False):
            _same(pr._predict(state, dt, params, want_phi),
                  pr._predict_py(state, dt, params, want_phi))


@needs_kernel
def test_predict_step_is_predict(replay_steps):
    """predict_step() (its memo lookups and the new state made inline) is _predict(…, True)
    and _predict_py: the same floats, arrays, metadata and instance dict, in the same order."""
    for state, dt, params in replay_steps:
        got = pr.predict_step(state, dt, params)
        for ref in (pr._predict(state, dt, params, True), pr._predict_py(state, dt, params, True)):
            _same(got, ref)
            assert type(got[0]) is FilterState and list(vars(got[0])) == list(vars(ref[0]))
            assert got[0].fix_cov is state.fix_cov and got[0].t == state.t + dt


@needs_kernel
def test_predict_step_position_is_predict_step_and_position(replay_steps,
                                                            monkeypatch: pytest.MonkeyPatch):
    """predict_step_position() (one kernel call) is predict_step() and then the compiled
    position() of the predicted state (cycle.filter_estimate): the same state, Φ and estimate;
    its estimate None where position() declines (no grid), and from the Python's prediction
    (kernel None, Δt 0) too, where the caller makes the estimate as before."""
    from engine.fast.geodesy import FastTMGrid as TMGrid

    grid = TMGrid(cycle_mod.WGS84.ellipsoid, 3.0)
    monkeypatch.setattr(cycle_mod, "_POSITION_K", cycle_mod._UNSET)
    k = cycle_mod._position_kernel()
    assert k is not None
    for state, dt, params in replay_steps[:60]:
        ref = pr.predict_step(state, dt, params)
        got = pr.predict_step_position(state, dt, params, "KF", grid._packed)
        _same(got[:2], ref)
        assert type(got[0]) is FilterState and list(vars(got[0])) == list(vars(ref[0]))
        assert got[0].fix_cov is state.fix_cov and got[0].t == state.t + dt
        _same_estimate(got[2], k.position("KF", grid._packed, ref[0].x, ref[0].P))
        _same_estimate(got[2], cycle_mod.filter_estimate("KF", grid, ref[0]))
        none = pr.predict_step_position(state, dt, params, "KF", None)
        _same(none[:2], ref)
        assert none[2] is None
    state, dt, params = replay_steps[0]
    same = pr.predict_step_position(state, 0.0, params, "KF", grid._packed)
    assert same[0] is state and same[2] is None
    monkeypatch.setattr(pr, "_K", None)
    py = pr.predict_step_position(state, dt, params, "KF", grid._packed)
    _same(py[:2], pr._predict_py(state, dt, params, True))
    assert py[2] is None


@needs_kernel
def test_the_kernel_is_what_runs(replay_steps, monkeypatch: pytest.MonkeyPatch):
    """The kernel answers (not None) for the replay's states: the Python is not called."""
    def boom(*a: object) -> None:
        raise AssertionError("Python path taken")

    monkeypatch.setattr(pr, "_predict_py", boom)
    for state, dt, params in replay_steps[:20]:
        pr.predict_step(state, dt, params)


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
    want_phi=st.booleans(),
)
def test_generated_predictions_are_bit_identical(m, x, p, dt, mode, which, sym, fortran, taus,
                                                 want_phi):
    n = N_NAV + m
    xs = np.array(x[:n])
    xs[4] = xs[4] % 6.3  # ψ, ε as angles (rad)
    xs[5] = xs[5] * 1e-4
    P = _spd(p, n, sym)
    state = FilterState(0.0, xs, P, tuple(f"k{i}" for i in range(m)), tuple(taus[:m]),
                        _spd(p[::-1], m, True) if m else np.zeros((0, 0)))
    if fortran:  # an F-ordered P (numpy passes it to dgemm as transposed)
        Pf = np.asfortranarray(state.P)
        Pf.flags.writeable = False
        object.__setattr__(state, "P", Pf)
    params = _PARAMS[mode][which]
    _same(pr._predict(state, dt, params, want_phi), pr._predict_py(state, dt, params, want_phi))


@needs_kernel
def test_inputs_it_does_not_cover_go_to_python():
    """More states than the kernel's stack buffers: None, and _predict runs the Python."""
    m = 30
    n = N_NAV + m
    state = FilterState(0.0, np.arange(n) * 0.1, np.eye(n), tuple(f"k{i}" for i in range(m)),
                        (240.0,) * m, np.eye(m))
    params = FilterParams()
    c = pr.step_constants(params, 1.0)
    assert KERNEL.predict(state.x, state.P, c, c.fix_decay(state.fix_tau_s), state.fix_cov,
                          True) is None
    _same(pr._predict(state, 1.0, params, True), pr._predict_py(state, 1.0, params, True))


def test_pure_env_runs_the_python(monkeypatch: pytest.MonkeyPatch):
    """UVNAV_PURE=1: the kernel is not resolved (None) and the Python gives the result."""
    monkeypatch.setenv(native.PURE_ENV, "1")
    monkeypatch.setattr(pr, "_K", pr._UNRESOLVED)
    calls: list[int] = []
    real = pr._predict_py

    def counted(*a: object) -> tuple[FilterState, np.ndarray]:
        calls.append(1)
        return real(*a)  # type: ignore[arg-type]

    monkeypatch.setattr(pr, "_predict_py", counted)
    state = FilterState(0.0, np.arange(11) * 0.1, np.eye(11))
    pr.predict_step(state, 1.0, FilterParams())
    assert pr._K is None and calls == [1]


def test_the_kernel_is_not_resolved_at_import():
    """Start-up: importing the filter does not resolve the kernel; that happens at the first
    prediction."""
    import subprocess
    import sys

    code = "import engine.filter.predict as p; print(p._K is p._UNRESOLVED)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=Path(__file__).resolve().parents[2])
    assert out.stdout.split() == ["True"]


# ---- measurement rows (engine.filter.measurements): the lean paths give the same arrays ----


def _same_meas(a: Measurement, b: Measurement) -> None:
    """Same z, H, R, prior (values, shape, dtype, order) and the same labels, angle rows, keys,
    τ and template columns."""
    for f in ("z", "H", "R", "bias_cov"):
        u, v = getattr(a, f), getattr(b, f)
        if u is None or v is None:
            assert u is v, f
            continue
        assert u.shape == v.shape and u.dtype == v.dtype, f
        assert u.flags.c_contiguous == v.flags.c_contiguous, f
        assert_close(u, v), f
    for f in ("labels", "angle_rows", "bias_keys", "bias_tau_s", "_cols"):
        u, v = getattr(a, f), getattr(b, f)
        assert u == v and type(u) is type(v), (f, u, v)
    assert type(a) is type(b) and list(vars(a)) == list(vars(b))


@pytest.fixture(scope="module")
def replay_rows() -> list[tuple[str, tuple, dict]]:
    """(function name, args, kwargs) of the measurement builders over 200 demo epochs."""
    calls: list[tuple[str, tuple, dict]] = []
    patches: list[tuple[object, str, object]] = []
    for name in ("stack_measurements", "lse_measurement"):
        real = getattr(cycle_mod, name)

        def recording(*a: object, _name: str = name, _real=real, **k: object) -> Measurement:
            calls.append((_name, a, k))
            return _real(*a, **k)

        patches.append((cycle_mod, name, recording))
    real_rows, real_two = cycle_mod.sensor_rows, cycle_mod.update_rows_two_gated

    def rows(depth_m, log_ms, gyro_grid_rad, incl_rad, params, log_sigma_ms=None,
             gyro_sigma_deg=None):  # the sensor_measurement the cycle's rows stand for
        kw = dict(depth_m=depth_m, log_ms=log_ms, gyro_grid_rad=gyro_grid_rad,
                  incl_rad=incl_rad, params=params, log_sigma_ms=log_sigma_ms,
                  gyro_sigma_deg=gyro_sigma_deg)
        calls.append(("sensor_measurement", (None,), kw))
        return real_rows(depth_m, log_ms, gyro_grid_rad, incl_rad, params, log_sigma_ms,
                         gyro_sigma_deg)

    def two(state, zs, var, layout, b, params):  # the stack update_rows_two_gated updates with
        calls.append(("stack_measurements", (ms.rows_measurement(zs, var, layout), b), {}))
        return real_two(state, zs, var, layout, b, params)

    patches += [(cycle_mod, "sensor_rows", rows),
                (cycle_mod, "depth_sensor_rows", lambda depth_m, params: rows(
                    depth_m, None, None, None, params)),
                (cycle_mod, "update_rows_two_gated", two)]
    replay_patched(patches, 200)
    return calls


def test_depth_sensor_rows_is_sensor_rows() -> None:
    """depth_sensor_rows(d, params) is sensor_rows(d, None, None, None, params): the same
    values, variances (bits) and the same layout object."""
    for params in (FilterParams(), FilterParams(sigma_press_m=0.37)):
        for d in (0.0, 12.5, 1e-7, 3021.25):
            got = ms.depth_sensor_rows(d, params)
            ref = ms.sensor_rows(d, None, None, None, params)
            assert got[0] == ref[0] and [v.hex() for v in got[1]] == [v.hex() for v in ref[1]]
            assert got[2] is ref[2]


def test_replay_measurement_rows_are_the_same(replay_rows):
    names = {c[0] for c in replay_rows}
    assert names == {"sensor_measurement", "stack_measurements", "lse_measurement"}
    for name, a, k in replay_rows:
        if name == "sensor_measurement":
            _same_meas(ms.sensor_measurement(*a, **k), ms._sensor_measurement_py(*a, **k))
        elif name == "stack_measurements":
            _same_meas(ms.stack_measurements(*a), ms._stack_py(*a))
        else:
            _same_meas(ms.lse_measurement(*a, **k), ms._lse_py(*a, **k))


_opt_float = st.one_of(st.none(), st.floats(-50.0, 50.0, allow_nan=False))


@settings(max_examples=100, deadline=None)
@given(depth=_opt_float, log=_opt_float, gyro=_opt_float, incl=_opt_float,
       log_sigma=_opt_float, gyro_sigma=_opt_float, frac=st.floats(0.0, 0.99),
       coloured=st.booleans(), c2=st.lists(st.floats(-100.0, 100.0), min_size=4, max_size=4),
       order=st.booleans(), lse_first=st.booleans())
def test_generated_measurement_rows_are_the_same(depth, log, gyro, incl, log_sigma, gyro_sigma,
                                                 frac, coloured, c2, order, lse_first):
    params = FilterParams(coloured=coloured, fix_sigma_frac=frac)
    state = FilterState(0.0, np.zeros(11), np.eye(11))
    kw = dict(depth_m=depth, log_ms=log, gyro_grid_rad=gyro, incl_rad=incl, params=params,
              log_sigma_ms=log_sigma, gyro_sigma_deg=gyro_sigma)
    sens = ms.sensor_measurement(state, **kw)
    _same_meas(sens, ms._sensor_measurement_py(state, **kw))
    lse = ms.lse_measurement(1.5, -2.5, np.array(c2).reshape(2, 2), params)
    parts = (lse, sens) if lse_first else (sens, lse)
    if order:
        parts = (ms.sensor_measurement(state, depth_m=depth, params=params),) + parts[1:]
    _same_meas(ms.stack_measurements(*parts), ms._stack_py(*parts))
    lop = ms.lop_measurement(np.array([[0.6, 0.8]]), np.array([1.0]), np.array([3.0, 4.0]),
                             np.array([[2.0]]), ["fix_e"], None, np.eye(1) * 5.0, (240.0,))
    _same_meas(ms.stack_measurements(sens, lop), ms._stack_py(sens, lop))
    _same_meas(ms.stack_measurements(sens, lse, lop), ms._stack_py(sens, lse, lop))


def test_measurement_arrays_fall_back_to_numpy(monkeypatch: pytest.MonkeyPatch):
    """Inputs the compiled helpers decline (numpy scalars, other dtypes, an F-ordered prior)
    and no kernel at all (UVNAV_PURE=1) give the same measurements as the first code."""
    params = FilterParams(coloured=True)
    state = FilterState(0.0, np.zeros(11), np.eye(11))
    cases = [dict(depth_m=np.float64(3.25), params=params),
             dict(depth_m=3, log_ms=2.5, params=params),
             dict(gyro_grid_rad=1.0, incl_rad=np.float32(0.25), params=params)]
    C2 = np.asfortranarray(np.array([[4.0, 1.0], [1.0, 9.0]]))
    for kernel in (ms._kernel(), None):
        monkeypatch.setattr(ms, "_K", kernel)
        for kw in cases:
            sens = ms.sensor_measurement(state, **kw)
            _same_meas(sens, ms._sensor_measurement_py(state, **kw))
            for c in (C2, np.ascontiguousarray(C2), C2.astype(np.float32)):
                lse = ms.lse_measurement(1.0, 2.0, c, params)
                _same_meas(ms.stack_measurements(sens, lse), ms._stack_py(sens, lse))
            odd = ms._measurement(np.array([1, 2]), np.eye(2, 11), np.eye(2, dtype=int),
                                  ("a", "b"), (1,), ("k", None), np.eye(3), (5.0,),
                                  ((0,), (1,)))
            _same_meas(ms.stack_measurements(sens, odd), ms._stack_py(sens, odd))


def test_pure_env_builds_measurements_with_numpy(monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setenv(native.PURE_ENV, "1")
    monkeypatch.setattr(ms, "_K", ms._UNRESOLVED)
    state = FilterState(0.0, np.zeros(11), np.eye(11))
    kw = dict(depth_m=1.5, log_ms=2.0, params=FilterParams())
    _same_meas(ms.sensor_measurement(state, **kw), ms._sensor_measurement_py(state, **kw))
    assert ms._K is None


@settings(max_examples=100, deadline=None)
@given(x=st.floats(-1e7, 1e7), y=st.floats(-1e7, 1e7),
       c2=st.lists(st.floats(-1e6, 1e6), min_size=4, max_size=4), frac=st.floats(0.0, 0.99),
       coloured=st.booleans(), layout=st.sampled_from(["C", "F", "f32", "list", "np"]))
def test_lse_rows_are_the_same(x, y, c2, frac, coloured, layout):
    params = FilterParams(coloured=coloured, fix_sigma_frac=frac)
    C = np.array(c2).reshape(2, 2)
    C2 = {"C": C, "F": np.asfortranarray(C), "f32": C.astype(np.float32),
          "list": C.tolist(), "np": C}[layout]
    xs = (np.float64(x), np.float64(y)) if layout == "np" else (x, y)
    _same_meas(ms.lse_measurement(*xs, C2, params), ms._lse_py(*xs, C2, params))
    _same_meas(ms.lse_measurement(*xs, C2), ms._lse_py(*xs, C2))


# --------------------------------------------------------------------------- estimate parts

def _same_parts(a: tuple, b: tuple) -> None:
    """estimate_parts results equal bit for bit: floats, the 2×2 copy (C order, read-only)."""
    assert len(a) == len(b) == 5
    for u, v in zip(a[:3], b[:3], strict=True):
        assert type(u) is type(v) is float and u.hex() == v.hex()
    ca, cb = a[3], b[3]
    assert ca.shape == cb.shape == (2, 2) and ca.dtype == cb.dtype == np.float64
    assert ca.strides == cb.strides and ca.tobytes() == cb.tobytes()
    assert not ca.flags.writeable and not cb.flags.writeable
    assert ca.flags.owndata and cb.flags.owndata
    assert a[4] is b[4]


@needs_kernel
def test_estimate_parts_are_the_same(replay_steps):
    """A state's position, depth and VCV copy (cycle.filter_estimate) from the kernel and from
    numpy: the replay's states, a Fortran-ordered and a strided P, non-finite variances."""
    import engine.filter.state as fs

    fs._K = fs._UNRESOLVED
    assert fs.estimate_parts(replay_steps[0][0]) is not None and fs._K is not None
    states = [s for s, _, _ in replay_steps[:60]]
    s0 = states[-1]
    big = np.arange(4.0 * s0.n * s0.n).reshape(2 * s0.n, 2 * s0.n)
    for P in (np.asfortranarray(s0.P), big[::2, ::2], np.where(np.eye(s0.n) > 0, np.inf, s0.P),
              np.full((s0.n, s0.n), np.nan)):
        states.append(FilterState(s0.t, s0.x, P))
    odd = FilterState(s0.t, s0.x, s0.P)
    object.__setattr__(odd, "P", big[::2, ::2])  # a strided view, as a state never holds
    states.append(odd)
    for s in states:
        r = KERNEL.estimate(s.x, s.P)
        assert r is not None
        _same_parts(r, fs._estimate_parts_py(s))
        _same_parts(fs.estimate_parts(s), fs._estimate_parts_py(s))


@needs_kernel
def test_estimate_parts_decline_what_they_do_not_cover():
    assert KERNEL.estimate(np.zeros(2), np.zeros((2, 2))) is None
    assert KERNEL.estimate(np.zeros(11, dtype=np.float32), np.zeros((11, 11))) is None
    assert KERNEL.estimate(np.zeros(11), np.zeros((11, 12))) is None
    assert KERNEL.estimate([0.0] * 11, np.zeros((11, 11))) is None


@needs_kernel
def test_sym2_is_with_fix_cov_numpy_expression():
    """sym2 (FilterState.with_fix_cov's usual case) gives the numpy code's array: the same
    bits, read-only; anything but a float64 2×2 is declined."""
    rng = np.random.default_rng(3)
    for C in (rng.normal(size=(2, 2)) * 1e3, np.asfortranarray(rng.normal(size=(2, 2))),
              rng.normal(size=(4, 4))[::2, ::2], np.array([[np.inf, 1.0], [np.nan, -0.0]])):
        (a, b), (c, d) = C.tolist()
        ref = np.array([[0.5 * (a + a), 0.5 * (b + c)], [0.5 * (c + b), 0.5 * (d + d)]])
        got = KERNEL.sym2(C)
        assert got.tobytes() == ref.tobytes() and got.strides == ref.strides
        assert not got.flags.writeable
    for bad in (np.zeros((3, 3)), np.zeros((2, 2), dtype=np.float32), [[1.0, 0.0], [0.0, 1.0]]):
        assert KERNEL.sym2(bad) is None


def _same_estimate(a: object, b: object) -> None:
    """Two PositionEstimates with the same floats and the same (read-only) arrays."""
    assert type(a) is type(b)
    for f in ("source", "lat_deg", "lon_deg", "x_m", "y_m", "depth_m"):
        assert getattr(a, f) == getattr(b, f) or (getattr(a, f) != getattr(a, f) and
                                                   getattr(b, f) != getattr(b, f))
    ca, cb = a.cov, b.cov  # type: ignore[attr-defined]
    assert ca.tobytes() == cb.tobytes() and ca.strides == cb.strides
    assert not ca.flags.writeable and not cb.flags.writeable
    ea, eb = a.ellipse, b.ellipse  # type: ignore[attr-defined]
    assert (ea is None) == (eb is None)
    if ea is not None:
        assert list(ea.__dict__) == list(eb.__dict__)
        for k, va in ea.__dict__.items():
            vb = eb.__dict__[k]
            if isinstance(va, np.ndarray):
                assert va.tobytes() == vb.tobytes() and not va.flags.writeable
                assert not vb.flags.writeable
            else:
                assert va == vb


@needs_kernel
def test_position_is_filter_estimate_in_python(replay_steps, monkeypatch: pytest.MonkeyPatch):
    """cycle.filter_estimate in one compiled call (kalman_predict.position through the TM and
    ellipse kernels) gives the Python's estimate: the replay's states and non-finite VCVs."""
    from engine.fast.geodesy import FastTMGrid as TMGrid

    grid = TMGrid(cycle_mod.WGS84.ellipsoid, 3.0)
    monkeypatch.setattr(cycle_mod, "_POSITION_K", cycle_mod._UNSET)
    k = cycle_mod._position_kernel()
    assert k is not None
    states = [s for s, _, _ in replay_steps[:80]]
    s0 = states[-1]
    for P in (np.where(np.eye(s0.n) > 0, np.inf, s0.P), np.full((s0.n, s0.n), np.nan)):
        states.append(FilterState(s0.t, s0.x, P))
    for s in states:
        for source in ("KF", "DR"):
            got = k.position(source, grid._packed, s.x, s.P)
            assert got is not None
            _same_estimate(got, cycle_mod.filter_estimate(source, grid, s))
            with monkeypatch.context() as m:
                m.setattr(cycle_mod, "_POSITION_K", None)  # the Python
                _same_estimate(got, cycle_mod.filter_estimate(source, grid, s))
    assert k.position("KF", None, s0.x, s0.P) is None
    assert k.position("KF", grid._packed, np.zeros(2), np.zeros((2, 2))) is None


def test_cycle_makers_are_the_dataclasses() -> None:
    """The cycle's _Prediction / _Filtering made positionally (runparse.make, or the class on
    the pure path) equal the dataclasses' own instances, field by field."""
    state = FilterState(0.0, np.zeros(N_NAV), np.eye(N_NAV))
    link = (state, state, np.eye(N_NAV))
    p = ("est", link, "upd", True, "ground")
    got = cycle_mod._new_prediction(state, *p)
    assert type(got) is cycle_mod._Prediction and got == cycle_mod._Prediction(state, *p)
    assert cycle_mod._new_prediction(None, None, None, None, False, "water") == \
        cycle_mod._Prediction()
    f = (state, link, True, ("LSE",), 2, "N/A")
    got_f = cycle_mod._new_filtering(*f, None, "")
    assert type(got_f) is cycle_mod._Filtering and got_f == cycle_mod._Filtering(*f)
    got_f.status = "ON"  # still a plain (mutable) slots instance
    assert got_f.status == "ON"

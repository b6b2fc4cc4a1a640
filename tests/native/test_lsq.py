"""The compiled LSQ kernel (engine/native/lsq.c) gives the bits of the Python it replaces.

Each entry point is compared with the reference Python it stands for, to the bit (``float.hex``
/ the bytes of the arrays): ``step`` with ``adjustment._solve`` + ``_step``, ``finish`` with
``adjustment._adjustment`` (residuals, S², RMS, drms, the statistics block), ``ellipse`` with
``confidence.error_ellipse``; on (a) the matrices a short demo replay really produces and (b)
hypothesis-generated inputs around them; and whole adjustments by the kernel's ``adjust`` (as
engine.fast.lsq calls it) against ``gauss_newton``. The pure path is the one taken with
``UVNAV_PURE=1``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import engine.fast as fast
import engine.filter.estimate as filter_estimate
import engine.lsq.adjustment as adj
import engine.lsq.confidence as conf
import engine.lsq.fix as fixmod
import engine.lsq.snooping as snoop
from engine import native
from engine.fast import filter as fast_filter
from engine.fast import lsq as fast_lsq
from engine.lsq.adjustment import COND_MAX, MAX_AXIS_RATIO, Adjustment, Linearisation, gauss_newton
from engine.lsq.statistics import delta0, frozen_instance, unit_variance_test, w_critical
from tests.native.replay import replay_patched
from tests.tolerance import ATOL_METRES, RTOL, close

K = fast_lsq.kernel()
needs_kernel = pytest.mark.skipif(K is None, reason="engine.native.lsq not built or not bound")
ROOT = Path(__file__).resolve().parents[2]

ADJ_FIELDS = ("ok", "reason", "x", "cov_x", "cov_x_apriori", "n_used", "redundancy", "category",
              "iterations", "converged", "steps", "dx", "v", "s2", "rms_m", "drms_m",
              "stats_block", "A_used", "b_used", "Cl_used", "W_used", "variance_test",
              "scaled")
ELL_FIELDS = ("a_m", "b_m", "az_deg", "eigenvalues", "eigenvectors", "phi_deg")


def same(a: Any, b: Any, rtol: float = RTOL) -> bool:
    """Equal to the tolerance contract (tests.tolerance): arrays by shape, dtype and values
    within it; floats within it; everything else identical (``rtol`` widened for an
    ill-conditioned problem). The fix's numbers are metres and test statistics in σ: the
    contract's floor for both is 1e-6 (a residual of a fix without redundancy is rounding
    noise of ~1e-9 m)."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return not close(np.asarray(a), np.asarray(b), ATOL_METRES, rtol=rtol)
    return not close(a, b, ATOL_METRES, rtol=rtol)


def adjustment_rtol(adj: Any) -> float:
    """The contract's 1e-9, or cond(N)·1e-16 for an adjustment whose normal matrix N has a
    condition number beyond 1e7 (two correct solutions differ by up to cond(N) units in the
    last place): the number its failure reason states, else N = AᵀWA of the rows it used; 1e-5
    for a Gauss–Newton that did not converge (its numbers are a failed fix's, never logged as a
    position; its reason, iterations and counts are still compared exactly)."""
    if getattr(adj, "reason", None) == "no convergence":
        return 1e-5  # a failed fix's last iterate: the iteration magnifies the last bits
    hit = re.search(r"condition number ([0-9.e+-]+)", str(getattr(adj, "reason", "")))
    cond = float(hit.group(1)) if hit else 0.0
    A, W = getattr(adj, "A_used", None), getattr(adj, "W_used", None)
    if not hit and isinstance(A, np.ndarray) and isinstance(W, np.ndarray) and A.size:
        N = A.T @ W @ A
        cond = float(np.linalg.cond(N)) if np.all(np.isfinite(N)) else 0.0
    return max(RTOL, cond * 1e-16)


class _Run(adj._Run):
    """A _Run at x over ``used`` (the state the kernel's callers hand over)."""

    def __init__(self, x: np.ndarray, used: np.ndarray) -> None:
        super().__init__(np.array(x, dtype=float), np.array(used, dtype=bool))


def check_step(Au: np.ndarray, bu: np.ndarray, Clu: np.ndarray, x: np.ndarray,
               cond_max: float = COND_MAX) -> bool:
    """The kernel's step equals the Python's (or declines); True when it took the case."""
    res = K.step(Au, bu, Clu, cond_max, x)
    try:
        sol = adj._solve(Au, bu, Clu, cond_max)
        run = _Run(x, np.ones(bu.size, bool))
        big = adj._step(run, sol)
    except adj._Stop:
        assert res is None
        return False
    if res is None:
        return False
    ksol, kx, length, kbig = res
    assert type(ksol) is adj._Solution
    for name, a, b in zip(adj._Solution._fields, sol, ksol, strict=True):
        assert same(a, b), name
    assert same(run.x, kx) and same(run.steps[0], length) and same(big, kbig)
    return True


def check_finish(sol: adj._Solution, x: np.ndarray, used: np.ndarray, scale_vcv: bool) -> bool:
    """The kernel's _adjustment equals the Python's (or declines); True when it took it."""
    run = _Run(x, used)
    run.it, run.steps, run.converged = 2, [3.0, 0.5], True
    d0 = delta0(0.05, 0.80)
    res = K.finish(sol, run.used, scale_vcv, d0)
    want = adj._adjustment(run, sol, 1.0, scale_vcv, 0.05, 0.80, None)
    if res is None:
        return False
    v, s2, rms, drms, cov, scaled, block = res
    rtol = adjustment_rtol(want)
    for name, got in (("v", v), ("s2", s2), ("rms_m", rms), ("drms_m", drms), ("cov_x", cov),
                      ("scaled", scaled), ("stats_block", block)):
        assert same(getattr(want, name), got, rtol), name
    return True


def check_ellipse(c2: np.ndarray) -> bool:
    """The kernel's ellipse equals the Python's (or declines); True when it took it."""
    got = K.ellipse(c2)
    try:
        want = conf.error_ellipse(c2)
    except (ValueError, ZeroDivisionError):
        assert got is None
        return False
    if got is None:
        return False
    assert type(got) is conf.Ellipse
    for name in ELL_FIELDS:
        assert same(getattr(want, name), getattr(got, name)), name
    return True


# ------------------------------------------------------------------------------------------
# (a) what a replay really produces


@pytest.fixture(scope="module")
def recorded() -> dict[str, list[Any]]:
    """The inputs of every step / finish / ellipse of the first 200 demo epochs (kernel off
    while recording, so each is recorded as the Python saw it)."""

    rec: dict[str, list[Any]] = {"step": [], "finish": [], "ellipse": []}
    evaluate, adjustment, ellipse = adj._evaluate, adj._adjustment, conf.error_ellipse

    def ev(lin: Any, run: adj._Run, sq: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        out = evaluate(lin, run, sq)
        rec["step"].append((*out, run.x.copy()))
        return out

    def fin(run: adj._Run, sol: adj._Solution, *a: Any) -> Any:
        rec["finish"].append((sol, run.x.copy(), run.used.copy()))
        return adjustment(run, sol, *a)

    def ell(c2: np.ndarray) -> Any:
        rec["ellipse"].append(np.array(c2))
        return ellipse(c2)

    replay_patched([(fast_lsq, "kernel", lambda: None),
                    # the filter estimate's ellipse too (its compiled PositionEstimate calls
                    # the ellipse in C)
                    (fast_filter, "POSITION", None),
                    (adj, "_evaluate", ev),
                    (adj, "_adjustment", fin),
                    (fixmod, "error_ellipse", ell),
                    (filter_estimate, "error_ellipse", ell)], 200)
    return rec


@needs_kernel
def test_replay_steps_are_bit_identical(recorded: dict[str, list[Any]]) -> None:
    taken = [check_step(Au, bu, Clu, x) for Au, bu, Clu, x in recorded["step"]]
    assert len(taken) > 300 and all(taken)  # the kernel takes every iteration of the demo


@needs_kernel
def test_replay_finishes_are_bit_identical(recorded: dict[str, list[Any]]) -> None:
    for sol, x, used in recorded["finish"]:
        assert check_finish(sol, x, used, False)
        assert check_finish(sol, x, used, True)  # ScaleVCV on: C_x̂ × S²
    assert len(recorded["finish"]) >= 200


@needs_kernel
def test_replay_ellipses_are_bit_identical(recorded: dict[str, list[Any]]) -> None:
    assert all(check_ellipse(c2) for c2 in recorded["ellipse"])
    assert len(recorded["ellipse"]) >= 400


# ------------------------------------------------------------------------------------------
# (b) generated inputs around them


@st.composite
def problems(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A (m, 2) design of unit-ish rows, misclosures, an SPD C_l (GPS-like diagonal and a
    correlated Decca-like block) and a grid point."""
    m = draw(st.integers(2, 10))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    ang = rng.uniform(0.0, 2.0 * np.pi, m)
    A = np.column_stack((np.sin(ang), np.cos(ang))) * rng.choice([1.0, 1.0, 0.5, 2.0], (m, 1))
    b = rng.normal(0.0, 10.0 ** rng.uniform(-3, 2), m)
    L = np.tril(rng.normal(0, 1, (m, m))) * (rng.random((m, m)) < 0.3)
    np.fill_diagonal(L, 10.0 ** rng.uniform(0, 2, m))
    Cl = L @ L.T
    x = np.array([rng.uniform(-1e5, 1e5), rng.uniform(5.5e6, 6.5e6)])
    return A, b, Cl, x


@needs_kernel
@settings(max_examples=300, deadline=None)
@given(problems())
def test_generated_steps_are_bit_identical(p: tuple[np.ndarray, ...]) -> None:
    A, b, Cl, x = p
    check_step(A, b, Cl, x)
    n = b.size + 2  # the same numbers as strided views of a larger layout (unused slots)
    big = np.eye(n)
    big[1:-1, 1:-1] = Cl
    check_step(A, b, big[1:-1, 1:-1], x)


@needs_kernel
@settings(max_examples=300, deadline=None)
@given(problems(), st.integers(0, 2**32 - 1), st.booleans())
def test_generated_finishes_are_bit_identical(p: tuple[np.ndarray, ...], seed: int,
                                              scale: bool) -> None:
    A, b, Cl, x = p
    try:
        sol = adj._solve(A, b, Cl, COND_MAX)
    except adj._Stop:
        return
    rng = np.random.default_rng(seed)
    n = b.size + int(rng.integers(0, 4))
    used = np.zeros(n, bool)
    used[np.sort(rng.choice(n, b.size, replace=False))] = True  # any layout of the used slots
    check_finish(sol, x + sol.dx, used, scale)


@needs_kernel
@settings(max_examples=500, deadline=None)
@given(st.floats(0.0, 1e8), st.floats(0.0, 1e8), st.floats(-1.0, 1.0),
       st.sampled_from(["any", "iso", "diag", "neg"]))
def test_generated_ellipses_are_bit_identical(sxx: float, syy: float, rho: float,
                                              kind: str) -> None:
    sxy = rho * math.sqrt(sxx * syy)
    if kind == "iso":
        syy, sxy = sxx, 0.0
    elif kind == "diag":
        sxy = 0.0
    elif kind == "neg":
        sxx, sxy = -sxx, -sxy
    check_ellipse(np.array([[sxx, sxy], [sxy, syy]]))


@needs_kernel
def test_ellipse_edge_cases() -> None:
    for c in ([[0.0, 0.0], [0.0, 0.0]], [[-0.0, -0.0], [-0.0, -0.0]], [[4.0, 0.0], [0.0, 1.0]],
              [[1.0, 0.0], [0.0, 4.0]], [[1.0, 2.0], [2.0, 1.0]], [[1e-300, 0.0], [0.0, 0.0]],
              [[math.nan, 0.0], [0.0, 1.0]], [[math.inf, 0.0], [0.0, 1.0]],
              [[1e308, 1e308], [1e308, 1e308]]):
        try:
            check_ellipse(np.array(c))
        except OverflowError:
            pass
    assert K.ellipse([[1.0, 0.0], [0.0, 1.0]]) is None  # not an array: the Python's case
    assert K.ellipse(np.eye(3)) is None and K.ellipse(np.eye(2, dtype=np.float32)) is None


def check_step_rows(A: np.ndarray, b: np.ndarray, Cl: np.ndarray, idx: list[int],
                    x: np.ndarray, cond_max: float = COND_MAX) -> bool:
    """``step_rows`` on the model's lists equals ``step`` on the used rows as
    ``adjustment._evaluate`` slices them (new arrays with the same numbers); True when its
    step took the case."""
    lists = A.ravel().tolist(), b.tolist(), Cl, list(idx), cond_max, x
    got = K.step_rows(*lists, math.inf)
    assert got is not None  # lists of floats, slots in range: always gathered
    Au, bu, Clu, res = got
    ix = np.array(idx)
    want = A[ix], b[ix], Cl[np.ix_(ix, ix)]
    for a, w in zip((Au, bu, Clu), want, strict=True):
        assert same(a, w) and a.flags.c_contiguous and a.flags.writeable
    ref = K.step(*want, cond_max, x)
    if ref is None or res is None:
        assert ref is None and res is None
        assert K.step_rows(*lists, -math.inf)[3] is None  # declined: arrays for the Python
        return False
    # a step not below eps is not kept: only x + dx and the step lengths, the same numbers
    for eps in (-math.inf, 0.0, ref[3], np.nextafter(ref[3], math.inf), 1e300):
        light = K.step_rows(*lists, float(eps))
        if ref[3] < eps:
            assert all(same(a, w) for a, w in zip(light[:3], want, strict=True))
            assert all(same(a, w) for a, w in zip(light[3][0], ref[0], strict=True))
        else:
            assert light[:3] == (None, None, None) and light[3][0] is None
        assert all(same(a, w) for a, w in zip(light[3][1:], ref[1:], strict=True))
    for name, a, w in zip(adj._Solution._fields, res[0], ref[0], strict=True):
        assert same(a, w), name
    assert res[0][0] is Au and res[0][1] is bu and res[0][2] is Clu
    assert all(same(a, w) for a, w in zip(res[1:], ref[1:], strict=True))
    return check_step(*want, x, cond_max)


@needs_kernel
def test_replay_step_rows_are_bit_identical(recorded: dict[str, list[Any]]) -> None:
    for Au, bu, Clu, x in recorded["step"]:  # the used rows laid out behind two unused slots
        m = bu.size
        A, b, Cl = np.zeros((m + 2, 2)), np.zeros(m + 2), np.eye(m + 2)
        A[2:], b[2:], Cl[2:, 2:] = Au, bu, Clu
        assert check_step_rows(A, b, Cl, list(range(2, m + 2)), x)


@needs_kernel
@settings(max_examples=300, deadline=None)
@given(problems(), st.integers(0, 2**32 - 1))
def test_generated_step_rows_are_bit_identical(p: tuple[np.ndarray, ...], seed: int) -> None:
    A, b, Cl, x = p
    rng = np.random.default_rng(seed)
    m = b.size
    n = m + int(rng.integers(0, 4))
    idx = np.sort(rng.choice(n, m, replace=False))  # any layout of the used slots
    Af, bf = rng.normal(0.0, 1.0, (n, 2)), rng.normal(0.0, 1.0, n)
    Clf = np.eye(n)
    Af[idx], bf[idx], Clf[np.ix_(idx, idx)] = A, b, Cl
    check_step_rows(Af, bf, Clf, idx.tolist(), x)
    check_step_rows(Af, bf, np.asfortranarray(Clf), idx.tolist(), x)  # any strides of C_l


@needs_kernel
def test_step_rows_declines_what_it_does_not_gather() -> None:
    A, b, Cl, x = [1.0, 0.0, 0.0, 1.0, 1.0, 1.0], [1.0, 2.0, 3.0], np.eye(3), np.zeros(2)
    assert K.step_rows(A, b, Cl, [0, 1, 2], COND_MAX, x, math.inf) is not None
    for args in ((A[:-1], b, Cl, [0, 1, 2]),  # 2n floats
                 ([1, 0.0, 0.0, 1.0, 1.0, 1.0], b, Cl, [0, 1, 2]),  # an int, not a float
                 (A, [1.0, np.float64(2.0), 3.0], Cl, [0, 1, 2]),  # a numpy float
                 (A, b, Cl, [0, 1, 3]), (A, b, Cl, [-1, 0, 1]), (A, b, Cl, [0]),  # slots
                 (A, b, Cl, (0, 1, 2)), (tuple(A), b, Cl, [0, 1, 2]),  # not lists
                 (A, b, np.eye(4), [0, 1, 2]), (A, b, np.eye(3, dtype=np.float32), [0, 1, 2])):
        assert K.step_rows(*args, COND_MAX, x, math.inf) is None
    for eps in (math.inf, -math.inf):  # gathered, then step declines (singular C_l)
        got = K.step_rows(A, b, np.zeros((3, 3)), [0, 1, 2], COND_MAX, x, eps)
        assert got is not None and got[3] is None and same(got[2], np.zeros((3, 3)))


@needs_kernel
def test_declined_cases_go_to_python() -> None:
    A = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    b = np.array([1.0, 2.0, 3.0])
    x = np.zeros(2)
    assert K.step(A, b, np.zeros((3, 3)), COND_MAX, x) is None  # singular C_l
    assert K.step(np.array([[1.0, 1.0], [1.0, 1.0 + 1e-7], [1.0, 1.0]]), b, np.eye(3), COND_MAX,
                  x) is None  # ill-conditioned normal matrix
    assert K.step(A, np.array([1.0, np.inf, 0.0]), np.eye(3), COND_MAX, x) is None
    assert K.step(np.ones((3, 3)), b, np.eye(3), COND_MAX, np.zeros(3)) is None  # u = 3
    assert K.step(np.asfortranarray(A), b, np.eye(3), COND_MAX, x) is None
    assert K.step(A.astype(np.float32), b, np.eye(3), COND_MAX, x) is None


@needs_kernel
@settings(max_examples=300, deadline=None)
@given(st.lists(st.one_of(st.floats(-5.0, 5.0), st.just(math.nan), st.just(2.576),
                          st.just(-1.959963984540054), st.just(-0.0), st.just(math.inf)),
                min_size=1, max_size=12), st.booleans())
def test_worst_and_monitor_are_the_pythons(w: list[float], row: bool) -> None:
    arr = np.array(w)
    if row:  # a row of a statistics block, as adj.w is
        block = np.zeros((3, arr.size))
        block[1] = arr
        arr = block[1]
    else:
        arr = np.repeat(arr, 2)[::2]  # a strided view
    fake = type("A", (), {"w": arr})()
    want = snoop._worst(fake)  # type: ignore[arg-type]
    got = K.worst(arr)
    assert got[0] == want[0] and same(got[1], want[1])
    k = 1.959963984540054
    assert K.monitor(arr, k, 2.576) == snoop._monitor(arr, k, 2.576)
    assert K.worst(np.zeros(0)) is None
    # quiet: the band when the largest |w| is within the bound (_snoop stops at once), else None
    block = np.zeros((9, arr.size))
    block[1] = arr
    quiet = K.quiet(block, k, 2.576)
    if abs(want[1]) <= 2.576:
        assert quiet == snoop._monitor(arr, k, 2.576)
    else:
        assert quiet is None


# ------------------------------------------------------------------------------------------
# whole adjustments, kernel against no kernel


def _bearings(stations: np.ndarray, obs: np.ndarray, sig: np.ndarray,
              corr: float) -> Any:
    """Distance LOPs to ``stations`` (m): a metric linearisation with correlated C_l."""
    n = len(stations)
    cl = np.diag(sig**2)
    for i in range(n - 1):
        cl[i, i + 1] = cl[i + 1, i] = corr * sig[i] * sig[i + 1]

    def lin(x: np.ndarray) -> Linearisation:
        d = x - stations
        r = np.hypot(d[:, 0], d[:, 1])
        return Linearisation(d / r[:, None], obs - r, cl)

    return lin


_GN = {"epsilon": 1.0, "max_iter": 10, "s02": 1.0, "scale_vcv": False, "cond_max": COND_MAX,
       "max_axis_ratio": MAX_AXIS_RATIO, "alpha": 0.05, "power": 0.80}
"""gauss_newton's defaults."""


def _kernel_gn(model: Any, x0: Any, used: Any, fresh: Any = None, **kw: Any) -> Adjustment:
    """The adjustment by the kernel's ``adjust`` on the model's rows (a plain linearisation
    wrapped in :class:`_RowsModel`), as engine.fast.lsq hands it over; gauss_newton (of
    ``fresh()``, a model not called yet, where given) where the kernel declines (it hands back
    its state, or None)."""
    p = {**_GN, **kw}
    rows_model = model if hasattr(model, "rows") else _RowsModel(model)
    state = K.adjust(rows_model.rows, np.array(x0, dtype=float), np.array(used, dtype=bool),
                     p["epsilon"], p["max_iter"], p["cond_max"], p["max_axis_ratio"],
                     p["scale_vcv"], delta0(p["alpha"], p["power"]))
    if type(state) is dict:
        if state["s2"] is not None:
            state["variance_test"] = unit_variance_test(state["s2"], state["redundancy"],
                                                        p["alpha"], p["s02"])
        return frozen_instance(Adjustment, state)
    return gauss_newton(model if fresh is None else fresh(), x0, used, **kw)


def _both(*args: Any, **kw: Any) -> Iterator[Any]:
    yield _kernel_gn(*args, **kw)
    yield gauss_newton(*args, **kw)


@needs_kernel
@settings(max_examples=150, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(3, 8), st.booleans(), st.booleans())
def test_gauss_newton_with_and_without_the_kernel(seed: int, n: int, scale: bool,
                                                  gap: bool) -> None:
    rng = np.random.default_rng(seed)
    stations = rng.uniform(-3e4, 3e4, (n, 2))
    truth = rng.uniform(-5e3, 5e3, 2)
    sig = rng.uniform(5.0, 50.0, n)
    obs = np.hypot(*(truth - stations).T) + rng.normal(0, 1, n) * sig
    obs[rng.integers(n)] += rng.choice([0.0, 200.0])
    used = np.ones(n, bool)
    if gap:
        used[rng.integers(n)] = False
    lin = _bearings(stations, obs, sig, rng.uniform(-0.5, 0.5))
    x0 = truth + rng.normal(0, 300, 2)
    got, want = _both(lin, x0, used, scale_vcv=scale)
    rtol = adjustment_rtol(want)
    for name in ADJ_FIELDS:
        assert same(getattr(want, name), getattr(got, name), rtol), name


@needs_kernel
@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from(["lsq", "huber", "danish"]),
       st.sampled_from(["Y", "N", "A"]))
def test_data_snooping_with_and_without_the_kernel(seed: int, estimator: str,
                                                   policy: str) -> None:
    """The whole snooping driver (rejections, robust IRLS with damped C_l, messages)."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(4, 9))
    stations = rng.uniform(-3e4, 3e4, (n, 2))
    truth = rng.uniform(-5e3, 5e3, 2)
    sig = rng.uniform(5.0, 50.0, n)
    obs = np.hypot(*(truth - stations).T) + rng.normal(0, 1, n) * sig
    obs[rng.integers(n)] += rng.choice([150.0, 400.0])  # an outlier to reject or down-weight
    lin = _bearings(stations, obs, sig, rng.uniform(-0.3, 0.3))
    x0 = truth + rng.normal(0, 300, 2)
    kw: dict[str, Any] = {"policy": policy, "estimator": estimator}
    got, want = _both_snoop(lin, x0, np.ones(n, bool), **kw)
    for name in ("rejected", "candidate", "candidate_w", "flagged", "monitor",
                 "not_identifiable", "variance_test", "messages"):
        assert same(getattr(want, name), getattr(got, name)), name
    rtol = adjustment_rtol(want.adjustment)
    for name in ADJ_FIELDS:
        assert same(getattr(want.adjustment, name), getattr(got.adjustment, name), rtol), name


@needs_kernel
@settings(max_examples=80, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from(["Y", "N", "A"]),
       st.sampled_from([0.2, 1.0, 4.0]), st.booleans())
def test_quiet_fixes_with_and_without_the_kernel(seed: int, policy: str, noise: float,
                                                 rows: bool) -> None:
    """Fixes without an outlier (the kernel's ``quiet`` path), their noise too small, right or
    too large for C_l (the unit-variance messages), with and without rows()."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(3, 9))
    stations = rng.uniform(-3e4, 3e4, (n, 2))
    truth = rng.uniform(-5e3, 5e3, 2)
    sig = rng.uniform(5.0, 50.0, n)
    obs = np.hypot(*(truth - stations).T) + rng.normal(0, noise, n) * sig
    lin = _bearings(stations, obs, sig, rng.uniform(-0.3, 0.3))
    model = _RowsModel(lin) if rows else lin
    x0 = truth + rng.normal(0, 300, 2)
    got, want = _both_snoop(model, x0, np.ones(n, bool), policy=policy)
    for name in ("rejected", "candidate", "candidate_w", "monitor", "not_identifiable",
                 "variance_test", "messages", "policy", "estimator", "robust"):
        assert same(getattr(want, name), getattr(got, name)), name
    if not same(want.flagged, got.flagged):
        # A tie: with redundancy 1 every |w| is the same number, and which slot is "the
        # largest" is the last bit's choice (the outlier is then not identifiable). Any slot
        # whose |w| is the largest within the contract is the same answer.
        w = np.abs(want.adjustment.stats_block[1])  # NaN: a slot not used
        ties = {int(i) for i in np.flatnonzero(w >= np.nanmax(w) * (1 - 1e-9))}
        assert len(ties) > 1 and set(got.flagged) <= ties and len(got.flagged) == len(
            want.flagged), ("flagged", got.flagged, want.flagged)
    assert list(vars(got)) == list(vars(want))
    rtol = adjustment_rtol(want.adjustment)
    for name in ADJ_FIELDS:
        assert same(getattr(want.adjustment, name), getattr(got.adjustment, name), rtol), name


def _both_snoop(model: Any, x0: Any, used: Any, **kw: Any) -> Iterator[Any]:
    """adjust_with_testing as the compiled fix runs it (the first adjustment by ``adjust``, a
    quiet fix concluded by the kernel's ``quiet``), then the reference."""
    policy, estimator = kw.get("policy", "Y"), kw.get("estimator", "lsq")
    got = None
    if estimator == "lsq":
        first = _kernel_gn(model, x0, used)
        got = fast_lsq.tested_quiet(first, w_critical(0.05), policy, estimator, K)
        if got is None:
            got = snoop.adjust_with_testing(model, x0, used, first=first, **kw)
    yield got if got is not None else snoop.adjust_with_testing(model, x0, used, **kw)
    yield snoop.adjust_with_testing(model, x0, used, **kw)


@needs_kernel
def test_an_untestable_slot_goes_to_python() -> None:
    """Slot 0 is the only x observation (r_0 = 0): finish declines, the Python marks it."""
    A = np.array([[1.0, 0.0], [0.0, 1.0], [0.0, 1.0], [0.0, 1.0]])
    lin0 = Linearisation(A, np.array([1.0, 2.0, 2.5, 1.5]), np.diag([4.0, 9.0, 9.0, 16.0]))
    sol = adj._solve(lin0.A, lin0.b, lin0.Cl, COND_MAX)
    assert K.finish(sol, np.ones(4, bool), False, 2.8) is None
    got, want = _both(lambda x: lin0, np.zeros(2), np.ones(4, bool))
    assert math.isinf(got.sigma_d[0]) and math.isnan(got.w[0])
    rtol = adjustment_rtol(want)
    for name in ADJ_FIELDS:
        assert same(getattr(want, name), getattr(got, name), rtol), name


# ------------------------------------------------------------------------------------------
# the pure path


def test_pure_env_takes_the_python(monkeypatch: pytest.MonkeyPatch) -> None:
    """UVNAV_PURE=1: the run's fix is the reference's."""
    monkeypatch.setenv(native.PURE_ENV, "1")
    fast._verdict.cache_clear()
    try:
        from engine.run.parts import choose

        assert choose().compute_fix is fixmod.compute_fix
    finally:
        fast._verdict.cache_clear()


def test_binding_is_lazy() -> None:
    """Importing the LSQ modules resolves no kernel (that is done once per run, on first use)."""
    import subprocess
    import sys

    code = ("import sys, engine.lsq.fix, engine.lsq.adjustment, engine.fast.lsq as k; "
            "assert k.kernel.cache_info().currsize == 0; print('ok')")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=ROOT, timeout=60)
    assert done.stdout.strip() == "ok", done.stderr


# ------------------------------------------------------------------------------------------
# adjust: the whole gauss_newton of a model with rows() in one call


class _RowsModel:
    """A linearisation offering ``arrays`` and ``rows`` (as engine.lsq.fix._Model does), so
    gauss_newton hands the whole adjustment to the kernel's ``adjust``; ``fail_at`` makes the
    k-th call raise ValueError (a model failing mid-loop)."""

    def __init__(self, lin: Any, fail_at: int | None = None) -> None:
        self.lin, self.fail_at, self.calls = lin, fail_at, 0

    def __call__(self, x: np.ndarray) -> Linearisation:
        A, b, Cl = self.arrays(x)
        return Linearisation(A, b, Cl)

    def arrays(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        A, b, Cl = self.rows(x)
        return np.array(A).reshape(len(b), 2), np.array(b), Cl

    def rows(self, x: np.ndarray) -> tuple[list[float], list[float], np.ndarray]:
        self.calls += 1
        if self.fail_at is not None and self.calls >= self.fail_at:
            raise ValueError("model fails here")
        lin = self.lin(np.asarray(x, dtype=float))
        return (np.asarray(lin.A, dtype=float).ravel().tolist(), lin.b.tolist(),
                np.asarray(lin.Cl, dtype=float))


def _both_rows(make: Any, *args: Any, **kw: Any) -> Iterator[Any]:
    """A fresh model from ``make()`` adjusted by the kernel's ``adjust``, then gauss_newton."""
    yield _kernel_gn(make(), *args, fresh=make, **kw)
    yield gauss_newton(make(), *args, **kw)


@needs_kernel
@settings(max_examples=150, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(2, 8), st.booleans(), st.booleans(),
       st.integers(1, 10), st.sampled_from([None, 1, 2, 3]), st.sampled_from([1.0, 1e-9]))
def test_adjust_is_gauss_newton(seed: int, n: int, scale: bool, gap: bool, max_iter: int,
                                fail_at: int | None, eps: float) -> None:
    """The one-call adjustment against the Python loop: converged, not converged (max_iter,
    a tiny ε), a model raising in some iteration, r = 0, a slot left out."""
    rng = np.random.default_rng(seed)
    stations = rng.uniform(-3e4, 3e4, (n, 2))
    truth = rng.uniform(-5e3, 5e3, 2)
    sig = rng.uniform(5.0, 50.0, n)
    obs = np.hypot(*(truth - stations).T) + rng.normal(0, 1, n) * sig
    used = np.ones(n, bool)
    if gap and n > 2:
        used[rng.integers(n)] = False
    lin = _bearings(stations, obs, sig, rng.uniform(-0.5, 0.5))
    x0 = truth + rng.normal(0, 3000, 2)
    got, want = _both_rows(lambda: _RowsModel(lin, fail_at), x0, used, scale_vcv=scale,
                           max_iter=max_iter, epsilon=eps)
    for name in ADJ_FIELDS + ("ok", "reason", "used", "u", "damping"):
        assert same(getattr(want, name), getattr(got, name)), name
    assert (got.cov_x is got.cov_x_apriori) == (want.cov_x is want.cov_x_apriori)
    assert list(vars(got)) == list(vars(want))  # every field, in order


@needs_kernel
def test_adjust_declines_to_the_python() -> None:
    """Nearly parallel LOPs (the axis-ratio guard), an untestable slot and a singular C_l: the
    kernel hands back and the Python gives its reason and numbers."""
    par = _bearings(np.array([[0.0, 1e4], [1e-3, 2e4], [2e-3, 3e4]]),
                    np.array([1e4, 2e4, 3e4]), np.array([10.0, 10.0, 10.0]), 0.0)
    A = np.array([[1.0, 0.0], [0.0, 1.0], [0.0, 1.0], [0.0, 1.0]])
    unt = Linearisation(A, np.array([1.0, 2.0, 2.5, 1.5]), np.diag([4.0, 9.0, 9.0, 16.0]))
    sing = Linearisation(A, np.array([1.0, 2.0, 2.5, 1.5]), np.zeros((4, 4)))
    for lin, x0, n in ((par, np.array([5.0, 1.0]), 3), (lambda x: unt, np.zeros(2), 4),
                       (lambda x: sing, np.zeros(2), 4)):
        got, want = _both_rows(lambda lin=lin: _RowsModel(lin), x0, np.ones(n, bool))
        assert not got.ok
        for name in ADJ_FIELDS + ("ok", "reason"):
            assert same(getattr(want, name), getattr(got, name)), name
    state = K.adjust(_RowsModel(lambda x: unt).rows, np.zeros(2), np.ones(4, bool), 1.0, 10,
                     COND_MAX, 1e4, False, 2.8)
    assert state is None or type(state) is tuple  # the untestable slot: never a result



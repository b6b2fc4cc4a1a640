"""The compiled measurement update (engine/native/kalman_update.c, through engine.fast.filter)
agrees with the reference (engine.filter.update.update, innovation_distance) to the tolerance
contract.

Compared: every array of the result (x, P, fix_cov, v̂, S, K, L⁻¹, w, the LS statistics), its
layout and the LOM test; on (a) the updates a short demo replay really makes and (b) random
states and rows around them — one to nine rows, templates and general H, fix-error columns,
angle rows, Joseph and the thesis' P update. Error paths (S not positive definite, a
non-positive variance, an infinite angle innovation) raise the same exception with the same
state.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

import engine.filter.update as U
import engine.run.session as session_mod
from engine import native
from engine.fast import filter as ff
from engine.filter import kalman as kf
from engine.filter import measurements as ms
from engine.filter.measurements import Measurement, _measurement
from engine.filter.params import FilterParams
from engine.filter.state import N_NAV, FilterState, add_fix_states
from tests.native.replay import record_parts, replay_patched
from tests.tolerance import RTOL, close

ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.skipif(native.kernel("kalman_update") is None,
                                reason="kernel kalman_update not built (or UVNAV_PURE=1)")


@pytest.fixture(autouse=True)
def _kernel_resolved() -> None:
    if ff.KU is None:
        pytest.skip("the kernel declined at its first-use check (uvnav --version says why)")


def fast_two(state: FilterState, a: Measurement, b: Measurement,
             params: FilterParams) -> U.UpdateResult:
    """The fast update of rows ``a`` (no fix-error keys) stacked before ``b``: one
    ``update_blocks`` call where it takes them (:func:`engine.fast.filter.update_two`), else
    the fast update of the stack."""
    if not (a.bias_keys or a.bias_cov is not None or a._cols is None or not a.z.shape[0]):
        r = ff.update_two(state, (a.z, a.R), a._cols, a.labels, a.angle_rows, a.H.shape[1], b,
                          params)
        if r is not None:
            return r  # type: ignore[no-any-return]
    return ff.update(state, ms.stack_measurements(a, b), params)


def same(a: object, b: object, rtol: float = RTOL) -> bool:
    """Equal to the tolerance contract (tests.tolerance; arrays: dtype, shape and strides
    identical, values within it; ``rtol`` widened for an ill-conditioned problem)."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        assert isinstance(a, np.ndarray) and isinstance(b, np.ndarray)
        return a.strides == b.strides and not close(a, b, rtol=rtol)
    if isinstance(a, float) and isinstance(b, float):
        return not close(a, b, rtol=rtol)
    return a == b


def _rtol(S: np.ndarray) -> float:
    """The contract's relative tolerance, or more for an ill-conditioned innovation VCV S: two
    correct solutions of S differ by up to cond(S) units in the last place (forward error),
    here cond(S)·1e-15."""
    return max(RTOL, float(np.linalg.cond(S)) * 1e-15) if S.size else RTOL


def _rtol_p(S: np.ndarray, prior: np.ndarray, post: np.ndarray) -> float:
    """:func:`_rtol` for the posterior P = P⁻ − K S Kᵀ, a difference of terms as large as the
    prior's: two correct evaluations differ by cond(S) units in the last place of P⁻'s largest
    entry, which is more than that of P's own largest entry when the update shrinks P (by
    3850 times, cond(S) 2.3e5, in the @example of test_random_updates_are_the_same that a fresh
    draw found: 1.4e-9 of P's scale apart, both correct)."""
    big = float(np.abs(post).max()) if post.size else 0.0
    shrink = float(np.abs(prior).max()) / big if big > 0.0 and math.isfinite(big) else 1.0
    return max(RTOL, float(np.linalg.cond(S)) * 1e-15 * max(shrink, 1.0)) if S.size else RTOL


def assert_same_update(state: FilterState, rows: Measurement, params: FilterParams) -> None:
    """The fast update() (kernel) and the reference's agree to the tolerance contract, or raise
    the same."""
    try:
        ref = U.update(state, rows, params)
    except Exception as exc:  # noqa: BLE001 — the kernel path must raise the same
        with pytest.raises(type(exc)) as got:
            ff.update(state, rows, params)
        assert str(got.value) == str(exc)
        if isinstance(exc, U.FilterDivergence):
            assert isinstance(got.value, U.FilterDivergence)
            assert same(got.value.state.x, exc.state.x) and same(got.value.state.P, exc.state.P)
        return
    new = ff.update(state, rows, params)
    rtol = _rtol(ref.S)
    for name in ("x", "P", "fix_cov"):
        assert same(getattr(new.state, name), getattr(ref.state, name),
                    _rtol_p(ref.S, state.P, ref.state.P) if name == "P" else rtol), name
    assert new.state.x.flags.writeable is False and new.state.P.flags.writeable is False
    assert (new.state.t, new.state.fix_states, new.state.fix_tau_s) == \
        (ref.state.t, ref.state.fix_states, ref.state.fix_tau_s)
    for name in ("innovation", "S", "K"):
        assert same(getattr(new, name), getattr(ref, name), rtol), name
    for name in ("l_inv", "w", "t"):
        assert same(getattr(new.ls, name), getattr(ref.ls, name), rtol), name
    assert new.ls.lom_reject == ref.ls.lom_reject and new.ls.identified == ref.ls.identified
    assert not close(vars(new.lom), vars(ref.lom), rtol=rtol) and new.labels == ref.labels
    p = rows.z.shape[0]
    for rows_slice in (slice(None), slice(1, None), slice(max(p - 2, 0), None), slice(0, 1),
                       slice(p, None)):
        assert same(ff.innovation_distance(new, rows_slice),
                    U.innovation_distance(ref, rows_slice), rtol), rows_slice


# --------------------------------------------------------------------------- (a) a replay


@pytest.fixture(scope="module")
def replay_updates() -> list[tuple[FilterState, Measurement, FilterParams]]:
    """The (state, rows, params) of every update of the first 200 demo epochs."""

    seen: list[tuple[FilterState, Measurement, FilterParams]] = []

    def record(state: FilterState, rows: Measurement, params: FilterParams) -> U.UpdateResult:
        seen.append((state, rows, params))
        return U.update(state, rows, params)

    # The cycle's updates: update(), and update_rows() / update_gated(), which are update() of
    # the rows' measurement and of the stack (test_update_rows_and_two_are_update,
    # test_update_rows_gated_is_update_and_distance).
    def gated(state: FilterState, zs: list[float], var: list[float], layout: ms.SensorLayout,
              b: Measurement, params: FilterParams) -> tuple[U.UpdateResult, float]:
        r = record(state, ms.stack_measurements(ms.rows_measurement(zs, var, layout), b), params)
        return r, U.innovation_distance(r, slice(len(zs), None))

    replay_patched([(session_mod, "choose_parts", record_parts(
        update=lambda _real: record,
        update_rows=lambda _real: lambda state, zs, var, layout, params: record(
            state, ms.rows_measurement(zs, var, layout), params),
        update_gated=lambda _real: gated))], 200)
    assert len(seen) > 300
    return seen


@pytest.fixture(scope="module")
def replay_blocks() -> list[tuple[str, tuple[object, ...]]]:
    """The arguments of every update_rows() and update_gated() (recorded as update_rows_two)
    of the first 100 demo epochs, and of update_two() of the same rows as a Measurement."""
    seen: list[tuple[str, tuple[object, ...]]] = []

    def recorder(as_name: str) -> object:
        def wrap(real: object) -> object:
            def recording(*a: object) -> object:
                seen.append((as_name, a))
                return real(*a)  # type: ignore[operator]
            return recording
        return wrap

    replay_patched([(session_mod, "choose_parts", record_parts(
        update_rows=recorder("update_rows"), update_gated=recorder("update_rows_two")))], 100)
    assert {n for n, _ in seen} == {"update_rows", "update_rows_two"}
    seen += [("update_two", (a[0], ms.rows_measurement(*a[1:4]), *a[4:]))
             for n, a in list(seen) if n == "update_rows_two"]
    return seen


def _same_result(got: U.UpdateResult, ref: U.UpdateResult) -> None:
    """Two update results alike to the tolerance contract: every array, float and field, in
    the same order."""
    assert list(vars(got)) == list(vars(ref)) and list(vars(got.state)) == list(vars(ref.state))
    for name in ("t", "x", "P", "fix_states", "fix_tau_s", "fix_cov"):
        assert same(getattr(got.state, name), getattr(ref.state, name)), name
    assert not got.state.fix_cov.flags.writeable and not ref.state.fix_cov.flags.writeable
    for name in ("innovation", "S", "K", "labels"):
        assert same(getattr(got, name), getattr(ref, name)), name
    for name in ("l_inv", "w", "t", "lom_reject"):
        assert same(getattr(got.ls, name), getattr(ref.ls, name)), name
    assert not close(vars(got.lom), vars(ref.lom))


def test_update_rows_and_two_are_update(replay_blocks, monkeypatch) -> None:
    """The fast update_rows(), update_rows_gated() and update_two() give the reference's
    update() of the rows' measurement and of the stack, on the cycle's calls and on inputs
    they hand to the general code: a fix-error state still missing, a prior of another shape,
    H wider than the state, rows without fix-error keys."""
    cases: list[tuple[str, tuple[object, ...]]] = list(replay_blocks)
    two = [a for n, a in replay_blocks if n == "update_two"]
    state, depth, lse, params = two[-1]
    rows_two = [a for n, a in replay_blocks if n == "update_rows_two"][-1]
    zs, var, layout = rows_two[1:4]
    cases.append(("update_rows_two", (state, [], [], layout, lse, params)))  # no depth row
    cases.append(("update_rows_two", (state, [int(zs[0])], var, layout, lse, params)))
    bare_ = FilterState(state.t, state.x[:N_NAV], state.P[:N_NAV, :N_NAV])
    cases.append(("update_rows_two", (bare_, zs, var, layout, lse, params)))
    assert lse.bias_keys and state.fix_states == ("fix_e", "fix_n")
    bare = FilterState(state.t, state.x[:N_NAV], state.P[:N_NAV, :N_NAV])
    cases.append(("update_two", (bare, depth, lse, params)))  # the states are added
    wide = _measurement(lse.z, lse.H, lse.R, lse.labels, (), lse.bias_keys,
                        np.eye(3), lse.bias_tau_s, lse._cols)
    cases.append(("update_two", (state, depth, wide, params)))  # prior 3×3: the general code
    plain = _measurement(lse.z, lse.H, lse.R, lse.labels, cols=lse._cols)
    cases.append(("update_two", (state, depth, plain, params)))
    cases.append(("update_two", (bare, depth, plain, params)))
    cases.append(("update_two", (state, plain, depth, params)))
    for name, a in cases:
        if name == "update_rows":
            st_, zs, var, layout, prm = a
            ref = U.update(st_, ms.rows_measurement(zs, var, layout), prm)
            _same_result(ff.update_rows(*a), ref)
            _same_result(U.update_rows(*a), ref)
        elif name == "update_rows_two":
            st_, zs, var, layout, y, prm = a
            x = ms.rows_measurement(zs, var, layout)
            ref = U.update(st_, ms.stack_measurements(x, y), prm)
            _same_result(ff.update_rows_gated(*a)[0], ref)
            _same_result(U.update_rows_gated(*a)[0], ref)
        else:
            st_, x, y, prm = a
            _same_result(fast_two(*a), U.update(st_, ms.stack_measurements(x, y), prm))


def test_update_rows_template_cache_follows_the_width(replay_blocks, monkeypatch) -> None:
    """update_rows()'s last H template (looked up by the layout's identity and n) is
    h_template's for each width in turn: a state with fix-error states, one without, again
    with; each update the one of update()."""
    rows = [a for n, a in replay_blocks if n == "update_rows"]
    wide = next(a for a in rows if a[0].n > N_NAV)
    st_, zs, var, layout, prm = wide
    bare = FilterState(st_.t, st_.x[:N_NAV], st_.P[:N_NAV, :N_NAV])
    monkeypatch.setattr(ff, "_ROWS_LAST", [(None, -1, None)])
    for s_ in (st_, bare, st_, st_):
        ref = U.update(s_, ms.rows_measurement(zs, var, layout), prm)
        _same_result(ff.update_rows(s_, zs, var, layout, prm), ref)
        last = ff._ROWS_LAST[0]
        if s_.n > N_NAV:
            assert last[0] is layout[1] and last[1] == s_.n
            assert last[2] is ms.h_template(layout[1], s_.n)


def test_update_rows_gated_is_update_and_distance(replay_blocks) -> None:
    """The fast update_rows_gated() is the reference's (the update of the stack and the
    innovation_distance() of the fix's rows, the last), the kernel's update_blocks with its
    gate answering every cycle's call but the first fix's; and so is the kernel's gate on other
    starts; an update the kernel declines is declined with the gate too."""
    two_ = [a for n, a in replay_blocks if n == "update_rows_two"]
    state, zs, var, layout, lse, params = two_[-1]
    cases = list(two_) + [(state, [], [], layout, lse, params)]  # no depth row: the stack
    k = ff.KU
    for a in cases:
        got, d = ff.update_rows_gated(*a)
        ref, d_ref = U.update_rows_gated(*a)
        _same_result(got, ref)
        assert same(d, d_ref)
        assert same(d, U.innovation_distance(ref, slice(len(a[1]), None)))
    gated = 0
    for a in two_:
        gated += ff.update_two(a[0], (a[1], a[2]), a[3][1], a[3][0], a[3][3], a[3][2].shape[1],
                               a[4], a[5], len(a[1])) is not None
    assert gated >= len(two_) - 1
    labels, cols, H, angle = layout
    Hw = U._bias_h(cols + lse._cols, (None,) * len(cols) + lse.bias_keys, state.fix_states,
                   state.n)
    p = len(zs) + 2
    for gate in range(p + 1):
        r = k.update_blocks(state, Hw, ((zs, var), (lse.z, lse.R)), angle + (), params.joseph,
                            U.IPSI, params.alpha, labels + lse.labels, None, gate)
        assert same(r[1], U.innovation_distance(r[0], slice(gate, None)))
    # a fix whose R makes S not positive definite: declined (None), as update_blocks without gate
    bad = -1e12 * np.eye(2)
    args = (state, Hw, ((zs, var), (lse.z, bad)), angle, params.joseph, U.IPSI, params.alpha,
            labels + lse.labels, None)
    assert k.update_blocks(*args) is None and k.update_blocks(*args, len(zs)) is None


def test_update_blocks_declines_what_it_does_not_cover(replay_blocks) -> None:
    """update_blocks() reads lists of floats and float64 arrays only, else None (the Python)."""
    k = ff.KU
    state, zs, var, layout, params = next(a for n, a in replay_blocks if n == "update_rows")
    labels, _cols, H, angle = layout
    H = ms.h_template(_cols, state.n)
    args = (angle, params.joseph, U.IPSI, params.alpha, labels)
    assert k.update_blocks(state, H, ((zs, var),), *args) is not None
    bad_z = [int(z) for z in zs]
    for blocks in (((bad_z, var),), ((zs, var[:-1]),), ((zs,),), [(zs, var)], ((), ),
                   ((np.array(zs, dtype=np.float32), var),), ((zs, np.eye(len(zs) + 1)),)):
        assert k.update_blocks(state, H, blocks, *args) is None


def test_the_updates_of_a_demo_replay_are_the_same(replay_updates) -> None:
    for state, rows, params in replay_updates:
        assert_same_update(state, rows, params)


def test_the_kernel_really_runs_on_the_replay(replay_updates, monkeypatch) -> None:
    """No silent fallback: the kernel answers for every update of the replay."""
    k = ff.KU
    answered = []
    real = k.update_result

    class Spy:
        def __getattr__(self, name: str) -> object:
            return getattr(k, name)

        @staticmethod
        def update_result(*args: object) -> object:
            out = real(*args)
            answered.append(out is not None)
            return out

    monkeypatch.setattr(ff, "KU", Spy())
    for state, rows, params in replay_updates[:50]:
        ff.update(state, rows, params)
    assert answered and all(answered)


def test_update_new_is_update_into_new_arrays(replay_updates) -> None:
    """update_new() makes the arrays update() fills, with the same bits and layout; x⁺, P⁺ and
    the filled LS statistics come back read-only, the rest writable."""
    k = ff.KU
    for state, rows, params in replay_updates[:40]:
        new, H = U._full_width(state, rows, params) if not rows.bias_keys else \
            U._with_bias_columns(state, rows, params)
        n, p = new.x.shape[0], rows.z.shape[0]
        outs = [np.empty(s) for s in ((n + 1 + p, p), p, (p, p), (n, p), n, (n, n), p)]
        ref = k.update(new.x, new.P, H, rows.z, rows.R, *outs, rows.angle_rows, params.joseph,
                       U.IPSI)
        got = k.update_new(new.x, new.P, H, rows.z, rows.R, rows.angle_rows, params.joseph,
                           U.IPSI)
        assert ref is not None and got is not None
        nis, t_ok, v, S, K, xn, Pn, t, Yc = got
        assert same(nis, ref[0]) and t_ok == ref[1]
        Y0, v0, S0, K0, xn0, Pn0, t0 = outs
        for a, b in ((v, v0), (S, S0), (K, K0), (xn, xn0), (Pn, Pn0), (Yc, Y0)):
            assert same(a, b)
        assert not xn.flags.writeable and not Pn.flags.writeable
        assert v.flags.writeable and S.flags.writeable and K.flags.writeable
        assert Yc.flags.writeable
        if t_ok:
            assert same(t, t0) and not t.flags.writeable


def test_update_result_builds_the_objects_the_python_builds(replay_updates) -> None:
    """update_result() (what the fast update() calls) builds the result as the reference's
    update(): the same classes, attributes in the same order, the LOM test's
    values, numpy views of one array for l_inv and w, and the bounds of any α and p (more pairs
    than the kernel remembers: its table is refilled)."""
    for i, (state, rows, params) in enumerate(replay_updates[:120]):
        if i % 3 == 0:
            alpha = (0.001, 0.01, 0.05, 0.1, 0.2, 0.3)[i % 6] + (i % 40) * 1e-4
            params = FilterParams(alpha=alpha, joseph=params.joseph, coloured=params.coloured)
        ref = U.update(state, rows, params)
        new = ff.update(state, rows, params)
        assert type(new) is U.UpdateResult and list(vars(new)) == list(vars(ref))
        assert type(new.state) is FilterState and list(vars(new.state)) == list(vars(ref.state))
        assert type(new.lom) is U.LomTest and list(vars(new.lom)) == list(vars(ref.lom))
        for name, value in vars(ref.lom).items():
            assert same(getattr(new.lom, name), value), name
        assert type(new.ls) is U.LsTest and list(vars(new.ls))[:3] == ["l_inv", "w", "lom_reject"]
        assert new.ls.l_inv.base is not None and new.ls.l_inv.base is new.ls.w.base
        assert new.labels is rows.labels
        assert new.state.fix_cov is state.fix_cov or rows.bias_keys


def test_ls_views_are_numpys_views(replay_updates) -> None:
    """The LsTest's l_inv and w the kernel makes from Y's data (without numpy's .T and
    indexing, once its probe found them equal) are the views numpy makes: same base, data,
    shape, strides and flags."""
    k = ff.KU
    for state, rows, params in replay_updates[:60]:
        new = ff.update(state, rows, params)
        Yc = new.ls.w.base
        n = new.state.x.shape[0]
        for got, ref in ((new.ls.l_inv, Yc.T[:, n + 1:]), (new.ls.w, Yc.T[:, n])):
            assert got.base is ref.base is Yc
            assert got.__array_interface__ == ref.__array_interface__
            assert got.flags == ref.flags and got.strides == ref.strides
    assert k._views_state() == 1


@pytest.mark.parametrize("joseph", [True, False])
def test_replay_states_with_other_rows(replay_updates, joseph: bool) -> None:
    """The replay's states with one row, two rows and the thesis' P update."""
    params = FilterParams(joseph=joseph)
    rng = np.random.default_rng(7)
    for state, _rows, _ in replay_updates[::15]:
        n = state.n
        for p in (1, 2):
            cols = tuple((int(c),) for c in rng.choice(N_NAV, p, replace=False))
            H = _template(cols, n)
            z = H.dot(state.x) + rng.normal(0.0, 1.0, p)
            R = np.diag(rng.uniform(0.5, 4.0, p))
            m = _measurement(z, H, R, tuple(f"r{i}" for i in range(p)),
                             angle_rows=(0,) if rng.random() < 0.5 else (), cols=cols)
            assert_same_update(state, m, params)


def _template(cols: tuple[tuple[int, ...], ...], n: int) -> np.ndarray:
    from engine.filter.measurements import h_template

    return h_template(cols, n)


# --------------------------------------------------------------------------- (b) random


def _state(rng: np.random.Generator, fix: int, scale: float) -> FilterState:
    x = np.concatenate([rng.normal(0.0, 1e3, 3), [abs(rng.normal(3.0, 2.0))],
                        [rng.uniform(-1.0, 7.5)], rng.normal(0.0, 0.05, 1),
                        rng.normal(0.0, 0.3, 2), rng.normal(0.0, 0.01, 3)])
    A = rng.normal(size=(N_NAV, N_NAV)) * rng.uniform(0.01, 10.0, N_NAV) * scale
    s = FilterState(float(rng.uniform(0, 1e4)), x, A @ A.T + np.eye(N_NAV) * 1e-3)
    if fix:
        keys = ("fix_e", "fix_n", "lop_b")[:fix]
        B = rng.normal(size=(fix, fix)) * 5.0
        s = add_fix_states(s, keys, B @ B.T + np.eye(fix), FilterParams(coloured=True),
                           tuple(rng.choice([180.0, 240.0, 1800.0], fix)))
        xs = np.array(s.x)
        xs[N_NAV:] = rng.normal(0.0, 3.0, fix)
        G = rng.normal(size=(s.n, s.n))
        s = FilterState(s.t, xs, s.P + 0.01 * (G @ G.T), s.fix_states, s.fix_tau_s, s.fix_cov)
    return s


@settings(max_examples=150, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), p=st.integers(1, 9), fix=st.integers(0, 3),
       template=st.booleans(), joseph=st.booleans(), narrow=st.booleans(),
       scale=st.sampled_from([1e-3, 1.0, 1e3]), r_scale=st.sampled_from([1e-6, 1.0, 1e4]))
# S numerically singular: the reference's variance after the update is ≤ 0 (cond(S) ~ 3e11)
@example(seed=742065, p=7, fix=0, template=True, joseph=False, narrow=False, scale=1e3,
         r_scale=1e-6)
# cond(S) ~ 2e16: the kernel's Cholesky of S fails where LAPACK's does not (the distance)
@example(seed=3, p=9, fix=3, template=True, joseph=True, narrow=True, scale=1e3, r_scale=1e-6)
# P shrinks 3850 times (cond(S) 2.3e5): the posterior's cancellation, not a wrong update
@example(seed=2585850601, p=9, fix=2, template=False, joseph=False, narrow=True, scale=1e3,
         r_scale=1e-6)
def test_random_updates_are_the_same(seed: int, p: int, fix: int, template: bool, joseph: bool,
                                     narrow: bool, scale: float, r_scale: float) -> None:
    rng = np.random.default_rng(seed)
    s = _state(rng, fix, scale)
    n = s.n
    width = N_NAV if narrow else n
    if template:
        cols = tuple(tuple(int(c) for c in rng.choice(width, int(rng.integers(1, 3)),
                                                      replace=False)) for _ in range(p))
        H = _template(cols, width)
    else:
        cols = None
        H = rng.normal(size=(p, width))
    z = H.dot(s.x[:width]) + rng.normal(0.0, 3.0, p)
    C = rng.normal(size=(p, p))
    D = np.diag(10.0 ** rng.uniform(-3.0, 3.0, p)) if rng.random() < 0.5 else np.eye(p)
    R = D @ (C @ C.T + np.eye(p)) @ D * r_scale  # rows of L⁻¹ with a wide range (LS sums)
    angle_rows = tuple(int(i) for i in rng.choice(p, int(rng.integers(0, min(p, 2) + 1)),
                                                  replace=False))
    m = _measurement(z, H, R, tuple(f"r{i}" for i in range(p)), angle_rows=angle_rows,
                     cols=cols)
    assert_same_update(s, m, FilterParams(joseph=joseph, coloured=bool(fix)))


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), joseph=st.booleans())
def test_random_updates_with_fix_error_columns_are_the_same(seed: int, joseph: bool) -> None:
    """Rows with fix-error keys (states added or their VCV renewed) and a depth row."""
    rng = np.random.default_rng(seed)
    params = FilterParams(joseph=joseph, coloured=True)
    s = _state(rng, int(rng.integers(0, 3)), 1.0)
    C = rng.normal(size=(2, 2)) * rng.uniform(1.0, 30.0)
    C = C @ C.T + np.eye(2)
    fix_xy = (float(s.x[0] + rng.normal(0, 20)), float(s.x[1] + rng.normal(0, 20)))
    lse = kf.lse_measurement(*fix_xy, C, params)
    depth = kf.sensor_measurement(s, depth_m=float(rng.normal(20.0, 5.0)), params=params)
    for rows in (lse, depth, kf.stack_measurements(depth, lse)):
        assert_same_update(s, rows, params)


# --------------------------------------------------------------------------- error paths


def _nav_rows(state: FilterState, R: np.ndarray, z: np.ndarray | None = None,
              angle_rows: tuple[int, ...] = ()) -> Measurement:
    cols = ((0,), (4,))
    H = _template(cols, state.n)
    return _measurement(H.dot(state.x) + 1.0 if z is None else z, H, R, ("x", "psi"),
                        angle_rows=angle_rows, cols=cols)


def test_a_non_positive_definite_s_raises_the_same() -> None:
    s = _state(np.random.default_rng(3), 0, 1.0)
    R = np.diag([-1e12, 1.0])
    with pytest.raises(U.FilterDivergence, match="not positive definite") as got:
        ff.update(s, _nav_rows(s, R), FilterParams())
    assert got.value.state is s
    assert_same_update(s, _nav_rows(s, R), FilterParams())


def test_a_non_positive_variance_raises_the_same() -> None:
    s = _state(np.random.default_rng(4), 0, 1.0)
    R = np.diag([1.0, -0.5 * float(s.P[4, 4])])  # S stays PD; P[4, 4] goes negative
    assert_same_update(s, _nav_rows(s, R), FilterParams(joseph=False))
    assert_same_update(s, _nav_rows(s, R), FilterParams(joseph=True))


def test_the_kernel_declines_at_the_boundary_and_the_reference_decides() -> None:
    """At the boundary of positive definiteness (docs/PERFORMANCE.md, the tolerance contract)
    the kernel returns None: S not positive definite or near-singular in distance(), a
    variance shrunk to within 1e-13·tr(S)·tr(S⁻¹) of zero in the update; the fast functions
    then give the reference's answer. A plain S is answered: √(2²/4 + 3²/9) = √2."""
    k = ff.KU
    v = np.array([2.0, 3.0])
    assert same(k.distance(v, np.diag([4.0, 9.0]), 0, 2), math.sqrt(2.0))
    not_pd = np.array([[1.0, 2.0], [2.0, 1.0]])
    near = np.array([[1.0, 1.0], [1.0, 1.0 + 4e-15]])  # pivot 4e-15·S_11: rounding's choice
    for S in (not_pd, near):
        assert k.distance(v, S, 0, 2) is None
        u = dataclasses.replace(U._empty_update(_state(np.random.default_rng(1), 0, 1.0)),
                                innovation=v, S=S)
        assert same(ff.innovation_distance(u), U.innovation_distance(u))
    assert ff.innovation_distance(u) == U.innovation_distance(u)
    # x observed with σ 1e-6 m on a prior σ of 1e3 m: P⁺_xx / P_xx ≈ 1e-18, the reference's call
    s = FilterState(0.0, np.zeros(N_NAV), np.diag(np.full(N_NAV, 1e6)))
    rows = _nav_rows(s, np.diag([1e-12, 1.0]))
    new, H = U._full_width(s, rows, FilterParams())
    assert k.update_result(new, H, rows.z, rows.R, (), False, U.IPSI, 0.05, rows.labels) is None
    assert_same_update(s, rows, FilterParams(joseph=False))
    assert_same_update(s, rows, FilterParams(joseph=True))


@pytest.mark.parametrize("bad", [math.inf, -math.inf, math.nan])
def test_a_non_finite_angle_innovation_does_what_python_does(bad: float) -> None:
    s = _state(np.random.default_rng(5), 0, 1.0)
    z = np.array([1.0, bad])
    assert_same_update(s, _nav_rows(s, np.eye(2), z=z, angle_rows=(1,)), FilterParams())


def test_unusual_layouts_fall_back_with_the_same_bits() -> None:
    s = _state(np.random.default_rng(6), 1, 1.0)
    Pf = np.asfortranarray(s.P)
    sf = FilterState(s.t, s.x, Pf, s.fix_states, s.fix_tau_s, s.fix_cov)
    rows = _nav_rows(s, np.asfortranarray(np.array([[2.0, 0.3], [0.3, 1.0]])))
    assert_same_update(sf, rows, FilterParams())
    assert_same_update(s, rows, FilterParams())


def test_an_empty_update_and_a_strided_distance() -> None:
    s = _state(np.random.default_rng(8), 0, 1.0)
    empty = _measurement(np.zeros(0), np.zeros((0, N_NAV)), np.zeros((0, 0)), ())
    assert ff.update(s, empty, FilterParams()).lom.verdict == "none"
    u = ff.update(s, _nav_rows(s, np.eye(2)), FilterParams())
    assert same(ff.innovation_distance(u, slice(None, None, -1)),
                U.innovation_distance(u, slice(None, None, -1)))


# --------------------------------------------------------------------------- pure path


def test_the_reference_loads_no_scipy_at_import() -> None:
    """Importing the filter loads no SciPy (start-up time): its LAPACK/BLAS on first use."""
    import subprocess
    import sys

    code = ("import sys, engine.filter.update as U\n"
            "assert 'scipy' not in sys.modules\n")
    subprocess.run([sys.executable, "-c", code], cwd=ROOT, check=True)


def test_update_blocks_answers_the_cycle(replay_blocks, monkeypatch) -> None:
    """No silent fallback: update_blocks() answers every update_rows()/update_rows_gated()/
    update_two() of the replay but the first fix's (whose fix-error states are added by the
    general code)."""
    k = ff.KU
    answered = []
    real = k.update_blocks

    class Spy:
        def __getattr__(self, name: str) -> object:
            return getattr(k, name)

        @staticmethod
        def update_blocks(*args: object) -> object:
            out = real(*args)
            answered.append(out is not None)
            return out

    monkeypatch.setattr(ff, "KU", Spy())
    calls = {"update_rows": ff.update_rows, "update_rows_two": ff.update_rows_gated,
             "update_two": fast_two}
    for name, a in replay_blocks:
        calls[name](*a)
    assert len(answered) >= len(replay_blocks) - 3 and all(answered)

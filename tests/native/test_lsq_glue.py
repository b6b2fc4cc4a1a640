"""The fix's glue shortcuts give the same objects and bits as the code they stand for.

* ``engine.native.lsq.row`` (the LOP table rows of :func:`engine.lsq.fix._lop_rows`) makes the
  same frozen slotted ``LopRow`` as its generated ``__init__``: on the rows of a short demo
  replay (kernel on and off) and on hypothesis-generated field values; only a plain slotted
  class can be bound; the pure path (``UVNAV_PURE=1``) uses ``LopRow`` itself.
* ``_Model.arrays`` (what :func:`engine.lsq.adjustment.gauss_newton` calls when the model
  offers it) gives the arrays of ``_Model.__call__``, and a whole adjustment with and without
  it is the same to the bit.
* The one-call fix (``engine.fast.lsq.compute_fix``): ``tail`` (the linear-range check and
  the table of the systems' readings) is ``fix._tail``; ``adjust_tested`` (adjust, the
  unit-variance test, the Adjustment and a quiet fix's TestedAdjustment built in C, the start
  arrays made of compute_fix's tuple and list) is ``adjust`` + ``first_adjustment`` +
  ``tested_quiet`` of engine.fast.lsq; ``estimate`` (a quiet fix's FixResult) is
  ``fix._at_estimate``; each declines what the Python must say.
"""

from __future__ import annotations

import dataclasses
import gc
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import engine.fast as fast
import engine.lsq.fix as fix
from engine import native
from engine.fast import lsq as fast_lsq
from engine.lsq.adjustment import COND_MAX, MAX_AXIS_RATIO, gauss_newton
from engine.lsq.fix import LopRow
from tests.native.replay import replay_patched
from tests.tolerance import close

K = fast_lsq.kernel()
needs_kernel = pytest.mark.skipif(K is None, reason="engine.native.lsq not built or not bound")
ROOT = Path(__file__).resolve().parents[2]
FIELDS = tuple(f.name for f in dataclasses.fields(LopRow))


def same(a: Any, b: Any) -> bool:
    """Equal to the tolerance contract (tests.tolerance): arrays by shape, dtype and values
    within it; floats within it; objects of the same type by their fields (dataclasses) or
    ``==``."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return not close(np.asarray(a), np.asarray(b))
    return not close(a, b)


def same_row(got: Any, want: LopRow, same_values: bool = True) -> bool:
    """``got`` is the LopRow ``want``: its type, every field within the tolerance contract, and
    its hash too when both hold the same value objects (``same_values``; not ``==``, which from
    Python 3.13 on compares field by field, so a NaN field makes a row unequal to itself)."""
    if type(got) is not LopRow or not same(got, want):
        return False
    if same_values and all(getattr(got, f) is getattr(want, f) for f in FIELDS):
        return hash(got) == hash(want)
    return True


# ------------------------------------------------------------------------------------------
# (a) what a replay really produces


@pytest.fixture(scope="module")
def replay() -> dict[str, list[Any]]:
    """The compute_fix calls of the first 200 demo epochs and the model of each fix."""

    rec: dict[str, list[Any]] = {"calls": [], "models": []}
    compute, model_cls = fast_lsq.compute_fix, fix._Model

    def record(*a: Any, **k: Any) -> Any:
        rec["calls"].append((a, k))
        return compute(*a, **k)

    class Model(model_cls):  # type: ignore[misc, valid-type]
        def __init__(self, *a: Any, **k: Any) -> None:
            super().__init__(*a, **k)
            rec["models"].append(self)

    fast.parts()  # the probes made before recording (they call compute_fix too)
    replay_patched([(fast_lsq, "compute_fix", record), (fix, "_Model", Model)], 200)
    return rec


def _fixes(calls: list[Any], pure: bool, mp: pytest.MonkeyPatch) -> list[fix.FixResult]:
    """Each recorded call by the compiled compute_fix (engine.fast.lsq), or with ``pure`` by
    the reference's (its own systems)."""
    try:
        if pure:
            return [fix.compute_fix(*a, **dict(k, systems=None)) for a, k in calls]
        return [fast_lsq.compute_fix(*a, **k) for a, k in calls]
    finally:
        mp.undo()


@needs_kernel
def test_replay_rows_are_the_dataclass_rows(replay: dict[str, list[Any]]) -> None:
    mp = pytest.MonkeyPatch()
    native_fixes = _fixes(replay["calls"], False, mp)
    pure_fixes = _fixes(replay["calls"], True, mp)
    n = 0
    for got, want in zip(native_fixes, pure_fixes, strict=True):
        assert len(got.lops) == len(want.lops)
        for g, w in zip(got.lops, want.lops, strict=True):
            assert same_row(g, w, same_values=False)
            assert same_row(K.row(*(getattr(w, f) for f in FIELDS)), w)
            n += 1
    assert n > 500


def test_replay_model_arrays_are_the_linearisation(replay: dict[str, list[Any]]) -> None:
    models = replay["models"]
    assert len(models) > 100
    for (a, _k), model in zip(replay["calls"], models, strict=False):
        x = np.array(a[2], dtype=float)
        lin = model(x)
        A, b, Cl = model.arrays(x)
        assert same(A, lin.A) and same(b, lin.b) and same(Cl, lin.Cl)
        Al, bl, Cl2 = model.rows(x)  # the lists the compiled adjustment gathers from
        assert type(Al) is list and type(bl) is list
        assert all(type(v) is float for v in Al + bl)
        assert same(np.array(Al).reshape(-1, 2), lin.A) and same(np.array(bl), lin.b)
        assert same(Cl2, lin.Cl)


def test_replay_adjustments_with_and_without_arrays(replay: dict[str, list[Any]]) -> None:
    """gauss_newton on the model (rows or arrays taken), on the model without its rows (arrays
    taken) and on a plain function calling it (the Linearisation path) gives the same
    Adjustment, for consecutive and scattered used slots."""

    class ArraysOnly:
        def __init__(self, model: Any) -> None:
            self.model, self.arrays = model, model.arrays

        def __call__(self, x: np.ndarray) -> Any:
            return self.model(x)

    for _ in (0,):
        mp = pytest.MonkeyPatch()
        try:
            for (a, _k), model in list(zip(replay["calls"], replay["models"], strict=False))[:60]:
                x0 = np.array(a[2], dtype=float)
                n = model.n_slots
                for used in (np.array([True] * 5 + [False] * (n - 5)),
                             np.array([True, False, True, True, True] + [False] * (n - 5))):
                    want = gauss_newton(lambda x, _m=model: _m(x), x0, used)
                    for got in (gauss_newton(model, x0, used),
                                gauss_newton(ArraysOnly(model), x0, used)):
                        for f in dataclasses.fields(want):
                            if f.name != "variance_test":
                                assert same(getattr(got, f.name), getattr(want, f.name)), f.name
                        assert got.variance_test == want.variance_test
        finally:
            mp.undo()


def _variants(calls: list[Any]) -> list[tuple[tuple[Any, ...], dict[str, Any]]]:
    """The recorded calls, and some of them with a GPS blunder (the snooping loop after the
    one-call adjustment), under each rejection policy, without GPS (Decca alone: category
    III) and with a robust estimator (the layers only)."""
    out = list(calls)
    for i, (a, k) in enumerate(calls[:90:3]):
        vals = dict(k.get("readings") or {})
        g = vals.get("gps")
        if g is not None:
            vals["gps"] = dataclasses.replace(g, x_m=g.x_m + 40.0 * (i % 5), y_m=g.y_m - 25.0)
        st_ = k["settings"]
        est = ("lsq", "lsq", "huber", "lsq")[i % 4]
        k2 = dict(k, readings=vals,
                  settings=dataclasses.replace(st_, lop_reject="YNA"[i % 3], estimator=est,
                                               scale_vcv=bool(i % 2)))
        out.append((a, k2))
        if g is not None and i % 4 == 0:
            out.append((a, dict(k2, readings=dict(vals, gps=None))))
    return out


@needs_kernel
def test_replay_one_call_fix_is_the_layers(replay: dict[str, list[Any]]) -> None:
    """compute_fix's one-call path (``adjust`` and ``quiet`` called by compute_fix itself, the
    layers only when there is more to do) gives the FixResult of adjust_with_testing's layers
    and of the pure Python, field by field to the bit (the adjustment, its tests, the table,
    messages), on the replay's fixes and on blundered, re-weighted and GPS-less variants."""
    calls = _variants(replay["calls"])
    mp = pytest.MonkeyPatch()
    got = _fixes(calls, False, mp)
    mp.setattr(fast_lsq, "quick_settings", lambda s: None)
    layers = _fixes(calls, False, mp)
    pure = _fixes(calls, True, mp)
    kinds = set()
    for g, w, p in zip(got, layers, pure, strict=True):
        assert same(g, w) and same(g, p)
        if g.tested is not None:
            kinds.add((g.tested.rejected != (), g.tested.candidate is not None,
                       g.tested.not_identifiable, g.tested.estimator))
    assert len(kinds) >= 5, kinds


def _adjust(rows: Any, x0: np.ndarray, used: np.ndarray) -> Any:
    return K.adjust(rows, x0, used, 1.0, 10, COND_MAX, MAX_AXIS_RATIO, False, 2.8)


@needs_kernel
def test_replay_adjust_of_the_model_spec_is_adjust_of_rows(
        replay: dict[str, list[Any]]) -> None:
    """``adjust`` given the model's spec (it makes the lists, the copy of the identity and the
    Point and calls each system's linearise itself) returns what it returns calling
    ``_Model.rows``, for consecutive and scattered used slots, from the replay's start points
    and from far off (where it hands back); a linearise that raises gives the same hand-back;
    a spec it cannot read is declined (None)."""
    models = replay["models"]
    for (a, _k), model in list(zip(replay["calls"], models, strict=False))[:80]:
        n = model.n_slots
        for x0 in (np.array(a[2], dtype=float), np.array(a[2], dtype=float) + 3e5):
            for used in (np.array([True] * 5 + [False] * (n - 5)),
                         np.array([True, False, True, True, True] + [False] * (n - 5))):
                want, got = _adjust(model.rows, x0, used), _adjust(fast_lsq.spec(model), x0, used)
                assert type(got) is type(want)
                if type(want) is dict:
                    assert list(got) == list(want)
                    assert all(same(got[f], want[f]) for f in want if f != "used"), x0
                else:
                    assert same(got, want)
    model = models[0]
    x0 = np.array(replay["calls"][0][0][2], dtype=float)
    used = np.array([True] * 5 + [False] * (model.n_slots - 5))

    class Boom:
        def linearise(self, *a: Any) -> None:
            raise ValueError("boom")

    sp = fast_lsq.spec(model)
    bad = ((sp[0][0], (2, Boom())), *sp[1:])
    assert _adjust(bad, x0, used) is None
    assert _adjust(lambda x: model.rows(x) and Boom().linearise(), x0, used) is None
    for spec in (sp[:4], (list(sp[0]), *sp[1:]), (*sp[:4], np.eye(model.n_slots + 1)),
                 (*sp[:4], np.asfortranarray(np.eye(model.n_slots))[:, ::-1])):
        assert _adjust(spec, x0, used) is None


# ------------------------------------------------------------------------------------------
# (b) generated values

_float = st.floats(allow_nan=True, allow_infinity=True)


@needs_kernel
@settings(max_examples=200, deadline=None)
@given(st.integers(-5, 40), st.sampled_from(["GPS", "Decca", "KF", "periscope"]),
       st.text(max_size=8), st.lists(_float, min_size=10, max_size=10), st.booleans(),
       st.sampled_from(["", "accept", "monitor", "reject"]))
def test_generated_rows(slot: int, system: str, pattern: str, vals: list[float], used: bool,
                        verdict: str) -> None:
    args = (slot, system, pattern, *vals[:5], used, *vals[5:9], verdict)
    assert len(args) == len(FIELDS)
    assert same_row(K.row(*args), LopRow(*args))


@needs_kernel
def test_rows_are_frozen_and_keep_their_references() -> None:
    value = object.__new__(type("Marker", (), {}))
    before = sys.getrefcount(value)
    rows = [K.row(1, "s", "p", 0.0, 0.0, 0.0, 0.0, 0.0, True, 1.0, 2.0, 3.0, 4.0, value)
            for _ in range(100)]
    assert sys.getrefcount(value) == before + 100
    with pytest.raises(dataclasses.FrozenInstanceError):
        rows[0].slot = 2  # type: ignore[misc]
    import pickle

    row = K.row(*(rows[0].slot, *(getattr(rows[0], f) for f in FIELDS[1:-1]), "accept"))
    assert pickle.loads(pickle.dumps(row)) == row
    assert dataclasses.replace(rows[0], slot=3).slot == 3
    del rows
    gc.collect()
    assert sys.getrefcount(value) == before


@needs_kernel
def test_row_binding_refuses_other_classes() -> None:
    @dataclasses.dataclass(frozen=True)
    class WithDict:
        a: float

    @dataclasses.dataclass(frozen=True, slots=True)
    class Slotted:
        a: float
        b: float

    with pytest.raises(TypeError):
        K._bind_row(WithDict, ("a",))
    with pytest.raises(TypeError):
        K._bind_row(Slotted, ("a",))  # not every slot named
    with pytest.raises(AttributeError):
        K._bind_row(Slotted, ("a", "c"))
    K._bind_row(LopRow, FIELDS)  # rebound to LopRow (as engine.fast.lsq binds it)
    with pytest.raises(TypeError):
        K.row(1, 2)


# ------------------------------------------------------------------------------------------
# the pure path


def test_pure_env_makes_plain_rows(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(native.PURE_ENV, "1")
    fast._verdict.cache_clear()
    try:
        from engine.run.parts import choose

        assert choose().compute_fix is fix.compute_fix  # the reference makes LopRow itself
    finally:
        fast._verdict.cache_clear()
    assert not math.isnan(LopRow(0, "s", "p", 0.0, 0.0, 0.0, 0.0, 0.0, True).read)


# ------------------------------------------------------------------------------------------
# lop_rows: the whole table in one call


def _adj_like(w: list[float], seed: int) -> Any:
    """What the table reads of an Adjustment: stats_block (9, n), v (n,), used (n,)."""
    import types

    rng = np.random.default_rng(seed)
    n = len(w)
    block = rng.uniform(0.0, 50.0, (9, n))
    block[1] = w
    used = rng.random(n) < 0.7
    v = rng.normal(0.0, 20.0, n)
    v[~used] = np.nan
    return types.SimpleNamespace(stats_block=block, v=v, used=used)


def _groups(n: int, seed: int) -> list[tuple[int, list[Any]]]:
    from engine.systems.base import LopReading

    rng = np.random.default_rng(seed)
    cut = int(rng.integers(0, n + 1))
    mk = lambda i: LopReading(i, "Decca", f"P{i}", float(rng.normal()), 0.25 * i,  # noqa: E731
                              float(rng.normal()), float(rng.uniform(0, 360)))
    return [(0, [mk(i) for i in range(cut)]), (cut, [mk(i) for i in range(n - cut)])]


def _ref_lop_rows(adj: Any, groups: list[tuple[int, list[Any]]], alpha: float) -> list[Any]:
    """The reference table (fix._lop_rows) of ``groups``: each a system whose readings are
    the group's, its slots from the group's first."""
    import types

    sets, layout = {}, {}
    for i, (first, readings) in enumerate(groups):
        sets[f"s{i}"] = types.SimpleNamespace(readings=lambda p, _r=readings: _r)
        layout[f"s{i}"] = range(first, first + len(readings))
    return fix._lop_rows(adj, sets, None, alpha, None, layout)  # type: ignore[arg-type]


@needs_kernel
@settings(max_examples=200, deadline=None)
@given(st.lists(st.one_of(st.floats(-6.0, 6.0), st.just(math.nan), st.just(1.96),
                          st.just(2.576), st.just(-2.576)), min_size=1, max_size=10),
       st.integers(0, 2**32 - 1), st.sampled_from([0.05, 0.01, 0.1]))
def test_lop_rows_are_the_pythons(w: list[float], seed: int, alpha: float) -> None:
    adj = _adj_like(w, seed)
    groups = _groups(len(w), seed)
    got = K.lop_rows(groups, adj.stats_block, adj.v, adj.used,
                     fix.w_critical(alpha), fix.REJECT_BOUND)
    want = _ref_lop_rows(adj, groups, alpha)
    assert len(got) == len(want)
    for g, r in zip(got, want, strict=True):
        assert same_row(g, r, same_values=False)


@needs_kernel
def test_lop_rows_declines_what_the_python_must_do() -> None:
    adj = _adj_like([0.5, 1.0, 3.0], 1)
    args = (adj.stats_block, adj.v, adj.used, 1.96, 2.576)
    assert K.lop_rows([(2, _groups(3, 1)[1][1])], *args) is None  # a slot beyond n
    assert K.lop_rows([(-1, _groups(3, 1)[1][1])], *args) is None  # a negative slot
    assert K.lop_rows([(0, (1, 2))], *args) is None  # not a list of readings
    assert K.lop_rows([(0, [object()])], *args) is None  # not a reading
    assert K.lop_rows([], *args) == []


# ------------------------------------------------------------------------------------------
# tail: the linear-range check and the table of the systems' readings in one call


def _tail_calls(replay: dict[str, list[Any]]) -> list[tuple[Any, ...]]:
    """The arguments ``tail`` takes for every table of the replay's fixes and of their
    variants (the reference's _tail calls, its arguments as the kernel takes them)."""
    calls: list[tuple[Any, ...]] = []
    real = fix._tail

    def record(adj: Any, problem: Any, p_hat: Any, used: Any, check: Any, l1: Any,
               alpha: float) -> Any:
        calls.append((problem.sets, problem.spans, p_hat, used, check, l1, adj.stats_block,
                      adj.v, adj.used, fix.w_critical(alpha), fix.REJECT_BOUND))
        return real(adj, problem, p_hat, used, check, l1, alpha)

    mp = pytest.MonkeyPatch()
    mp.setattr(fix, "_tail", record)
    mp.setattr(K, "estimate", lambda *a: None)  # _at_estimate, which calls _tail
    try:
        _fixes(_variants(replay["calls"]), False, mp)
    finally:
        mp.undo()
    return calls


def _twin(a: tuple[Any, ...], alpha: float = 0.05) -> Any:
    """The reference's fix._tail on what ``tail`` was given (``a``: its arguments)."""
    import types

    from engine.systems import registry

    sets, spans, p_hat, used, check, l1, stats, v, used_arr, k, bound = a
    assert k == fix.w_critical(alpha) and bound == fix.REJECT_BOUND
    adj = types.SimpleNamespace(stats_block=stats, v=v, used=used_arr, cov_x_apriori=None)
    problem = types.SimpleNamespace(sets=sets, spans=spans, layout=registry.layout())
    return fix._tail(adj, problem, p_hat, used, check, l1, alpha)  # type: ignore[arg-type]


@needs_kernel
def test_replay_tail_is_the_python(replay: dict[str, list[Any]]) -> None:
    """``tail`` gives the reference _tail's rows (to the bit) on every call of the replay's
    fixes and their variants (GPS + Decca, Decca alone, blunders), and declines (None) what the
    Python must say: beyond the linear range (a huge λ1), a check without λ1, a system raising."""
    calls = _tail_calls(replay)
    assert len(calls) > 150
    n_rows = 0
    for a in calls:
        if a[4] and a[5] is None:  # ScaleVCV: λ1 of the a priori C_x̂ not at hand
            assert K.tail(*a) is None
            continue
        got, want = K.tail(*a), _twin(a)
        assert type(want) is tuple and type(got) is tuple and len(got) == len(want)
        for g, w in zip(got, want, strict=True):
            assert same_row(g, w, same_values=False)
            n_rows += 1
        if a[4]:
            big = (*a[:5], 1e30, *a[6:])
            assert K.tail(*big) is None and isinstance(_twin(big), str)
            assert K.tail(*a[:5], None, *a[6:]) is None
            nan = (*a[:5], math.nan, *a[6:])  # sqrt(max(nan, 0)) is nan: beyond, as Python
            assert K.tail(*nan) is None and isinstance(_twin(nan), str)
            neg = (*a[:5], -4.0, *a[6:])  # max(l1, 0.0): a = 0
            assert same(K.tail(*neg), _twin(neg))
        no_check = (*a[:4], False, None, *a[6:])
        assert same(K.tail(*no_check), _twin(no_check))
    assert n_rows > 500

    class Boom:
        def nearest_station_m(self, *a: Any) -> float:
            raise ValueError("boom")

        def readings(self, *a: Any) -> list[Any]:
            raise ValueError("boom")

    class NotFloat(Boom):
        def nearest_station_m(self, *a: Any) -> float:
            return 5  # an int: the Python's min() would take it, the kernel leaves it

    a = calls[0]
    for bad in (Boom(), NotFloat()):
        sets = dict(a[0], gps=bad)
        assert K.tail(sets, *a[1:]) is None
        assert K.tail(sets, a[1], a[2], a[3], False, None, *a[6:]) is None  # readings raise
    assert K.tail(dict(a[0], other=Boom()), *a[1:]) is None  # no span
    assert K.tail(a[0], a[1], a[2], tuple(a[3]), *a[4:]) is None  # used not a list


# ------------------------------------------------------------------------------------------
# adjust_tested: adjust() and the tests of a quiet fix, the results built by the kernel


@needs_kernel
def test_replay_adjust_tested_is_the_python(replay: dict[str, list[Any]]) -> None:
    """``adjust_tested`` gives what ``adjust`` followed by first_adjustment and tested_quiet
    gives (a quiet fix's TestedAdjustment, else the Adjustment, field by field to the bit), on
    the replay's models with their used slots and fewer, at several σ0² (the unit variance
    accepted and rejected) and α; a dict where α or σ0² is not a float, adjust()'s hand-backs
    as they are."""
    from engine.lsq.adjustment import Adjustment
    from engine.lsq.snooping import TestedAdjustment

    kinds: set[tuple[str, bool]] = set()
    for (a, _k), model in list(zip(replay["calls"], replay["models"], strict=False))[:80]:
        n = model.n_slots
        x0 = np.array(a[2], dtype=float)
        for used in (np.array([True] * 5 + [False] * (n - 5)),
                     np.array([True, True, False, True, False] + [False] * (n - 5)),
                     np.array([True, False, True, True, True] + [False] * (n - 5))):
            for alpha, s02 in ((0.05, 1.0), (0.01, 1e-3), (0.1, 50.0), (0.05, 0.2)):
                base = (fast_lsq.spec(model), x0, used, 1.0, 10, COND_MAX, MAX_AXIS_RATIO,
                        False, 2.8)
                kw = (fix.w_critical(alpha), fix.REJECT_BOUND, "A", "lsq")
                got = K.adjust_tested(*base, alpha, s02, *kw)
                # x0 as compute_fix's tuple, used as its list: the arrays made by the kernel
                lists = K.adjust_tested(fast_lsq.spec(model), tuple(x0.tolist()), used.tolist(),
                                        *base[3:], alpha, s02, *kw)
                assert type(lists) is type(got) and same(lists, got)
                adj_l = lists if type(lists) is Adjustment else lists.adjustment
                assert adj_l.used.flags.writeable and adj_l.used.flags.c_contiguous
                assert same(adj_l.used, used)
                state = K.adjust(*base)
                assert type(state) is dict
                first = fast_lsq.first_adjustment(state, alpha, s02)
                want = fast_lsq.tested_quiet(first, kw[0], "A", "lsq", K) or first
                kinds.add((type(got).__name__, got.variance_test is None
                           or got.variance_test.accepted))
                if type(got) is Adjustment:  # more to do: the caller's tested_quiet
                    assert type(want) is Adjustment or not want.variance_test.accepted
                    got = fast_lsq.tested_quiet(got, kw[0], "A", "lsq", K) or got
                assert type(got) is type(want) and same(got, want)
                if type(got) is TestedAdjustment:
                    assert same(got.adjustment, want.adjustment)
                    assert got.variance_test is got.adjustment.variance_test
                    assert got.variance_test == want.variance_test
                else:
                    assert got.variance_test == want.variance_test
                assert type(K.adjust_tested(*base, 1, s02, *kw)) is dict  # α an int
    assert {("TestedAdjustment", True), ("Adjustment", False)} <= kinds, kinds
    model = replay["models"][0]
    x0 = np.array(replay["calls"][0][0][2], dtype=float)
    used = np.array([True] + [False] * (model.n_slots - 1))
    assert K.adjust_tested(fast_lsq.spec(model), x0, used, 1.0, 10, COND_MAX, MAX_AXIS_RATIO,
                           False, 2.8, 0.05, 1.0, 1.96, 2.576, "A",
                           "lsq") is None  # m < 2: adjust's None
    assert type(Adjustment) is type and type(TestedAdjustment) is type
    with pytest.raises(TypeError):
        K._bind_fix(LopRow, TestedAdjustment, Adjustment, fast_lsq._variance_bounds)  # slotted


# ------------------------------------------------------------------------------------------
# estimate: _at_estimate of a quiet fix in one call


@needs_kernel
def test_replay_estimate_is_at_estimate(replay: dict[str, list[Any]]) -> None:
    """compute_fix with ``estimate`` gives the FixResult it gives without it (fix._at_estimate,
    field by field to the bit, the table's rows, messages, geometry), on the replay's fixes
    and their variants; ``estimate`` builds most of them and declines (None) a fix with
    rejections, a grid or system that raises and sets it cannot read."""
    calls = _variants(replay["calls"])
    made: list[Any] = []
    args: list[tuple[Any, ...]] = []
    real = K.estimate

    def record(*a: Any) -> Any:
        r = real(*a)
        args.append(a)
        made.append(r)
        return r

    mp = pytest.MonkeyPatch()
    mp.setattr(K, "estimate", record)
    got = _fixes(calls, False, mp)
    mp.setattr(K, "estimate", lambda *a: None)
    want = _fixes(calls, False, mp)
    mp.undo()
    for g, w in zip(got, want, strict=True):
        assert same(g, w) and len(g.lops) == len(w.lops)
        assert same(g.decca_geometry, w.decca_geometry)
    assert sum(type(r) is fix.FixResult for r in made) > 150
    a = args[0]

    class Raising:
        def __init__(self, grid: Any) -> None:
            self.grid = grid

        def inverse(self, *xy: Any) -> Any:
            raise ValueError("off the grid")

    assert K.estimate(Raising(a[0]), *a[1:]) is None
    assert K.estimate(a[0], a[1], a[2], dict(a[3], manual=object()), *a[4:]) is None
    assert K.estimate(a[0], a[1], a[2], list(a[3]), *a[4:]) is None
    tested = dataclasses.replace(a[2], rejected=((2, 9.0),))
    assert K.estimate(a[0], a[1], tested, *a[3:]) is None
    assert type(K.estimate(*a)) is fix.FixResult

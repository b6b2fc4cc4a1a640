"""The LSQ fix's per-epoch shortcuts (issue 14) give exactly what the general code gives.

Each test compares a shortcut with the code it replaces: ``numpy.linalg.inv`` for the direct
gufunc call, the dataclasses' own ``__init__`` for ``frozen_instance``, the gathered (``take``)
sub-block for the consecutive-slot views, a returned statistics block for one written in place
and the general conversion for the ellipse's float64 fast path. Equality is exact (``==`` on
the bits, ``array_equal``): the shortcuts perform the same floating-point operations.
"""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine.lsq.adjustment import Adjustment, Linearisation, _inv, gauss_newton
from engine.lsq.confidence import error_ellipse
from engine.lsq.statistics import delta0, used_statistics
from tests.lsq.test_adjustment import A_PG821, B_PG821, CL_PG821, USED_PG, pg821
from tests.lsq.test_fix_worked_example import _sample_fix


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal to the bit (NaN where NaN), the same shape."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return a.shape == b.shape and np.ascontiguousarray(a).tobytes() == np.ascontiguousarray(
        b).tobytes()


def test_inverse_is_numpy_linalg_inv_to_the_bit() -> None:
    rng = np.random.default_rng(14)
    for n in (1, 2, 3, 4, 5, 7, 10):
        for _ in range(200):
            m = rng.normal(size=(n, n)) * 10.0 ** rng.integers(-3, 6)
            if rng.random() < 0.5:
                m = m @ m.T + np.eye(n)
            assert _same(_inv(m), np.linalg.inv(m))
            view = np.eye(n + 2)
            view[1:n + 1, 1:n + 1] = m
            assert _same(_inv(view[1:n + 1, 1:n + 1]), np.linalg.inv(m))  # a strided view


def test_singular_inverse_raises_like_numpy_without_a_warning() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(np.linalg.LinAlgError):
            _inv(np.zeros((3, 3)))
        with pytest.raises(np.linalg.LinAlgError):
            _inv(np.ones((2, 2)))


def _by_init(obj: object) -> object:
    """The same dataclass instance made by its own ``__init__``."""
    return dataclasses.replace(obj)  # type: ignore[type-var]


def test_results_made_without_init_equal_those_made_by_it() -> None:
    fix = _sample_fix()
    tested = fix.tested
    assert tested is not None
    adj = tested.adjustment
    for obj in (fix, tested, adj, fix.ellipse, adj.variance_test):
        assert obj is not None
        names = [f.name for f in dataclasses.fields(obj)]  # type: ignore[arg-type]
        assert list(vars(obj)) == names  # every field, in order, nothing else
        again = _by_init(obj)
        assert all(getattr(again, k) is getattr(obj, k) for k in names)
        with pytest.raises(dataclasses.FrozenInstanceError):
            obj.ok = False  # type: ignore[union-attr]


def _spread(rows: np.ndarray, cl: np.ndarray, slots: list[int], n: int
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The used rows of the Pg 821 problem placed at ``slots`` of an n-slot problem."""
    A = np.full((n, 2), 99.0)
    b = np.full(n, -7.0)
    Cl = np.eye(n) * 3.0
    A[slots] = rows[0]
    b[slots] = rows[1]
    Cl[np.ix_(slots, slots)] = cl
    return A, b, Cl


def _fields_at(adj: Adjustment, slots: list[int]) -> list[np.ndarray]:
    return [adj.x, adj.cov_x, adj.dx, adj.v[slots], adj.stats_block[:, slots], adj.A_used,
            adj.b_used, adj.Cl_used, adj.W_used, np.array([adj.s2, adj.rms_m, adj.drms_m])]


@pytest.mark.parametrize("scale_vcv", [False, True])
def test_consecutive_slots_as_views_give_the_gathered_numbers(scale_vcv: bool) -> None:
    """Used slots 1–4 of 7 (views) against the same rows at slots 0, 2, 3, 6 (take copies)."""
    used = USED_PG.nonzero()[0]
    rows = (A_PG821[used], B_PG821[used])
    cl = CL_PG821[np.ix_(used, used)]
    out = []
    for slots in ([1, 2, 3, 4], [0, 2, 3, 6]):
        A, b, Cl = _spread(rows, cl, slots, 7)
        mask = np.zeros(7, bool)
        mask[slots] = True
        adj = gauss_newton(lambda x, A=A, b=b, Cl=Cl: Linearisation(A, b, Cl), np.zeros(2),
                           mask, epsilon=50.0, scale_vcv=scale_vcv)
        assert adj.ok
        out.append(_fields_at(adj, slots))
        unused = np.setdiff1d(np.arange(7), slots)
        assert np.isnan(adj.stats_block[:, unused]).all() and np.isnan(adj.v[unused]).all()
    assert all(_same(a, b) for a, b in zip(*out, strict=True))
    reference = gauss_newton(pg821, np.zeros(2), USED_PG, epsilon=50.0, scale_vcv=scale_vcv)
    assert all(_same(a, b) for a, b in zip(out[0], _fields_at(reference, [0, 1, 2, 3]),
                                           strict=True))


def test_statistics_written_in_place_equal_the_returned_block() -> None:
    adj = gauss_newton(pg821, np.zeros(2), USED_PG, epsilon=50.0)
    args = (adj.A_used, adj.Cl_used, adj.W_used, adj.cov_x_apriori, adj.v[USED_PG],
            delta0(0.05, 0.80))
    plain = used_statistics(*args)
    full = np.full((9, 6), np.nan)
    used_statistics(*args, out=full[:, 1:5])
    assert _same(full[:, 1:5], plain)
    assert np.isnan(full[:, [0, 5]]).all()


finite = st.floats(-1e6, 1e6, allow_nan=False)


@settings(deadline=None, max_examples=300)
@given(st.floats(0.0, 1e8), finite, st.floats(0.0, 1e8))
def test_ellipse_fast_path_equals_the_general_conversion(sxx: float, sxy: float,
                                                         syy: float) -> None:
    fast = error_ellipse(np.array([[sxx, sxy], [sxy, syy]]))
    general = error_ellipse([[sxx, sxy], [sxy, syy]])  # type: ignore[arg-type]
    for name in ("a_m", "b_m", "az_deg", "phi_deg"):
        a, b = getattr(fast, name), getattr(general, name)
        assert math.copysign(1.0, a) == math.copysign(1.0, b) and (a == b or a != a and b != b)
    assert fast.eigenvalues == general.eigenvalues
    assert _same(fast.eigenvectors, general.eigenvectors)

"""runparse's ``prior``: the fix's prior from the prediction in one call
(``engine.fast.filter.filter_prior``) gives what the reference
(``engine.filter.estimate.filter_prior``) gives — the same two floats, a PositionPrior whose VCV
is a fresh copy of P's position block with the same bits — and declines what it does not read."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine import native
from engine.fast import filter as fast_filter
from engine.filter.estimate import filter_prior
from engine.filter.state import IX, IY, FilterState
from engine.systems.base import PositionPrior

K = native.kernel("runparse")
pytestmark = pytest.mark.skipif(K is None, reason=f"runparse kernel: {native.status('runparse')}")


def _both(state: FilterState) -> tuple[object, object]:
    return fast_filter.filter_prior(state), filter_prior(state)


_F = st.floats(allow_nan=True, allow_infinity=True, width=64)


@settings(max_examples=200, deadline=None)
@given(x=st.lists(_F, min_size=11, max_size=11), p=st.lists(_F, min_size=121, max_size=121),
       transpose=st.booleans())
def test_prior_is_the_python_prior(x: list[float], p: list[float], transpose: bool) -> None:
    P = np.array(p).reshape(11, 11)
    state = FilterState(0.0, np.array(x), P.T if transpose else P)
    assert fast_filter._PRIOR is not None
    fast, pure = _both(state)
    (xs, pr), (xs2, pr2) = fast, pure  # type: ignore[misc]
    assert [float.hex(v) for v in xs] == [float.hex(v) for v in xs2]
    assert all(type(v) is float for v in xs)
    assert type(pr) is PositionPrior and type(pr2) is PositionPrior
    assert float.hex(pr.x_m) == float.hex(pr2.x_m) and float.hex(pr.y_m) == float.hex(pr2.y_m)
    assert pr.cov.tobytes() == pr2.cov.tobytes() and pr.cov.shape == (2, 2)
    assert pr.cov.dtype == pr2.cov.dtype and pr.cov.flags.writeable and pr.cov.flags.owndata
    assert not np.shares_memory(pr.cov, state.P)


def test_prior_declines_other_arrays() -> None:
    make = fast_filter._new_prior
    x, P = np.arange(11.0), np.eye(11)
    assert K.prior(x.astype(np.float32), P, IX, IY, make) is None
    assert K.prior(x, P.astype(np.float32), IX, IY, make) is None
    assert K.prior(x[:1], P, IX, IY, make) is None
    assert K.prior(x.tolist(), P, IX, IY, make) is None
    assert K.prior(x, P, IX, IY + 1, make) is None
    (xy, pr) = K.prior(x, P, IX, IY, make)
    assert xy == (x[IX], x[IY]) and pr.cov.tolist() == P[IX:IY + 1, IX:IY + 1].tolist()

"""State edits (engine/filter/state.py): new values in, everything else untouched, P symmetric."""

from __future__ import annotations

import math

import numpy as np
import pytest

from engine.filter.params import FilterParams
from engine.filter.state import (
    IPSI,
    IVCX,
    IVCY,
    IX,
    IY,
    FilterState,
    init_state,
    move_to_grid,
    replace_current,
    replace_position,
)

PARAMS = FilterParams(p0="physical")


def _state():
    fs = init_state(0.0, 100.0, 200.0, 10.0, 3.0, 0.5, 0.01, 0.2, -0.1, PARAMS)
    P = fs.P + 0.01  # some cross-covariance everywhere
    return FilterState(0.0, fs.x, P)


def test_replace_position_decouples_the_position() -> None:
    fs = _state()
    cov = np.array([[4.0, 1.0], [1.0, 9.0]])
    new = replace_position(fs, 5.0, 6.0, cov)
    assert (new.x[IX], new.x[IY]) == (5.0, 6.0)
    np.testing.assert_array_equal(new.P[:2, :2], cov)
    assert not new.P[:2, 2:].any() and not new.P[2:, :2].any()
    np.testing.assert_array_equal(new.P[2:, 2:], fs.P[2:, 2:])
    assert not new.x.flags.writeable and fs.x[IX] == 100.0  # a new value, the old one kept


def test_replace_current_sets_both_components() -> None:
    new = replace_current(_state(), 0.3, -0.4, 0.25)
    assert (new.x[IVCX], new.x[IVCY]) == (0.3, -0.4)
    assert new.P[IVCX, IVCX] == new.P[IVCY, IVCY] == 0.25
    assert new.P[IVCX, IVCY] == 0.0 and not new.P[IVCX, :IVCX].any()


def test_move_to_grid_turns_heading_and_current() -> None:
    fs = _state()
    d = math.radians(1.5)
    new = move_to_grid(fs, 1.0, 2.0, d)
    assert (new.x[IX], new.x[IY]) == (1.0, 2.0)
    assert new.x[IPSI] == pytest.approx(fs.x[IPSI] - d)
    assert math.hypot(new.x[IVCX], new.x[IVCY]) == pytest.approx(math.hypot(0.2, -0.1))
    np.testing.assert_allclose(new.P, new.P.T)
    assert np.trace(new.P[:2, :2]) == pytest.approx(np.trace(fs.P[:2, :2]))

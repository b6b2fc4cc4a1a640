"""Angle wrapping (engine/geodesy/angles.py): ranges, boundaries and periodicity."""

from __future__ import annotations

import math

import pytest

from engine.geodesy.angles import TWO_PI, wrap_2pi, wrap_180_deg, wrap_pi


@pytest.mark.parametrize("a", [-7.0, -math.pi, -1.0, 0.0, 1.0, math.pi, 4.0, 100.0])
def test_wrap_pi_is_in_range_and_congruent(a: float) -> None:
    w = wrap_pi(a)
    assert -math.pi < w <= math.pi
    assert math.remainder(w - a, TWO_PI) == pytest.approx(0.0, abs=1e-12)


def test_wrap_pi_boundaries() -> None:
    assert wrap_pi(math.pi) == pytest.approx(math.pi)
    assert wrap_pi(-math.pi) == pytest.approx(math.pi)  # −π is outside (−π, π]
    assert wrap_pi(0.25) == 0.25


def test_wrap_2pi_and_degrees() -> None:
    assert wrap_2pi(-0.5) == pytest.approx(TWO_PI - 0.5)
    assert wrap_2pi(TWO_PI + 0.5) == pytest.approx(0.5)
    assert 0.0 <= wrap_2pi(-1e-3) < TWO_PI
    assert wrap_180_deg(-180.0) == 180.0
    assert wrap_180_deg(181.0) == pytest.approx(-179.0, abs=1e-12)
    assert math.copysign(1.0, wrap_180_deg(-360.0)) == 1.0  # −0 becomes +0

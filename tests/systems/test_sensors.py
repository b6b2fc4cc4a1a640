"""Sensor conversions against the thesis' worked numbers (THEORY §3.7–3.8, §14.1)."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from engine.systems import sensors


def test_knot_factor_reproduces_the_sample_displacement() -> None:
    # THEORY §14.1 item 6: two 1-s steps at 12.7 kn move the ship 13.07 m (printed to 0.01 m).
    assert 2 * sensors.knots_to_ms(12.7) == pytest.approx(13.07, abs=0.005)


def test_depth_of_one_megapascal() -> None:
    # THEORY §3.7–3.8: P − P_ref = 1.0e6 Pa gives d = 101.9716/1.026 = 99.39 m (hand calculation).
    ref = sensors.surface_reference_hz()
    f = sensors.crystal_frequency_hz(sensors.crystal_pressure_pa(ref) + 1.0e6)
    assert sensors.pressure_depth_m(f, ref, 1.026) == pytest.approx(99.39, abs=0.005)


def test_surface_reading_is_zero_depth_and_frequency_falls_with_depth() -> None:
    ref = sensors.surface_reference_hz()
    assert sensors.pressure_depth_m(ref, ref) == 0.0
    f10, f100 = sensors.depth_to_frequency_hz(10.0, ref), sensors.depth_to_frequency_hz(100.0, ref)
    assert f100 < f10 < ref


@given(
    depth=st.floats(min_value=0.0, max_value=600.0),
    s_weight=st.floats(min_value=1.0, max_value=1.05),
)
def test_depth_frequency_round_trip(depth: float, s_weight: float) -> None:
    # The simulator writes frequencies with this inverse; the engine must read the same depth back.
    # 1e-6 m: the inverse is closed-form, so only float rounding remains.
    ref = sensors.surface_reference_hz()
    f = sensors.depth_to_frequency_hz(depth, ref, s_weight)
    assert sensors.pressure_depth_m(f, ref, s_weight) == pytest.approx(depth, abs=1e-6)


def test_out_of_range_pressure_is_refused() -> None:
    with pytest.raises(ValueError, match="beyond"):
        sensors.crystal_frequency_hz(1e9)

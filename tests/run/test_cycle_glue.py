"""The cycle's glue around the compiled kernels (issue 14, wave 2): the objects it builds
without their generated ``__init__`` are the same values, and the cached per-run lookups give
what the functions they stand for give."""

from __future__ import annotations

from dataclasses import FrozenInstanceError, fields

import pytest

from engine.filter import update as upd
from engine.run.config import load_config
from engine.run.parts import choose
from engine.run.session import Session
from engine.systems import registry
from engine.systems.base import CycleInputs
from tests.paths import DATA

SAMPLE = DATA / "920917_1.toml"


def test_cycle_inputs_are_whole_frozen_dataclasses(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every system gets a CycleInputs with every field set, equal to the one its __init__
    builds, frozen, and seeing only the readings of the systems before it."""
    seen: list[tuple[str, CycleInputs]] = []
    for system in choose().run_systems(registry.SYSTEMS):  # the run's systems (engine.fast's)
        read = system.read

        def spy(inputs: CycleInputs, _read=read, _name=system.name):  # type: ignore[no-untyped-def]
            seen.append((_name, inputs))
            return _read(inputs)

        monkeypatch.setattr(system, "read", spy, raising=False)
    s = Session(load_config(SAMPLE))
    for _ in range(3):
        s.step()
    names = [system.name for system in registry.SYSTEMS]
    assert len(seen) == 3 * len(names)
    for k, (name, inputs) in enumerate(seen):
        # every slot set (an unset one raises AttributeError), no instance dict besides
        values = {f.name: getattr(inputs, f.name) for f in fields(CycleInputs)}
        assert not hasattr(inputs, "__dict__")
        assert CycleInputs(**values) == inputs
        assert list(inputs.earlier) == names[:names.index(name)]
        assert inputs.context is s.context and inputs.config is s.context.config
        with pytest.raises(FrozenInstanceError):
            inputs.cm_deg = 0.0  # type: ignore[misc]
        if k % len(names):  # a later system's view is a copy, not the cycle's own dict
            assert inputs.earlier is not seen[k - 1][1].earlier


def test_lom_limits_are_the_cached_bounds() -> None:
    """The update's dict of LOM limits gives the lru-cached χ² bounds, bit for bit."""
    for p in (1, 2, 3, 5, 8, 21, 30):
        for alpha in (0.05, 0.01):
            lom = upd._lom_from_nis(7.25, p, alpha)
            lower, upper = upd._lom_limits(p, alpha)
            assert (lom.lower, lom.upper) == (lower, upper)
            assert lom.t == 7.25 / p and lom.dof == p


def test_sensor_variances_follow_the_parameters() -> None:
    """The sensor rows' per-parameter variances (remembered per parameter set) are those the
    first code computes, for parameter sets that differ only in those σ, used in turn."""
    import numpy as np

    from engine.filter import measurements as ms
    from engine.filter.params import FilterParams
    from engine.filter.state import FilterState

    state = FilterState(0.0, np.zeros(11), np.eye(11))
    sets = [FilterParams(), FilterParams(sigma_press_m=0.37, sigma_gyro_deg=1.3,
                                         sigma_incl_deg=0.11), FilterParams(sigma_gyro_deg=0.2)]
    for _ in range(2):
        for params in sets:
            for gyro_sigma in (None, 2.5):
                kw = dict(depth_m=12.5, log_ms=3.0, gyro_grid_rad=1.25, incl_rad=0.01,
                          params=params, gyro_sigma_deg=gyro_sigma)
                a = ms.sensor_measurement(state, **kw)
                b = ms.nav_measurement(state, **kw)  # the rows built one by one
                assert np.array_equal(a.R, b.R) and np.array_equal(a.z, b.z)
                assert a.labels == b.labels and a.angle_rows == b.angle_rows

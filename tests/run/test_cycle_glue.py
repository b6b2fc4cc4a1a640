"""The cycle's glue around the compiled kernels (issue 14, wave 2): the objects it builds
without their generated ``__init__`` are the same values, and the cached per-run lookups give
what the functions they stand for give."""

from __future__ import annotations

from dataclasses import FrozenInstanceError, fields

import pytest

from engine.filter import update as upd
from engine.run.config import load_config
from engine.run.session import Session
from engine.systems import registry
from engine.systems.base import CycleInputs
from tests.paths import DATA

SAMPLE = DATA / "920917_1.toml"


def test_cycle_inputs_are_whole_frozen_dataclasses(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every system gets a CycleInputs with every field set, equal to the one its __init__
    builds, frozen, and seeing only the readings of the systems before it."""
    seen: list[tuple[str, CycleInputs]] = []
    for system in registry.SYSTEMS:
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
        assert set(vars(inputs)) == {f.name for f in fields(CycleInputs)}
        assert CycleInputs(**vars(inputs)) == inputs
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

"""The run's collaborators are chosen once per run: engine.fast's where it offers them, the
reference's where a kernel is missing, ``UVNAV_PURE=1`` is set, or a first-use probe fails."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

import engine.fast as fast
from engine import native
from engine.fast.geodesy import KERNEL as TM_KERNEL
from engine.fast.geodesy import FastTMGrid
from engine.geodesy.tmgrid import TMGrid
from engine.run.commands import SetDatum
from engine.run.config import load_config
from engine.run.parts import REFERENCE, CycleParts, choose
from engine.run.session import Session
from tests.native.replay import replay
from tests.paths import DATA

needs_tmgrid = pytest.mark.skipif(TM_KERNEL is None, reason="engine.native.tmgrid not built")


@pytest.fixture
def fresh_verdicts() -> Iterator[None]:
    """Forget the probes' verdicts before and after (they are kept per process)."""
    fast._verdict.cache_clear()
    yield
    fast._verdict.cache_clear()


def test_reference_parts_are_the_navigation_modules_own() -> None:
    assert REFERENCE == CycleParts()
    assert REFERENCE.grid is TMGrid


@needs_tmgrid
def test_a_run_takes_the_compiled_grid(fresh_verdicts: None) -> None:
    """With the kernel built, a session's cycle runs on FastTMGrid (its grids are one)."""
    assert choose().grid is FastTMGrid
    session = replay(5)
    assert session.parts.grid is FastTMGrid
    assert all(type(g) is FastTMGrid for g in session.context._grids.values())


def test_pure_env_chooses_the_reference(monkeypatch: pytest.MonkeyPatch,
                                        fresh_verdicts: None) -> None:
    monkeypatch.setenv(native.PURE_ENV, "1")
    assert choose() == REFERENCE
    assert ("grid", "tmgrid", f"pure ({native.PURE_ENV}=1)") in fast.declined()


@needs_tmgrid
def test_a_failing_probe_declines_for_the_run(monkeypatch: pytest.MonkeyPatch,
                                              fresh_verdicts: None) -> None:
    """A kernel whose numbers are off (here: the convergence shifted by 1e-6°) is not used:
    the run keeps the reference grid, and the kernel report says why."""
    real = FastTMGrid.forward_full

    def off(self: FastTMGrid, lat: float, lon: float) -> tuple[float, float, float, float]:
        x, y, g, k = real(self, lat, lon)
        return x, y, g + 1e-6, k

    monkeypatch.setattr(FastTMGrid, "forward_full", off)
    assert choose().grid is TMGrid
    why = [w for part, _k, w in fast.declined() if part == "grid"]
    assert why and why[0].startswith("first-use probe failed")
    from engine.run.kernels import kernel_report

    assert dict(kernel_report())["tmgrid"].startswith("compiled, not used here: first-use probe")


@needs_tmgrid
def test_a_raising_probe_declines(monkeypatch: pytest.MonkeyPatch,
                                  fresh_verdicts: None) -> None:
    def boom(self: FastTMGrid, lat: float, lon: float) -> tuple[float, float]:
        raise SystemError("kernel broken")

    monkeypatch.setattr(FastTMGrid, "forward_full", boom)
    assert choose().grid is TMGrid
    assert any("SystemError" in w for _p, _k, w in fast.declined())


def test_session_keeps_its_parts_across_a_setup_change(tmp_path: Path) -> None:
    """A set-up change rebuilds the context with the run's parts (chosen once per run), and
    a run built with the reference's parts stays on them."""
    for parts in (None, REFERENCE):
        session = Session(load_config(DATA / "DEMO.toml"), out_path=tmp_path / "R.OUT",
                          force=True, history=1)
        if parts is not None:
            session.parts = parts
            session.context = replace(session.context, parts=parts)
        try:
            session.run(max_cycles=3)
            session.apply(SetDatum("WGS84"))
            session.run(max_cycles=6)
        finally:
            session.close()
        assert session.context.parts is session.parts
        assert session.context.working.name == "WGS84"
        assert {type(g) for g in session.context._grids.values()} == {session.parts.grid}


def _off(real: Any, scale: float = 1.0 + 1e-6) -> Any:
    """``real`` with every float of its result (nested lists and tuples) scaled: a kernel whose
    numbers are off by more than the tolerance contract."""
    def scaled(v: Any) -> Any:
        if isinstance(v, float):
            return v * scale
        if isinstance(v, list | tuple) and not hasattr(v, "_fields"):
            return type(v)(scaled(x) for x in v)
        return v

    def call(*a: Any, **k: Any) -> Any:
        return scaled(real(*a, **k))
    return call


@needs_tmgrid
@pytest.mark.parametrize(("part", "target", "name"), [
    ("systems", "engine.fast.decca.FastDeccaObservations", "nearest_station_m"),
    ("systems", "engine.fast.gps.FastGpsObservations", "linearise"),
    ("compute_fix", "engine.fast.lsq", "compute_fix"),
    ("datum_shift", "engine.fast.geodesy.FastDatumShift", "transform"),
])
def test_each_part_declines_when_its_probe_sees_other_numbers(
        monkeypatch: pytest.MonkeyPatch, fresh_verdicts: None, part: str, target: str,
        name: str) -> None:
    """A compiled part whose numbers are off is not offered; the run takes the reference's."""
    import importlib

    mod_name, _, cls_name = target.rpartition(".")
    if cls_name == "lsq":
        owner: Any = importlib.import_module(target)
    else:
        owner = getattr(importlib.import_module(mod_name), cls_name)
    real = getattr(owner, name)
    if name == "linearise":
        def off_rows(self: Any, p: Any, slot0: int, A: list[float], b: list[float],
                     Cl: Any) -> None:
            real(self, p, slot0, A, b, Cl)
            b[slot0] *= 1.0 + 1e-6
        monkeypatch.setattr(owner, name, off_rows)
    elif name == "compute_fix":
        def off_fix(*a: Any, **k: Any) -> Any:
            from dataclasses import replace
            f = real(*a, **k)
            return replace(f, x_m=f.x_m + 1e-3)
        monkeypatch.setattr(owner, name, off_fix)
    else:
        monkeypatch.setattr(owner, name, _off(real))
    assert part not in fast.parts()
    why = {p: w for p, _k, w in fast.declined()}
    assert why[part].startswith("first-use probe failed"), why
    ref = getattr(REFERENCE, part)
    assert getattr(choose(), part) == ref


def test_a_context_built_without_parts_takes_the_runs_choice() -> None:
    """build_context (as ``uvnav denied`` calls it) without parts: the run's choice, not the
    reference (a silent slow path)."""
    from engine.run.cycle import build_context
    from engine.run.setup import load_data

    cfg = load_config(DATA / "DEMO.toml")
    ctx = build_context(cfg, *load_data(cfg))
    assert ctx.parts == choose()
    assert build_context(cfg, *load_data(cfg), REFERENCE).parts is REFERENCE


FILTER_PARTS = ("update", "predict", "predict_estimate", "estimate", "prior", "update_rows",
                "update_gated", "innovation_distance", "lse_measurement")
"""The filter's parts of the run: one probe (engine.fast.filter.probe) decides them all."""


def _nudged(value: Any) -> Any:
    """``value`` (a filter result, state, estimate, measurement, float or a tuple of them)
    with its leading numbers off by 1e-6 relative: a kernel outside the tolerance contract."""
    from dataclasses import replace as dc_replace

    import numpy as np

    from engine.filter.estimate import PositionEstimate
    from engine.filter.measurements import Measurement
    from engine.filter.state import FilterState
    from engine.filter.update import UpdateResult

    if isinstance(value, float):
        return value * (1.0 + 1e-6)
    if isinstance(value, tuple):
        return (_nudged(value[0]), *value[1:])
    if isinstance(value, FilterState):
        return value._with(value.t, np.array(value.x) * (1.0 + 1e-6), np.array(value.P))
    if isinstance(value, UpdateResult | Measurement):
        new = object.__new__(type(value))
        new.__dict__.update(value.__dict__)
        if isinstance(value, UpdateResult):
            new.__dict__["state"] = _nudged(value.state)
        else:
            new.__dict__["z"] = value.z * (1.0 + 1e-6)
        return new
    if isinstance(value, PositionEstimate):
        return dc_replace(value, lat_deg=value.lat_deg + 1e-6)
    raise TypeError(type(value))


@pytest.mark.skipif(native.kernel("kalman_update") is None or
                    native.kernel("kalman_predict") is None,
                    reason="the filter's kernels are not built")
@pytest.mark.parametrize("name", ["predict_estimate", "predict_step", "update_rows",
                                  "update_rows_gated", "update", "innovation_distance",
                                  "lse_measurement", "filter_estimate", "filter_prior"])
def test_the_filter_declines_when_its_probe_sees_other_numbers(
        monkeypatch: pytest.MonkeyPatch, fresh_verdicts: None, name: str) -> None:
    """A compiled filter function whose numbers are off is caught by the filter's probe: the
    run takes every filter part of the reference (one probe decides them all)."""
    from engine.fast import filter as fast_filter

    real = getattr(fast_filter, name)
    monkeypatch.setattr(fast_filter, name, lambda *a, **k: _nudged(real(*a, **k)))
    offered = fast.parts()
    assert not set(FILTER_PARTS) & set(offered), sorted(offered)
    why = {p: w for p, _k, w in fast.declined()}
    assert all(why[p].startswith("first-use probe failed") for p in FILTER_PARTS), why
    parts = choose()
    assert all(getattr(parts, p) == getattr(REFERENCE, p) for p in FILTER_PARTS)
    assert "compute_fix" in offered or native.kernel("lsq") is None  # the others unaffected


def test_the_filter_parts_are_offered_where_built(fresh_verdicts: None) -> None:
    """With the filter's kernels built and passing the probe, every filter part of the run is
    engine.fast.filter's (no silent reference); with UVNAV_PURE=1 every one is the
    reference's (test_pure_env_chooses_the_reference)."""
    from engine.fast import filter as fast_filter

    if fast_filter.KU is None or fast_filter.KP is None:
        pytest.skip("the filter's kernels are not built")
    parts = choose()
    for p in FILTER_PARTS:
        assert getattr(parts, p) is getattr(fast_filter, fast._FILTER_PARTS[p]), p

"""The benches' pure helpers: the plain numpy + FilterPy pipeline does the engine's job (its
positions agree with the engine's; a correctness check, never a timing), and the long
mission's scenario is the demo's legs repeated."""

from __future__ import annotations

import math
import tomllib

import pytest

from bench import bench_filterpy as bf
from bench import bench_long as bl
from engine.run.config import load_config
from engine.systems.decca import sigma_path_a, track_lane

AGREE_EPOCHS = 3600
"""The first hour of the demo: 45 min surfaced with fixes, then 15 min of the dive (DR)."""


def test_nearest_lane_is_the_decometer_rule():
    for prev in (44.88, 276.15, 1.05, 10.999, 3.0):
        for frac in (0.0, 0.001, 0.4, 0.5, 0.93):
            assert math.isclose(bf._nearest(prev, frac), track_lane(prev, frac), abs_tol=1e-9)


def test_sky_wave_sigma_is_the_engines():
    for d in (0.0, 50_000.0, 123_456.0, 300_000.0):
        assert math.isclose(float(bf._sigma_path(d)), sigma_path_a(d * 1e-5), rel_tol=1e-12)


def test_plain_pipeline_agrees_with_the_engine():
    pytest.importorskip("filterpy")
    cfg = load_config(bf.CONFIG)
    agree = bf.agreement(cfg, AGREE_EPOCHS)
    for name, (median, p95, _max, n) in agree.items():
        assert n > 1000, name
        assert median <= bf.AGREE_MEDIAN_M, (name, median)
        assert p95 <= bf.AGREE_P95_M, (name, p95)


def test_plain_pipeline_writes_one_line_per_epoch(tmp_path):
    pytest.importorskip("filterpy")
    inp = bf.prepare(load_config(bf.CONFIG), 30)
    out = tmp_path / "plain.log"
    assert bf.run_pipeline(inp, out) == 30
    lines = out.read_text().splitlines()
    assert len(lines) == 30
    assert all(len(ln.split()) >= 24 for ln in lines)


def test_long_scenario_is_24_hours_of_demo_legs():
    demo = tomllib.loads((bl.DATA / "DEMO.scenario.toml").read_text())
    long = tomllib.loads(bl.scenario_text())
    assert len(long["leg"]) == bl.REPEATS * len(demo["leg"])
    assert sum(leg["duration_s"] for leg in long["leg"]) == 24 * 3600
    assert {k: v for k, v in long.items() if k not in ("leg", "data_dir")} == \
        {k: v for k, v in demo.items() if k not in ("leg", "data_dir")}


def test_long_config_points_at_its_run_file(tmp_path):
    run = tmp_path / "X.RUN"
    cfg = tomllib.loads(bl.config_text(run))
    assert cfg["run_file"] == run.as_posix()
    assert cfg["data_dir"] == bl.DATA.as_posix()


def test_long_cache_is_keyed_on_scenario_and_seed():
    text = bl.scenario_text()
    assert bl.cache_dir(text) == bl.cache_dir(text)
    assert bl.cache_dir(text) != bl.cache_dir(text + "\n")
    assert bl.cache_dir(text, 1) != bl.cache_dir(text, 2)


def test_engine_bench_times_every_stage(tmp_path, monkeypatch):
    """Every row of bench_engine's stage split has a timer that fires on a short replay (a
    stage function renamed in the engine once left the .OUT row at 0.0 µs)."""
    from bench import bench_engine as be

    monkeypatch.setattr(be, "REPEATS", 1)
    spent = be._stage_split(load_config(be.CONFIG), tmp_path / "B.OUT", 30)
    for stage in (*be.STAGES, be.CYCLE, be.LOG_STAGE):
        assert spent[stage] > 0.0, stage


def test_engine_bench_counts_the_compiled_kernels(tmp_path, monkeypatch):
    """bench_engine's kernel time finds the kernels by the module in cProfile's label: the fix's
    kernel and the ``.OUT`` writer (a method the kernel binds at run time, which had no module
    in its label before) are both counted, and a method of a kernel type is named by its type."""
    from bench import bench_engine as be
    from engine.fast import outlog as fast_outlog
    from engine.run.records import BLOCK_SHAPES

    if fast_outlog.cycle_writer(BLOCK_SHAPES) is None:
        pytest.skip("the compiled .OUT writer is not in use (not built, or UVNAV_PURE=1)")
    monkeypatch.setattr(be, "REPEATS", 1)
    t, each = be.kernel_time(load_config(be.CONFIG), tmp_path / "B.OUT", 30)
    names = {be._kernel_name(label) for label in each}
    assert {"outfmt.write_cycle", "lsq.adjust_tested", "kalman_update.update_blocks"} <= names
    assert t == pytest.approx(sum(each.values()))
    assert be._kernel_name("<method 'forward' of 'engine.native.datum.Shift' objects>") == \
        "datum.Shift.forward"

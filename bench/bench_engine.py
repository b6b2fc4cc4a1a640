"""Engine throughput: replay epochs/s with .OUT writing and the per-stage split.

Run with ``make bench`` (or ``python -m bench.bench_engine``).  Medians over ``REPEATS`` runs of
the first ``N_EPOCHS`` records of the bundled demo (surfaced: GPS + Decca + filter).  The stage
split wraps the cycle's calls to the LSQ fix, the filter and the GPS geodesy with timers.
"""

from __future__ import annotations

import statistics
import tempfile
import time
from collections import defaultdict
from collections.abc import Callable
from itertools import islice
from pathlib import Path

import engine.cycle as cycle_mod
from engine.outlog import OutLogWriter
from engine.records import cycle_block
from engine.runconfig import load_config
from engine.runfile import RunRecord, iter_run_file
from engine.session import Session

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "data" / "DEMO.toml"
N_EPOCHS = 1500
REPEATS = 5
STAGES = {
    "geodesy (GPS datum shift, grid)": ("_gps_input",),
    "Decca lane tracking": ("_decca_totals",),
    "LSQ fix + tests": ("compute_fix",),
    "filter (predict, updates)": (
        "predict_step", "update", "sensor_measurement", "lse_measurement", "stack_measurements"),
}


def _median_time(fn: Callable[[], object], repeats: int = REPEATS) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def _stage_split(ctx: cycle_mod.RunContext, nav0: cycle_mod.NavState,
                 records: list[RunRecord]) -> dict[str, float]:
    """Seconds spent in each stage over one cycle-only pass (median of REPEATS)."""
    spent: dict[str, list[float]] = defaultdict(list)
    originals = {}
    acc: dict[str, float] = defaultdict(float)
    for stage, names in STAGES.items():
        for name in names:
            fn = getattr(cycle_mod, name)
            originals[name] = fn

            def timed(*a: object, _fn: Callable[..., object] = fn, _s: str = stage,
                      **k: object) -> object:
                t0 = time.perf_counter()
                try:
                    return _fn(*a, **k)
                finally:
                    acc[_s] += time.perf_counter() - t0

            setattr(cycle_mod, name, timed)
    try:
        for _ in range(REPEATS):
            acc.clear()
            nav = nav0
            t0 = time.perf_counter()
            for rec in records:
                nav, _r = cycle_mod.step(ctx, nav, rec)
            total = time.perf_counter() - t0
            for stage in STAGES:
                spent[stage].append(acc[stage])
            spent["cycle total"].append(total)
    finally:
        for name, fn in originals.items():
            setattr(cycle_mod, name, fn)
    return {k: statistics.median(v) for k, v in spent.items()}


def main() -> None:
    """Print the replay throughput and the stage split (medians, µs per epoch, shares)."""
    cfg = load_config(CONFIG)
    records = [r for r in islice(iter_run_file(cfg.run_path), N_EPOCHS)
               if isinstance(r, RunRecord)]
    n = len(records)
    tmp = Path(tempfile.mkdtemp())

    def full_replay() -> None:
        s = Session(cfg, out_path=tmp / "B.OUT", force=True, history=1)
        s.run(max_cycles=n)
        s.close()

    t_full = _median_time(full_replay)
    t_parse = _median_time(lambda: list(islice(iter_run_file(cfg.run_path), n)))
    s = Session(cfg, history=1)
    results = []
    nav = s.nav
    for rec in records:
        nav, r = cycle_mod.step(s.context, nav, rec)
        results.append(r)

    def log() -> None:
        w = OutLogWriter.create(tmp / "L.OUT", force=True)
        for r in results:
            w.write_cycle(*cycle_block(r))
        w.close()

    t_log = _median_time(log)
    split = _stage_split(s.context, Session(cfg, history=1).nav, records)
    cycle_total = split.pop("cycle total")
    rows = [("parse .RUN", t_parse), *split.items(),
            ("rest of the cycle", cycle_total - sum(split.values())), (".OUT block + write", t_log)]
    print(f"UVNAV engine benchmark: {n} epochs of data/DEMO.RUN (GPS + Decca + filter), "
          f"median of {REPEATS} runs")
    print(f"  replay incl. .OUT : {t_full / n * 1e6:7.1f} µs/epoch = {n / t_full:7.0f} epochs/s"
          f"  (target 10,000 epochs/s; ratio to target {n / t_full / 10_000:.2f})")
    total = sum(t for _, t in rows)
    for name, t in rows:
        print(f"  {name:34s}: {t / n * 1e6:7.1f} µs/epoch  {100 * t / total:5.1f} %")


if __name__ == "__main__":
    main()

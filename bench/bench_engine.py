"""Engine throughput: replay epochs/s with .OUT writing and the per-stage split.

Run with ``make bench`` (or ``python -m bench.bench_engine``).  Medians over ``REPEATS`` runs of
the first ``N_EPOCHS`` records of the bundled demo (surfaced: GPS + Decca + filter).

The headline is a plain replay (``Session.run`` with the ``.OUT`` log, nothing instrumented).
The stage split comes from the same replay with timers around the stage functions: the names
in ``STAGES`` as the cycle (``engine.run.cycle``) calls them, and the session's ``.OUT`` block and
write (the run's block writer: ``engine.fast.outlog.BlockWriter`` or
``engine.run.records.write_block``); parsing the ``.RUN`` is
timed on its own. "rest of the cycle" is the time inside ``engine.run.cycle.step`` outside the
stage functions; the session's own bookkeeping (history, counters) is in no row. The timers
cost about a microsecond per call, so the rows add up to a little more than the headline.

The same replay under cProfile gives the compiled kernels' own time (``engine/native``, every
function and method whose profile label names that package, callbacks into Python excluded):
what a cycle would still cost with no Python left between the kernels, the kernels as they are.

The same run also compares against the engines of issue 14's start and of main before the bit-exact
speed work (``BASELINE_REVS``, extracted once with ``git archive`` into the temp folder): each round
replays the same epochs with each baseline tree and with this tree, each in a fresh process (warm-up
first), alternating, and the ratio is of the medians of the CPU times (CPU, not wall: the
machine may be shared). This tree is also replayed with ``UVNAV_PURE=1`` (its compiled kernels,
``engine/native``, switched off), so the kernels' own gain is measured in the same run. Skipped
with a note where the checkout has no git history.
"""

from __future__ import annotations

import cProfile
import importlib
import io
import os
import pstats
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from collections import defaultdict
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from itertools import islice
from pathlib import Path

import engine.run.cycle as cycle_mod
import engine.run.session as session_mod
from engine import native
from engine.fast.outlog import BlockWriter
from engine.io.runfile import RunRecord, iter_run_file
from engine.run.config import RunConfig, load_config
from engine.run.parts import choose as choose_parts
from engine.run.session import Session

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "data" / "DEMO.toml"
N_EPOCHS = 1500
REPEATS = 5
TARGET_EPOCHS_S = 10_000
STAGES = {
    "geodesy (GPS datum shift, grid)": ("engine.systems.gps:GpsSystem.gps_input",
                                        "engine.fast.gps:FastGpsSystem.gps_input"),
    "Decca lane tracking": ("engine.systems.decca:decca_totals",
                            "engine.fast.decca:tracked_totals"),
    "LSQ fix + tests": ("engine.lsq.fix:compute_fix", "engine.fast.lsq:compute_fix"),
    "filter (predict, updates)": (
        "sensor_rows", "depth_sensor_rows",
        *(f"engine.fast.filter:{f}" for f in (
            "predict_estimate", "update", "update_rows", "update_rows_gated", "lse_measurement",
            "innovation_distance"))),
}
"""Stage → the functions whose time it is: ``module:function`` or ``module:Class.method`` (the
run's parts: the reference's and engine.fast's), or a function of ``engine.run.cycle`` (as
``step`` calls it)."""
BASELINE_REVS = {"f81acd7": "when issue 14 was filed", "7aa241a": "before the bit-exact speed work"}
"""The engines the same-run comparison measures this tree against: the one issue 14's figures
were taken on, and ``main`` just before the 2026-12-02 speed work (the engine whose ``.OUT``
the guard references hold, with issue 13's features)."""
_RUNNER = """
import sys, tempfile, time
from pathlib import Path
from engine.run.config import load_config
from engine.run.session import Session
cfg, n = load_config(Path(sys.argv[1])), int(sys.argv[2])
out = Path(tempfile.mkdtemp()) / "B.OUT"
def replay(k):
    s = Session(cfg, out_path=out, force=True, history=1)
    try:
        s.run(max_cycles=k)
    finally:
        s.close()
replay(50)  # warm-up: lazy imports, caches
t0 = time.process_time()
replay(n)
print(time.process_time() - t0)
"""
"""One timed replay (CPU s) of the first n epochs with the .OUT written, in the engine of the
tree on ``sys.path`` (the same code for the baseline and this tree)."""
PURE = "pure"
"""Key of this tree replayed with ``UVNAV_PURE=1`` in :func:`compare_baselines`."""
LOG_STAGE = ".OUT block + write"
CYCLE = "cycle total"


def _median_time(fn: Callable[[], object], repeats: int = REPEATS) -> float:
    """Median wall time of ``fn()`` over ``repeats`` calls (s)."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def _timed(fn: Callable[..., object], acc: dict[str, float], stage: str) -> Callable[..., object]:
    """``fn`` with its wall time added to ``acc[stage]`` (s) on every call."""

    def timed(*a: object, **k: object) -> object:
        t0 = time.perf_counter()
        try:
            return fn(*a, **k)
        finally:
            acc[stage] += time.perf_counter() - t0

    return timed


@contextmanager
def _instrumented(acc: dict[str, float]) -> Iterator[None]:
    """Timers on the stage functions, the cycle and the session's .OUT path (restored after)."""
    patches: list[tuple[object, str, object]] = []
    for stage, names in STAGES.items():
        for name in names:  # "module:function", "module:Class.method", or a cycle function
            mod_name, _, attr = name.rpartition(":")
            target: object = importlib.import_module(mod_name) if mod_name else cycle_mod
            owner, _, attr = attr.rpartition(".")
            if owner:
                target = getattr(target, owner)
            patches.append((target, attr, _timed(getattr(target, attr), acc, stage)))
    # session.step calls engine.run.cycle.step through its own imported name.
    patches.append((session_mod, "step", _timed(session_mod.step, acc, CYCLE)))
    # The session writes each block by its run's block writer: the compiled one
    # (engine.fast.outlog.BlockWriter: the kernel builds the block and writes it) or the
    # reference's (engine.run.records.write_block, which the session takes by its own name):
    # both are timed as the .OUT stage.
    for obj, attr in ((BlockWriter, "__call__"), (session_mod, "write_block")):
        patches.append((obj, attr, _timed(getattr(obj, attr), acc, LOG_STAGE)))
    originals = [(obj, name, getattr(obj, name)) for obj, name, _ in patches]
    try:
        for obj, name, fn in patches:
            setattr(obj, name, fn)
        yield
    finally:
        for obj, name, fn in originals:
            setattr(obj, name, fn)


def _replay(cfg: RunConfig, out: Path, n: int) -> None:
    """Replay the first ``n`` epochs of ``cfg`` with the ``.OUT`` log at ``out``."""
    s = Session(cfg, out_path=out, force=True, history=1)
    try:
        s.run(max_cycles=n)
    finally:
        s.close()


def _stage_split(cfg: RunConfig, out: Path, n: int) -> dict[str, float]:
    """Seconds per stage (and ``CYCLE``) over instrumented replays (median of REPEATS)."""
    spent: dict[str, list[float]] = defaultdict(list)
    acc: dict[str, float] = defaultdict(float)
    with _instrumented(acc):
        for _ in range(REPEATS):
            acc.clear()
            _replay(cfg, out, n)
            for stage in (*STAGES, CYCLE, LOG_STAGE):
                if not acc[stage]:  # a renamed stage function: say so, never print a 0 row
                    raise RuntimeError(f"bench_engine: no timer fired for stage {stage!r}; "
                                       "the functions it patches are no longer called")
                spent[stage].append(acc[stage])
    return {k: statistics.median(v) for k, v in spent.items()}


KERNEL_LABEL = "engine.native."
"""cProfile names every compiled kernel's function and method with its module (the ``.OUT``
writer too, whose ``__module__`` is ``engine.native.outfmt``); nothing else has it."""


def kernel_time(cfg: RunConfig, out: Path, n: int) -> tuple[float, dict[str, float]]:
    """Seconds spent inside the compiled kernels (``engine/native``) per replay of ``n`` epochs,
    the median over REPEATS replays under cProfile, and the median seconds of each kernel
    function (keyed by cProfile's label). Only the kernels' own time is counted: what a cycle
    with no Python between the kernels would still spend, the kernels as they are (their
    Python result objects and numpy arrays included). cProfile's hooks around each kernel
    call add well under a microsecond per call (about 25 calls an epoch)."""
    totals: list[float] = []
    each: dict[str, list[float]] = defaultdict(list)
    for _ in range(REPEATS):
        prof = cProfile.Profile()
        prof.enable()
        try:
            _replay(cfg, out, n)
        finally:
            prof.disable()
        stats = pstats.Stats(prof).stats  # type: ignore[attr-defined]
        own = {label: row[2] for (where, _, label), row in stats.items()
               if where == "~" and KERNEL_LABEL in label}
        totals.append(sum(own.values()))
        for label, t in own.items():
            each[label].append(t)
    return statistics.median(totals), {k: statistics.median(v) for k, v in each.items()}


def _kernel_name(label: str) -> str:
    """``lsq.adjust_tested`` of cProfile's ``<built-in method engine.native.lsq.adjust_tested>``
    (or of ``<method 'name' of 'engine.native.decca.Type' objects>``)."""
    if label.startswith("<method '"):
        name, _, owner = label[len("<method '"):].partition("' of '")
        return owner.split("'")[0].removeprefix(KERNEL_LABEL) + "." + name
    return label.split(KERNEL_LABEL, 1)[1].rstrip(">")


def _baseline_tree(rev: str) -> Path | None:
    """The baseline engine's source tree (extracted once into the temp folder), or None."""
    dest = Path(tempfile.gettempdir()) / f"uvnav-bench-baseline-{rev}"
    if (dest / ".complete").exists():
        return dest
    try:
        tar = subprocess.run(["git", "-C", str(ROOT), "archive", "--format=tar", rev],
                             capture_output=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return None
    dest.mkdir(parents=True, exist_ok=True)
    with tarfile.open(fileobj=io.BytesIO(tar)) as tf:
        tf.extractall(dest, filter="data")
    (dest / ".complete").touch()
    return dest


def _cpu_replay(tree: Path, n: int, pure: bool = False) -> float:
    """CPU seconds of one replay of ``n`` epochs by the engine of ``tree``, in a fresh process
    (``pure``: with ``UVNAV_PURE=1``, no compiled kernel)."""
    env = {**os.environ, "PYTHONPATH": str(tree)}
    env.pop(native.PURE_ENV, None)
    if pure:
        env[native.PURE_ENV] = "1"
    done = subprocess.run([sys.executable, "-c", _RUNNER, str(tree / "data" / "DEMO.toml"),
                           str(n)], cwd=tree, env=env, capture_output=True, text=True, check=True)
    return float(done.stdout.split()[-1])


def compare_baselines(n: int, rounds: int = REPEATS) -> dict[str, float] | None:
    """Median CPU seconds for ``n`` epochs of each baseline in :data:`BASELINE_REVS`, of this
    tree (key ``""``) and of this tree on its pure-Python path (key ``PURE``), one fresh process
    each, alternating per round; None without git."""
    trees = {rev: _baseline_tree(rev) for rev in BASELINE_REVS}
    if any(t is None for t in trees.values()):
        return None
    trees[""] = trees[PURE] = ROOT
    times: dict[str, list[float]] = defaultdict(list)
    for _ in range(rounds):
        for rev, tree in trees.items():
            times[rev].append(_cpu_replay(tree, n, pure=rev == PURE))  # type: ignore[arg-type]
    return {rev: statistics.median(ts) for rev, ts in times.items()}


def main() -> None:
    """Print the replay throughput and the stage split (medians, µs per epoch, shares)."""
    cfg = load_config(CONFIG)
    n = sum(isinstance(r, RunRecord) for r in islice(iter_run_file(cfg.run_path), N_EPOCHS))
    out = Path(tempfile.mkdtemp()) / "B.OUT"
    _replay(cfg, out, n)  # warm-up: lazy imports (scipy.stats), caches
    t_full = _median_time(lambda: _replay(cfg, out, n))
    quick = choose_parts().run_record  # the run's .RUN parser (compiled where in use)
    t_parse = _median_time(lambda: list(islice(iter_run_file(cfg.run_path, quick), n)))
    split = _stage_split(cfg, out, n)
    cycle_total = split.pop(CYCLE)
    t_log = split.pop(LOG_STAGE)
    rows = [("parse .RUN", t_parse), *split.items(),
            ("rest of the cycle", cycle_total - sum(split.values())), (LOG_STAGE, t_log)]
    rate = n / t_full
    print(f"UVNAV engine benchmark: {n} epochs of data/DEMO.RUN (GPS + Decca + filter), "
          f"median of {REPEATS} runs")
    print("  compiled kernels: " + (", ".join(f"{k} {native.status(k)}"
                                              for k in native.kernel_names()) or "none"))
    print(f"  replay incl. .OUT : {t_full / n * 1e6:7.1f} µs/epoch = {rate:7.0f} epochs/s"
          f"  (target {TARGET_EPOCHS_S:,} epochs/s; ratio to target "
          f"{rate / TARGET_EPOCHS_S:.2f})")
    total = sum(t for _, t in rows)
    for name, t in rows:
        print(f"  {name:34s}: {t / n * 1e6:7.1f} µs/epoch  {100 * t / total:5.1f} %")
    t_kern, each = kernel_time(cfg, out, n)
    if t_kern > 0.0:
        top = sorted(each.items(), key=lambda kv: -kv[1])[:5]
        print(f"  compiled kernels' own time (cProfile): {t_kern / n * 1e6:.1f} µs/epoch = "
              f"{100 * t_kern / t_full:.0f} % of the replay")
        print(f"    a cycle with no Python left between them: ≤ {n / t_kern:,.0f} epochs/s")
        print("    largest: " + ", ".join(f"{_kernel_name(k)} {t / n * 1e6:.1f}"
                                          for k, t in top) + " µs/epoch")
    cmp = compare_baselines(n)
    if cmp is None:
        print(f"  baselines {', '.join(BASELINE_REVS)}: not compared (no git history here)")
        return
    t_now = cmp.pop("")
    t_pure = cmp.pop(PURE)
    print(f"  same run, CPU time, fresh processes alternating, median of {REPEATS}:")
    for rev, t_base in cmp.items():
        print(f"    {rev} ({BASELINE_REVS[rev]}): {n / t_base:7.0f} epochs/s")
    print(f"    this tree, UVNAV_PURE=1 (no compiled kernel): {n / t_pure:7.0f} epochs/s")
    print(f"    this tree: {n / t_now:7.0f} epochs/s  (ratio "
          + ", ".join(f"{t / t_now:.2f} to {rev}" for rev, t in cmp.items())
          + f", {t_pure / t_now:.2f} to its pure path)")


if __name__ == "__main__":
    main()

"""The Decca lane rule's cost: the whole demo replayed under ``[decca] lane_rule = "bootstrap"``
(the default) and ``"sigma"``.

Run with ``make bench`` (or ``python -m bench.bench_lane_rule [--repeats N] [--tree DIR]``).
After its dive the demo's Purple (lane expansion factor ≈ 33, THEORY §12.12) is never settled
under the bootstrap rule, so its lane is identified again on each of the last 1,601 records
(THEORY §3.3); the 1,500 surfaced epochs of ``bench_engine`` have no gap, so there the two rules
do the same work. Each round replays all 7,200 records with the ``.OUT`` log under each rule in
a fresh process (a 50-epoch warm-up first), alternating; the figure is the process's CPU time
(``getrusage``, user + system) of the replay, the median over the rounds, and the ratio of the
medians. ``--tree`` replays another checkout's engine beside this one (its compiled kernels
built), e.g. the main branch, for a before/after in the same run.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RULES = ("bootstrap", "sigma")
_RUNNER = """
import dataclasses, resource, sys, tempfile
from pathlib import Path
from engine.run.config import load_config
from engine.run.session import Session
cfg = load_config(Path(sys.argv[1]))
cfg = cfg.replace(decca=dataclasses.replace(cfg.decca, lane_rule=sys.argv[2]))
out = Path(tempfile.mkdtemp()) / "B.OUT"
def replay(k):
    s = Session(cfg, out_path=out, force=True, history=1)
    try:
        s.run(max_cycles=k)
    finally:
        s.close()
def cpu():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime
replay(50)  # warm-up: lazy imports, caches
t0 = cpu()
replay(None)
print(cpu() - t0)
"""
"""One replay (CPU s) of the whole demo under the lane rule argv[2], by the engine on
``sys.path``."""


def cpu_replay(tree: Path, rule: str) -> float:
    """CPU seconds of one whole demo replay under ``rule`` by the engine of ``tree``, in a
    fresh process (this checkout's data/DEMO.toml)."""
    env = {**os.environ, "PYTHONPATH": str(tree)}
    done = subprocess.run([sys.executable, "-c", _RUNNER, str(ROOT / "data" / "DEMO.toml"),
                           rule], cwd=tree, env=env, capture_output=True, text=True,
                          check=True)  # cwd: ``-c`` puts it first on sys.path
    return float(done.stdout.split()[-1])


def main() -> None:
    """Replay alternately and print the medians and ratios."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--tree", type=Path, default=None,
                        help="another checkout to replay beside this one")
    args, _rest = parser.parse_known_args()
    trees = {"this tree": ROOT}
    if args.tree is not None:
        trees[str(args.tree)] = args.tree.resolve()
    print(f"lane rule: the whole demo (7,200 records, .OUT), {os.cpu_count()} CPU(s), load "
          f"average {os.getloadavg()[0]:.1f} at the start, medians of {args.repeats} "
          "alternating fresh processes (getrusage CPU of the replay)")
    times: dict[tuple[str, str], list[float]] = {(t, r): [] for t in trees for r in RULES}
    for _ in range(args.repeats):
        for name, tree in trees.items():
            for rule in RULES:
                times[name, rule].append(cpu_replay(tree, rule))
    for name in trees:
        boot, sigma = (statistics.median(times[name, r]) for r in RULES)
        print(f"  {name}: bootstrap {boot:.3f} s, sigma {sigma:.3f} s, "
              f"bootstrap / sigma {boot / sigma:.3f}")
    print(f"  load average {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()

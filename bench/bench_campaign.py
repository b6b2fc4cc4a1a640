"""``uvnav campaign`` on Dask: per-run overhead against a plain loop, scaling 1 → 2 workers, and
the projected time of 1,000 two-hour missions (docs/CAMPAIGN.md, docs/PERFORMANCE.md).

Run with ``make bench`` (or ``python -m bench.bench_campaign``); about two minutes.

* **Plain loop**: :data:`N_RUNS` runs of the 10-minute ``SHORT_DIVE`` scenario
  (data/campaigns/scenarios/, 300 epochs each), seeds 1…N, by
  :func:`engine.campaign.run.run_one` in this process (after one warm-up run: imports).
* **Dask, 1 and 2 workers**: the same runs through the campaign's own submission loop
  (``uvnav_tui.cli.campaign._run_all``: the bounded window, rows recorded to a scratch ``--out``)
  on a ``LocalCluster`` of single-threaded worker processes; the cluster's start-up is timed
  apart, and each worker does one warm-up run first. Overhead per run = (Dask 1 worker − plain
  loop) / N. Scaling = Dask 1 worker / Dask 2 workers (2.0 is perfect on two free cores; the
  machine may be shared).
* **Dispatch cost**: the time the workers spent outside the run function, per run
  ((elapsed × workers − the rows' own ``wall_s``) / N): what Dask adds to each run, less
  sensitive to a loaded machine than the difference of two elapsed times.
* **Projection**: one run of the two-hour demo mission (``data/DEMO.scenario.toml``, 7,200
  epochs) in the plain loop, plus the dispatch cost, times 1,000: on this machine as loaded now
  (wall time, divided by 2 workers × the measured efficiency), and on free cores (the
  mission's CPU time, which a free core gives as wall time) for 2 and per 100 cores.

Figures are printed, never asserted.
"""

from __future__ import annotations

import os
import statistics
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "data"
N_RUNS = 24
MISSIONS = 1000


def _spec(tmp: Path, scenario: Path, seeds: str) -> Path:
    p = tmp / f"{scenario.name}.campaign.toml"
    p.write_text(f'scenarios = ["{scenario.as_posix()}"]\nseeds = "{seeds}"\n', encoding="utf-8")
    return p


def _dask(spec_path: Path, workers: int, out: Path) -> tuple[float, float, float]:
    """(cluster start-up s, wall s of the runs, the runs' own wall s summed over their rows)
    with ``workers`` local worker processes."""
    from engine.campaign.spec import load_campaign
    from engine.campaign.store import CampaignStore
    from uvnav_tui.cli import campaign as cli

    spec = load_campaign(spec_path)
    store = CampaignStore(out)
    store.open(spec, restart=True)
    t0 = time.perf_counter()
    client, cluster = cli._connect(None, workers)
    started = time.perf_counter() - t0
    try:
        warm = [client.submit(cli.worker_run, spec.bundle(), spec.tasks[0], None, pure=False,
                              workers=[w]) for w in client.scheduler_info()["workers"]]
        client.gather(warm)
        progress = cli._Progress(0, 0)
        t1 = time.perf_counter()
        cli._run_all(client, spec, list(spec.tasks), store, progress, None)
        wall = time.perf_counter() - t1
        store.close()
        inside = sum(r["wall_s"] for r in store.rows(spec.tasks))
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    return started, wall, inside


def main() -> None:
    from engine.campaign.run import run_one
    from engine.campaign.spec import load_campaign

    short = DATA / "campaigns" / "scenarios" / "SHORT_DIVE.scenario.toml"
    with tempfile.TemporaryDirectory(prefix="uvnav-bench-campaign-") as tmp_name:
        tmp = Path(tmp_name)
        spec_path = _spec(tmp, short, f"1-{N_RUNS}")
        spec = load_campaign(spec_path)
        bundle = spec.bundle()
        run_one(bundle, spec.tasks[0])  # warm-up: imports
        t0 = time.perf_counter()
        rows = [run_one(bundle, t) for t in spec.tasks]
        plain = time.perf_counter() - t0
        cpu = statistics.median(r["cpu_s"] for r in rows)
        start1, dask1, inside1 = _dask(spec_path, 1, tmp / "w1")
        start2, dask2, inside2 = _dask(spec_path, 2, tmp / "w2")
        demo = load_campaign(_spec(tmp, DATA / "DEMO.scenario.toml", "1"))
        t0 = time.perf_counter()
        demo_row = run_one(demo.bundle(), demo.tasks[0])
        demo_wall = time.perf_counter() - t0
    overhead = (dask1 - plain) / N_RUNS
    idle1 = (dask1 - inside1) / N_RUNS
    idle2 = (2 * dask2 - inside2) / N_RUNS
    scaling = dask1 / dask2
    efficiency = min(scaling / 2.0, 1.0)
    here_h = MISSIONS * (demo_wall + max(idle1, 0.0)) / (2 * efficiency) / 3600.0
    free_h = MISSIONS * (demo_row["cpu_s"] + max(idle1, 0.0)) / 2 / 3600.0
    per100_min = MISSIONS * (demo_row["cpu_s"] + max(idle1, 0.0)) / 100 / 60.0
    print(f"campaign: {N_RUNS} runs of SHORT_DIVE (300 epochs), load "
          f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    print(f"  plain loop            {plain:7.2f} s  ({plain / N_RUNS * 1000:.0f} ms/run, "
          f"median CPU {cpu * 1000:.0f} ms/run)")
    print(f"  Dask 1 worker         {dask1:7.2f} s  (cluster start-up {start1:.1f} s apart)")
    print(f"  Dask 2 workers        {dask2:7.2f} s  (cluster start-up {start2:.1f} s apart)")
    print(f"  Dask overhead per run {overhead * 1000:7.0f} ms  (1 worker against the plain loop)")
    print(f"  worker time outside runs per run {idle1 * 1000:.0f} ms (1 worker), "
          f"{idle2 * 1000:.0f} ms (2 workers): dispatch, transfer, recording")
    print(f"  scaling 1 -> 2 workers {scaling:6.2f}x  (efficiency {efficiency:.0%})")
    print(f"  one 2-h mission (DEMO, {demo_row['epochs']} epochs, {demo_row['status']}) "
          f"{demo_wall:.1f} s wall, {demo_row['cpu_s']:.1f} s CPU")
    print(f"  projected 1,000 two-hour missions: {here_h:.1f} h on this machine as loaded now "
          f"(2 workers at the measured efficiency), {free_h:.1f} h on 2 free cores, "
          f"{per100_min:.1f} min per 100 free cores (CPU time per mission + dispatch)")


if __name__ == "__main__":
    main()

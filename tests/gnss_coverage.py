"""Coverage of the 95 % ellipse with GNSS receiver weights (issue 13; docs/GNSS_WEIGHTS.md).

The mission ``data/scenarios/G1_GNSS_HDOP`` is simulated with a per-epoch HDOP (its GPS error
per axis has σ = HDOP × UERE / √2, mostly Gauss–Markov) and replayed in memory through the
engine's cycle (the ``.RUN`` grammar has no HDOP column, so the records go straight from the
simulator to :func:`engine.run.cycle.step`), with start-up values only. Every epoch's MPP is
scored against the truth as in :mod:`tests.missions`: coverage of its 95 % ellipse and NEES.

Run ``python -m tests.gnss_coverage [--seeds 1-10] [--truth gps.uere_m=10] [--config
gps.uere_sps_m=5]`` (``--truth`` changes the scenario's ``[gps]``, ``--config`` the run
configuration: a mismatch between them is the honest test).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from engine.run.config import RunConfig, load_config
from engine.run.cycle import build_context, initial_state, step
from engine.run.session import read_data_dir
from engine.sim.scenario import load_scenario
from engine.sim.simulate import simulate
from tests.missions import K95_SQ, SCENARIOS, _value
from tests.paths import DATA

MISSION = "G1_GNSS_HDOP"


@dataclass(frozen=True)
class Coverage:
    """One realisation: fraction of epochs with the truth in the MPP's 95 % ellipse, mean NEES
    of the MPP and of the LSE (with its own VCV: how honest the weights alone are), RMS MPP and
    LSE errors (m), the mean σ per axis the LSE's GPS weight had (m), epochs."""

    seed: int
    coverage: float
    nees: float
    nees_lse: float
    rms_mpp: float
    rms_lse: float
    sigma_m: float
    epochs: int


def _with(obj: Any, changes: dict[str, Any]) -> Any:
    return dataclasses.replace(obj, **changes) if changes else obj


def run_seed(seed: int, truth: dict[str, Any], config: dict[str, dict[str, Any]],
             data: Any) -> Coverage:
    """Simulate ``seed`` of the mission (scenario ``[gps]`` changed by ``truth``), replay it
    with the start-up configuration (tables changed by ``config``) and score it."""
    scenario = load_scenario(SCENARIOS / f"{MISSION}.scenario.toml")
    scenario = dataclasses.replace(scenario, gps=_with(scenario.gps, truth))
    cfg: RunConfig = load_config(SCENARIOS / f"{MISSION}.toml")
    for table, changes in config.items():
        cfg = cfg.replace(**{table: _with(getattr(cfg, table), changes)})
    ctx = build_context(cfg, *data)
    nav = initial_state(cfg)
    quad, quad_lse, e_mpp, e_lse, sig = [], [], [], [], []
    for tr, rec in simulate(scenario, *data, seed):
        nav, r = step(ctx, nav, rec)
        grid = ctx.grid(r.cm_deg)
        tx, ty = grid.forward(tr.lat_deg, tr.lon_deg)
        e = np.array([r.mpp.x_m - tx, r.mpp.y_m - ty])
        quad.append(float(e @ np.linalg.solve(r.mpp.cov, e)))
        e_mpp.append(math.hypot(*e))
        if r.fix is not None and r.fix.lse_ok:
            el = np.array([r.fix.x_m - tx, r.fix.y_m - ty])
            e_lse.append(math.hypot(*el))
            quad_lse.append(float(el @ np.linalg.solve(r.fix.cov, el)))
        if r.gps is not None and r.gps.weight is not None:
            sig.append(r.gps.weight.sigma_m)
    q = np.array(quad)
    return Coverage(seed, float(np.mean(q <= K95_SQ)), float(np.mean(q)),
                    float(np.mean(quad_lse)) if quad_lse else math.nan,
                    float(np.sqrt(np.mean(np.square(e_mpp)))),
                    float(np.sqrt(np.mean(np.square(e_lse)))) if e_lse else math.nan,
                    float(np.mean(sig)) if sig else math.nan, len(quad))


def _pairs(items: list[str]) -> dict[str, Any]:
    return {k: _value(v) for k, v in (item.split("=", 1) for item in items)}


def main(argv: list[str] | None = None) -> int:
    """Print the per-seed coverage table and the mean."""
    p = argparse.ArgumentParser(prog="python -m tests.gnss_coverage")
    p.add_argument("--seeds", default="1-10", help="e.g. 1-10 or 3,5,7")
    p.add_argument("--truth", nargs="*", default=[], help="scenario [gps] key=value")
    p.add_argument("--config", nargs="*", default=[], help="configuration table.key=value")
    args = p.parse_args(argv)
    lo, _, hi = args.seeds.partition("-")
    seeds = list(range(int(lo), int(hi) + 1)) if hi else [int(v) for v in lo.split(",")]
    truth = {k.removeprefix("gps."): v for k, v in _pairs(args.truth).items()}
    config: dict[str, dict[str, Any]] = {}
    for key, value in _pairs(args.config).items():
        table, _, name = key.partition(".")
        if isinstance(value, float) and value.is_integer() and name == "quality":
            value = int(value)
        config.setdefault(table, {})[name] = value
    data = read_data_dir(DATA)
    print(f"truth {truth or 'as scenario'}  config {config or 'start-up values'}")
    print("seed | cover %  NEES  LSE | RMS MPP  LSE m | σ axis m | epochs")
    rows = []
    t0 = time.perf_counter()
    for seed in seeds:
        c = run_seed(seed, truth, config, data)
        rows.append(c)
        print(f"{seed:4d} | {100 * c.coverage:6.1f} {c.nees:5.2f} {c.nees_lse:5.2f} | "
              f"{c.rms_mpp:7.2f} "
              f"{c.rms_lse:5.2f} | {c.sigma_m:8.2f} | {c.epochs}", flush=True)
    cov = np.array([c.coverage for c in rows])
    print(f"mean | {100 * cov.mean():6.1f} {np.mean([c.nees for c in rows]):5.2f} "
          f"{np.mean([c.nees_lse for c in rows]):5.2f} | "
          f"{np.mean([c.rms_mpp for c in rows]):7.2f} {np.mean([c.rms_lse for c in rows]):5.2f}"
          f" | {np.mean([c.sigma_m for c in rows]):8.2f} | min cover {100 * cov.min():.1f} %, "
          f"{time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

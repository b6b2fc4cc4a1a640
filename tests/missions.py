"""The issue-11 mission family: simulate a mission, replay it with start-up values only, score it.

Each mission is a pair in ``data/scenarios/``: ``NAME.scenario.toml`` (the true mission and its
sensor error models, docs/SIMULATOR.md) and ``NAME.toml`` (what an operator enters at start-up:
datum, DR position, depth, current, GPS on, Decca chain, zone/lanes and selected patterns; no
``[filter]``, ``[lsq]`` or ``[demo]`` table). A seed is simulated in memory
(:func:`engine.sim.simulate.simulate`), written to a ``.RUN`` in a scratch directory, replayed
through :class:`engine.run.session.Session` with that configuration (only ``run_file`` changed,
plus optional ``[filter]`` overrides for comparisons) and every cycle is scored against the
simulator's truth: the MPP (with its own 2×2 covariance) and the LSE against the true position
projected on the cycle's grid, and each Decca total lane count used against the count of the
lane model at the true position.

Phases: ``surfaced`` (before the first fix-less epoch), ``submerged`` (no GPS/Decca: the truth's
``surfaced`` column is 0) and ``after`` (fixes again after a dive).

Run ``python -m tests.missions [NAME ...] [--seeds 1-10] [--filter key=value ...]`` for the
per-seed table and the mean over seeds (docs/ASSESS.md, "Missions nobody tuned to").
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from engine.io.datumfile import DatumFile
from engine.io.deccafile import DeccaChain
from engine.run.config import RunConfig, load_config
from engine.run.session import Session, read_data_dir
from engine.sim.scenario import load_scenario
from engine.sim.simulate import simulate
from engine.systems.decca import decca_geometry
from tests.paths import DATA

SCENARIOS = DATA / "scenarios"
MISSIONS = ("M1_SURF9B", "M2_DECCA2E", "M3_GPS_CM_MIDNIGHT", "M4_GPS_SW_WGS84", "M5_DIVE30",
            "M6_DIVE150")
PHASES = ("surfaced", "submerged", "after")
K95_SQ = -2.0 * math.log(0.05)  # 2-D 95 % ellipse: eᵀC⁻¹e ≤ 5.991


@dataclass(frozen=True)
class MissionFigures:
    """One replayed realisation of a mission, per phase (see the module docstring).

    ``coverage``: fraction of epochs whose truth lies in the MPP's 95 % ellipse (also
    ``"all"``); ``nees``: mean eᵀC⁻¹e of the MPP; ``rms_mpp``/``rms_lse``/``max_mpp``: horizontal
    errors (m; the LSE's only over epochs with an independent LSE, nan without);
    ``wrong_lane``: epochs whose fix used a Decca total lane count off the truth's by more than
    half a lane; ``lane_out``: epochs with Decca fractions but no lane count used;
    ``gated``/``lom_rejected``: fix updates kept out by the gross-error gate / failing the
    filter's innovation (LOM) test; ``seconds``: replay wall time.
    """

    mission: str
    seed: int
    epochs: dict[str, int]
    coverage: dict[str, float]
    nees: dict[str, float]
    rms_mpp: dict[str, float]
    rms_lse: dict[str, float]
    max_mpp: dict[str, float]
    wrong_lane: dict[str, int]
    lane_out: dict[str, int]
    gated: int
    lom_rejected: int
    fix_updates: int
    bad_records: int
    seconds: float


def _rms(errors: list[float]) -> float:
    return float(np.sqrt(np.mean(np.square(errors)))) if errors else math.nan


def mission_config(name: str, run_path: Path, filter_changes: dict[str, Any] | None = None
                   ) -> RunConfig:
    """The start-up configuration of mission ``name`` pointed at ``run_path``."""
    cfg = load_config(SCENARIOS / f"{name}.toml").replace(run_file=str(run_path))
    if filter_changes:
        cfg = cfg.replace(filter=dataclasses.replace(cfg.filter, **filter_changes))
    return cfg


def replay_mission(
    name: str,
    seed: int,
    data: tuple[DatumFile, dict[str, DeccaChain]],
    run_dir: Path,
    filter_changes: dict[str, Any] | None = None,
) -> MissionFigures:
    """Simulate ``seed`` of mission ``name``, replay it with its start-up values, score it."""
    scenario = load_scenario(SCENARIOS / f"{name}.scenario.toml")
    pairs = list(simulate(scenario, *data, seed))
    run_path = run_dir / f"{name}_{seed}.RUN"
    run_path.write_text("".join(rec.raw + "\n" for _t, rec in pairs), encoding="ascii")
    cfg = mission_config(name, run_path, filter_changes)
    t0 = time.perf_counter()
    session = Session(cfg, history=1, data=data)
    err: dict[str, dict[str, list[float]]] = {p: {"mpp": [], "lse": []} for p in PHASES}
    quad: dict[str, list[float]] = {p: [] for p in PHASES}
    wrong = dict.fromkeys(PHASES, 0)
    lane_out = dict.fromkeys(PHASES, 0)
    gated = lom_rejected = fix_updates = 0
    dived = False
    for truth, rec in pairs:
        r = session.step()
        assert r is not None and r.time == truth.time, (name, seed, truth.time)
        dived |= not truth.surfaced
        phase = "submerged" if not truth.surfaced else ("after" if dived else "surfaced")
        grid = session.context.grid(r.cm_deg)
        tx, ty = grid.forward(truth.lat_deg, truth.lon_deg)
        e = np.array([r.mpp.x_m - tx, r.mpp.y_m - ty])
        quad[phase].append(float(e @ np.linalg.solve(r.mpp.cov, e)))
        err[phase]["mpp"].append(math.hypot(*e))
        fix = r.fix
        if fix is not None and fix.ok and not fix.uses_prior:
            err[phase]["lse"].append(math.hypot(fix.x_m - tx, fix.y_m - ty))
        if any(m.startswith("Fix ") and "gross error" in m for m in r.messages):
            gated += 1
        u = r.filter_update
        if u is not None and fix is not None and fix.ok:
            fix_updates += 1
            lom_rejected += u.lom.verdict == "reject"
        if cfg.decca.on and any(f is not None for f in rec.decca):
            placed = session.context.placed_chain(r.cm_deg)
            assert placed is not None
            observed = (None, None, None) if fix is None else fix.decca_observed
            geom = None
            for i, pattern in enumerate(("red", "green", "purple")):
                if pattern not in cfg.decca.select or rec.decca[i] is None:
                    continue
                if observed[i] is None:
                    lane_out[phase] += 1
                    continue
                if geom is None:
                    geom = decca_geometry(placed, tx, ty, session.context.geodesic)
                if abs(float(observed[i]) - float(geom.n_calc[i])) > 0.5:  # type: ignore[arg-type]
                    wrong[phase] += 1
                    break
    assert session.step() is None
    every = [q for p in PHASES for q in quad[p]]

    def frac_in(q: list[float]) -> float:
        return float(np.mean(np.array(q) <= K95_SQ)) if q else math.nan

    coverage = {p: frac_in(quad[p]) for p in PHASES}
    coverage["all"] = frac_in(every)
    nees = {p: float(np.mean(quad[p])) if quad[p] else math.nan for p in PHASES}
    nees["all"] = float(np.mean(every))
    return MissionFigures(
        mission=name, seed=seed,
        epochs={p: len(quad[p]) for p in PHASES},
        coverage=coverage, nees=nees,
        rms_mpp={p: _rms(err[p]["mpp"]) for p in PHASES},
        rms_lse={p: _rms(err[p]["lse"]) for p in PHASES},
        max_mpp={p: max(err[p]["mpp"], default=math.nan) for p in PHASES},
        wrong_lane=wrong, lane_out=lane_out, gated=gated, lom_rejected=lom_rejected,
        fix_updates=fix_updates, bad_records=len(session.bad_records),
        seconds=time.perf_counter() - t0,
    )


HEADER = ("mission              seed | cover % surf dive after  all | NEES all | RMS m surf "
          "MPP/LSE | after MPP/LSE | max dive | lane wrong/out | gated LOM-rej/upd")


def row(f: MissionFigures, label: str | None = None) -> str:
    """One line of the figures table."""
    c = f.coverage
    return (f"{f.mission:<20} {label or f.seed:>4} | {100 * c['surfaced']:5.1f} "
            f"{100 * c['submerged']:5.1f} {100 * c['after']:5.1f} {100 * c['all']:5.1f} | "
            f"{f.nees['all']:7.2f} | {f.rms_mpp['surfaced']:6.1f} {f.rms_lse['surfaced']:6.1f} | "
            f"{f.rms_mpp['after']:6.1f} {f.rms_lse['after']:6.1f} | {f.max_mpp['submerged']:7.0f}"
            f" | {f.wrong_lane['after'] + f.wrong_lane['surfaced']:4d} "
            f"{sum(f.lane_out.values()):5d} | {f.gated:4d} {f.lom_rejected:5d}/{f.fix_updates}")


def mean_figures(figs: list[MissionFigures]) -> MissionFigures:
    """The mean over seeds of every figure (counts summed), for the table's summary line."""

    def avg(attr: str) -> dict[str, float]:
        keys = getattr(figs[0], attr).keys()
        return {k: float(np.nanmean([getattr(f, attr)[k] for f in figs])) if not all(
            math.isnan(getattr(f, attr)[k]) for f in figs) else math.nan for k in keys}

    def total(attr: str) -> dict[str, int]:
        return {k: sum(getattr(f, attr)[k] for f in figs) for k in getattr(figs[0], attr)}

    return MissionFigures(
        mission=figs[0].mission, seed=-1, epochs=figs[0].epochs, coverage=avg("coverage"),
        nees=avg("nees"), rms_mpp=avg("rms_mpp"), rms_lse=avg("rms_lse"),
        max_mpp={k: max(f.max_mpp[k] for f in figs) for k in PHASES},
        wrong_lane=total("wrong_lane"), lane_out=total("lane_out"),
        gated=sum(f.gated for f in figs), lom_rejected=sum(f.lom_rejected for f in figs),
        fix_updates=sum(f.fix_updates for f in figs), bad_records=sum(f.bad_records for f in figs),
        seconds=sum(f.seconds for f in figs))


def _value(text: str) -> Any:
    low = text.lower()
    if low in ("true", "false"):
        return low == "true"
    try:
        return float(text)
    except ValueError:
        return text


def main(argv: list[str] | None = None) -> int:
    """Print the figures table of the given missions over the given seeds."""
    p = argparse.ArgumentParser(prog="python -m tests.missions")
    p.add_argument("missions", nargs="*", default=list(MISSIONS))
    p.add_argument("--seeds", default="1-10", help="e.g. 1-10 or 3,5,7")
    p.add_argument("--filter", nargs="*", default=[], help="[filter] overrides key=value")
    args = p.parse_args(argv)
    if "-" in args.seeds:
        lo, hi = (int(v) for v in args.seeds.split("-"))
        seeds = list(range(lo, hi + 1))
    else:
        seeds = [int(v) for v in args.seeds.split(",")]
    changes = {k: _value(v) for k, v in (item.split("=", 1) for item in args.filter)}
    data = read_data_dir(DATA)
    print(HEADER, flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.missions:
            figs = []
            for seed in seeds:
                figs.append(replay_mission(name, seed, data, Path(tmp), changes))
                print(row(figs[-1]), flush=True)
            print(row(mean_figures(figs), "mean"), f" ({figs[0].epochs})", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

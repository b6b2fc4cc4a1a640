"""Randomized missions (engine/sim/sampler.py) scored against the targets of docs/ASSESS.md
("Randomized missions"): the figures of a campaign's rows, the distribution tables and the worst
missions with their drawn parameters.

``python -m tests.random_missions DIR [--worst N]`` prints the tables of a finished (or
partly finished) ``uvnav campaign data/campaigns/random.toml --out DIR``; the slow test
tests/assess/test_random_missions.py asserts the targets on ``data/campaigns/random_60.toml``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

Row = Mapping[str, Any]

PHASES = ("surfaced", "submerged", "after")
MIN_PHASE_EPOCHS = 300
"""A phase is scored when it holds at least this many epochs (the targets' wording)."""
PHASE_COVER = 0.85
SHARE_MISSIONS = 0.95
MEDIAN_ALL = (0.92, 0.985)
BEYOND_2A = 0.005
MPP_LE_LSE = 0.90


@dataclass(frozen=True)
class Figures:
    """The target figures of a set of runs (ok or failed; a failed run fails every target)."""

    missions: int
    failed: int
    share_phases_ok: float
    median_all_cover: float
    beyond_2a: float
    mpp_le_lse_share: float
    mpp_le_lse_missions: int
    wrong_lanes: int
    missions_with_wrong_lanes: int


def _f(x: Any) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return math.nan
    return v


def phases_ok(row: Row) -> bool:
    """MPP coverage ≥ 85 % in every phase of ≥ 300 epochs (a failed run is not ok)."""
    if row["status"] != "ok":
        return False
    for ph in PHASES:
        if int(row[f"{ph}_epochs"]) >= MIN_PHASE_EPOCHS:
            c = _f(row[f"{ph}_mpp_cover95"])
            if not (c >= PHASE_COVER):
                return False
    return True


def figures(rows: Iterable[Row]) -> Figures:
    rows = list(rows)
    ok = [r for r in rows if r["status"] == "ok"]
    n_all = sum(int(r["all_epochs"]) for r in ok)
    beyond = (sum(_f(r["all_mpp_beyond2a"]) * int(r["all_epochs"]) for r in ok
                  if math.isfinite(_f(r["all_mpp_beyond2a"]))) / n_all if n_all else math.nan)
    pairs = [(_f(r["fixes_mpp_rms_m"]), _f(r["fixes_lse_rms_m"])) for r in ok]
    pairs = [(m, s) for m, s in pairs if math.isfinite(m) and math.isfinite(s)]
    wrong = [sum(int(r[f"wrong_lane_{ph}"]) for ph in PHASES) for r in ok]
    return Figures(
        missions=len(rows), failed=len(rows) - len(ok),
        share_phases_ok=sum(phases_ok(r) for r in rows) / len(rows) if rows else math.nan,
        median_all_cover=float(np.median([_f(r["all_mpp_cover95"]) for r in ok])) if ok
        else math.nan,
        beyond_2a=beyond,
        mpp_le_lse_share=sum(m <= s for m, s in pairs) / len(pairs) if pairs else math.nan,
        mpp_le_lse_missions=len(pairs), wrong_lanes=sum(wrong),
        missions_with_wrong_lanes=sum(w > 0 for w in wrong))


def _q(values: Sequence[float]) -> str:
    a = np.asarray([v for v in values if math.isfinite(v)], dtype=float)
    if a.size == 0:
        return "– | – | – | – | –"
    qs = np.percentile(a, [5, 25, 50, 75, 95])
    return " | ".join(f"{100 * q:.1f}" for q in qs)


def tables(rows: Iterable[Row]) -> str:
    """Markdown: the per-phase coverage quantiles and the target figures."""
    rows = list(rows)
    ok = [r for r in rows if r["status"] == "ok"]
    lines = ["| phase | missions (≥ 300 epochs) | p5 | p25 | median | p75 | p95 | share ≥ 85 % |",
             "|---|---|---|---|---|---|---|---|"]
    for ph in (*PHASES, "all"):
        sel = [r for r in ok if int(r[f"{ph}_epochs"]) >= (MIN_PHASE_EPOCHS if ph != "all" else 1)]
        cov = [_f(r[f"{ph}_mpp_cover95"]) for r in sel]
        share = sum(c >= PHASE_COVER for c in cov) / len(cov) if cov else math.nan
        lines.append(f"| {ph} | {len(sel)} | {_q(cov)} | {100 * share:.1f} % |")
    f = figures(rows)
    lines += ["", "| target | measured | target value |", "|---|---|---|",
              f"| missions ≥ 85 % in every phase of ≥ 300 epochs | {100 * f.share_phases_ok:.1f} %"
              f" of {f.missions} | ≥ 95 % |",
              f"| median all-epoch coverage | {100 * f.median_all_cover:.1f} % | 92–98.5 % |",
              f"| epochs with error > 2 × a95 (all missions pooled) | {100 * f.beyond_2a:.2f} % |"
              " ≤ 0.5 % |",
              f"| MPP RMS ≤ LSE RMS while surfaced | {100 * f.mpp_le_lse_share:.1f} % of "
              f"{f.mpp_le_lse_missions} | ≥ 90 % |",
              f"| epochs with a wrong Decca lane | {f.wrong_lanes} in "
              f"{f.missions_with_wrong_lanes} missions | 0 |",
              f"| failed runs | {f.failed} | 0 |"]
    return "\n".join(lines)


def read_rows(directory: str | Path) -> list[dict[str, Any]]:
    """Every recorded row of a campaign directory (its ``parts/*.jsonl``), by seed."""
    rows: dict[str, dict[str, Any]] = {}
    for part in sorted(Path(directory, "parts").glob("part-*.jsonl")):
        for line in part.read_text(encoding="utf-8").splitlines():
            if line.strip():
                r = json.loads(line)
                rows[r["key"]] = r
    return sorted(rows.values(), key=lambda r: int(r["seed"]))


def worst(rows: Iterable[Row], n: int = 8) -> str:
    """The ``n`` missions with the lowest worst-phase coverage, with what the sampler drew."""
    from engine.sim.sampler import SamplerOptions, draw_mission
    from engine.sim.simulate import read_data_files
    from tests.paths import DATA

    data = read_data_files(DATA)

    def score(r: Row) -> float:
        vals = [_f(r[f"{ph}_mpp_cover95"]) for ph in PHASES
                if int(r[f"{ph}_epochs"]) >= MIN_PHASE_EPOCHS]
        return min(vals) if vals else 1.0

    out = ["| seed | min phase cov. | all cov. | beyond 2a | drawn |", "|---|---|---|---|---|"]
    for r in sorted((r for r in rows if r["status"] == "ok"), key=score)[:n]:
        interval = 2  # data/campaigns/random*.toml
        g = draw_mission(int(r["seed"]), *data, SamplerOptions(sample_interval_s=interval)).drawn
        drawn = (f"{g['systems']} {g['chain']}, {int(g['mission_s']) / 60:.0f} min "
                 f"({int(g['dived_s']) / 60:.0f} dived, {g['dives']} dives), GPS σ "
                 f"{g['gps_sigma_m']} m τ {g['gps_tau_s']} s"
                 f"{' HDOP' if float(g['gps_hdop']) > 0 else ''}, Decca ×{g['decca_red_scale']}/"
                 f"{g['decca_green_scale']}/{g['decca_purple_scale']} τ {g['decca_tau_s']} s, "
                 f"sky-wave legs {g['skywave_legs']} (max ×{g['skywave_max']}), current "
                 f"{g['current_kn']} kn, entry off {g['entry_error_kn']} kn, gyro bias "
                 f"{g['gyro_bias_deg']}°, log {100 * float(g['log_scale']):+.1f} %")
        out.append(f"| {r['seed']} | {100 * score(r):.1f} % | "
                   f"{100 * _f(r['all_mpp_cover95']):.1f} % | "
                   f"{100 * _f(r['all_mpp_beyond2a']):.1f} % | {drawn} |")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m tests.random_missions")
    p.add_argument("directory", help="the --out directory of a random campaign")
    p.add_argument("--worst", type=int, default=8)
    p.add_argument("--seeds", type=int, default=0, help="only seeds 1..N (0: all)")
    args = p.parse_args(argv)
    rows = read_rows(args.directory)
    if args.seeds:
        rows = [r for r in rows if 1 <= int(r["seed"]) <= args.seeds]
    print(f"{len(rows)} runs")
    print(tables(rows))
    print()
    print(worst(rows, args.worst))
    wall = [_f(r["wall_s"]) for r in rows]
    ep = sum(int(r["epochs"]) for r in rows)
    print(f"\nwall per run: median {np.median(wall):.1f} s, mean {np.mean(wall):.1f} s; "
          f"{ep / sum(wall):.0f} epochs/s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""The mission family on the campaign engine: simulate a mission, replay it with start-up values
only, score it (docs/ASSESS.md, "Missions nobody tuned to").

Each mission is a pair in ``data/scenarios/``: ``NAME.scenario.toml`` (the true mission and its
sensor error models, docs/SIMULATOR.md) and ``NAME.toml`` (what an operator enters at start-up;
no ``[filter]``, ``[lsq]`` or ``[demo]`` table). The campaign ``data/campaigns/missions.toml``
names all six with seeds 1–10; a run is :func:`engine.campaign.run.run_one` (simulate → replay
→ assess, plus the lane checks), its figures a row of the campaign table (docs/CAMPAIGN.md).
Here the runs are a plain loop in this process (no Dask); the same table, with Dask::

    uvnav campaign data/campaigns/missions.toml --out missions

``python -m tests.missions [NAME ...] [--seeds 1-10] [--filter key=value ...]`` prints the
summary (per-scenario means, distributions, worst runs) of a plain-loop run.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Iterable, Mapping
from typing import Any

from engine.campaign.run import COLUMNS, run_one
from engine.campaign.spec import (
    CampaignBundle,
    RunTask,
    Variant,
    load_campaign,
    parse_seeds,
    run_key,
)
from engine.campaign.summary import summary_markdown
from tests.paths import DATA

SPEC = DATA / "campaigns" / "missions.toml"
SCENARIOS = DATA / "scenarios"
K95_SQ = -2.0 * math.log(0.05)  # 2-D 95 % ellipse: eᵀC⁻¹e ≤ 5.991 (tests/gnss_coverage.py)
MISSIONS = ("M1_SURF9B", "M2_DECCA2E", "M3_GPS_CM_MIDNIGHT", "M4_GPS_SW_WGS84", "M5_DIVE30",
            "M6_DIVE150")
Row = dict[str, Any]


def mission_rows(names: Iterable[str], seeds: Iterable[int],
                 filter_changes: Mapping[str, Any] | None = None) -> dict[str, list[Row]]:
    """The campaign rows of missions ``names`` over ``seeds``, with optional ``[filter]``
    overrides (a variant named ``filter``), by mission."""
    spec = load_campaign(SPEC)
    bundle = spec.bundle()
    variant = (Variant("filter", {"filter": dict(filter_changes)}) if filter_changes
               else bundle.variants["default"])
    bundle = CampaignBundle(bundle.scenarios, {variant.name: variant})
    out: dict[str, list[Row]] = {}
    for name in names:
        inputs = bundle.scenarios[name]
        out[name] = [run_one(bundle, RunTask(name, variant.name, seed,
                                             run_key(inputs, variant, seed)))
                     for seed in seeds]
    return out


def summary(rows: Iterable[Row], title: str = "missions") -> str:
    """The campaign summary (engine.campaign.summary) of ``rows``."""
    rows = list(rows)
    cols = {name: [r[name] for r in rows] for name, _kind in COLUMNS}
    return summary_markdown(cols, name=title, spec_path=str(SPEC), planned=len(rows))


def _value(text: str) -> Any:
    low = text.lower()
    if low in ("true", "false"):
        return low == "true"
    try:
        return float(text)
    except ValueError:
        return text


def main(argv: list[str] | None = None) -> int:
    """Print the summary of the given missions over the given seeds."""
    p = argparse.ArgumentParser(prog="python -m tests.missions")
    p.add_argument("missions", nargs="*", default=list(MISSIONS))
    p.add_argument("--seeds", default="1-10", help="e.g. 1-10 or 3,5,7")
    p.add_argument("--filter", nargs="*", default=[], help="[filter] overrides key=value")
    args = p.parse_args(argv)
    changes = {k: _value(v) for k, v in (item.split("=", 1) for item in args.filter)}
    rows = mission_rows(args.missions, parse_seeds(args.seeds), changes or None)
    print(summary(r for name in args.missions for r in rows[name]))
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""The campaign's summary (``DIR/summary.md``): distributions per variant and phase, the mission
table per scenario and variant, the worst runs and the failed ones.

Input: the table's columns as a mapping name → sequence (e.g. ``pyarrow.Table.to_pydict()`` of
the columns :data:`SUMMARY_COLUMNS`). Statistics are over the ``ok`` runs: median, 5th and 95th
percentile (linear interpolation) over runs; the mission table gives means over seeds (lane
counts summed, the dive maximum the largest), as docs/ASSESS.md does. Pure: returns text.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from engine.campaign.run import PHASES, SINCE_FIX_BINS_MIN, since_fix_column

__all__ = ["DISTRIBUTION_METRICS", "SUMMARY_COLUMNS", "summary_markdown", "variant_arrays"]

DISTRIBUTION_METRICS: tuple[tuple[str, str, float], ...] = (
    ("mpp_cover95", "MPP 95 % coverage (%)", 100.0),
    ("mpp_nees", "MPP NEES", 1.0),
    ("mpp_rms_m", "MPP RMS (m)", 1.0),
    ("mpp_p95_m", "MPP p95 (m)", 1.0),
    ("mpp_max_m", "MPP max (m)", 1.0),
    ("lse_rms_m", "LSE RMS (m)", 1.0),
    ("lse_cover95", "LSE 95 % coverage (%)", 100.0),
    ("mpp_beyond2a", "MPP error > 2 × a95 (% of epochs)", 100.0),
)
"""(column suffix after ``{phase}_``, label, scale) of the distribution table."""
WORST = 5
"""Worst runs listed per variant."""
MAX_FAILED_LISTED = 20

SUMMARY_COLUMNS: tuple[str, ...] = (
    "scenario", "variant", "seed", "status", "error", "wall_s", "cpu_s",
    *(f"{ph}_{m}" for ph in PHASES for m, _l, _s in DISTRIBUTION_METRICS),
    *(f"{ph}_epochs" for ph in PHASES),
    *(since_fix_column(lo, hi) for lo, hi in SINCE_FIX_BINS_MIN),
    "wrong_lane_surfaced", "wrong_lane_submerged", "wrong_lane_after", "fix_updates",
    "lom_rejected",
)
"""The columns the summary and the plots read."""


def _arr(cols: Mapping[str, Sequence[Any]], name: str, sel: np.ndarray) -> np.ndarray:
    return np.asarray(cols[name], dtype=float)[sel]


def _pct(values: np.ndarray) -> tuple[float, float, float]:
    v = values[np.isfinite(values)]
    if v.size == 0:
        return (math.nan,) * 3
    p5, p50, p95 = np.percentile(v, [5.0, 50.0, 95.0])
    return float(p50), float(p5), float(p95)


def _num(v: float, digits: int = 1) -> str:
    return "–" if not math.isfinite(v) else f"{v:.{digits}f}"


def _md(text: str) -> str:
    """Text from a file or an error message as a literal table cell (no markup, no breaks)."""
    out = text.replace("\\", "\\\\").replace("|", "\\|").replace("\n", " ")
    for ch in "`*_[]<>#":
        out = out.replace(ch, "\\" + ch)
    return out


def variant_arrays(cols: Mapping[str, Sequence[Any]]) -> dict[str, np.ndarray]:
    """Boolean masks of the ``ok`` rows per variant (in order of first appearance)."""
    variants = list(dict.fromkeys(cols["variant"]))
    status = np.asarray(cols["status"])
    vcol = np.asarray(cols["variant"])
    return {v: (vcol == v) & (status == "ok") for v in variants}


def _distribution_table(cols: Mapping[str, Sequence[Any]], masks: Mapping[str, np.ndarray]
                        ) -> list[str]:
    lines = ["## Distributions over runs (median [p5, p95])", ""]
    head = "| variant | phase | runs | " + " | ".join(lab for _m, lab, _s in DISTRIBUTION_METRICS)
    lines += [head + " |", "|---|---|---:|" + "---|" * len(DISTRIBUTION_METRICS)]
    for v, sel in masks.items():
        for ph in PHASES:
            has = _arr(cols, f"{ph}_epochs", sel) > 0
            if not has.any():
                continue
            cells = []
            for m, _lab, scale in DISTRIBUTION_METRICS:
                med, lo, hi = _pct(_arr(cols, f"{ph}_{m}", sel)[has] * scale)
                digits = 2 if m.endswith("nees") else 1
                cells.append(f"{_num(med, digits)} [{_num(lo, digits)}, {_num(hi, digits)}]")
            lines.append(f"| {_md(v)} | {ph} | {int(has.sum())} | " + " | ".join(cells) + " |")
    return lines


def _mission_table(cols: Mapping[str, Sequence[Any]], masks: Mapping[str, np.ndarray]
                   ) -> list[str]:
    lines = ["## Per scenario (means over seeds)", "",
             "| scenario | variant | runs | surf | dive | after | all | NEES | "
             "RMS surf MPP / LSE | after MPP (target) | dive max | wrong lanes | LOM rej % |",
             "|---|---|---:|---|---|---|---|---|---|---|---|---|---|"]
    scen = np.asarray(cols["scenario"])
    for name in dict.fromkeys(cols["scenario"]):
        for v, vsel in masks.items():
            sel = vsel & (scen == name)
            n = int(sel.sum())
            if n == 0:
                continue

            def mean(col: str, scale: float = 1.0, s: np.ndarray = sel) -> float:
                a = _arr(cols, col, s) * scale
                return float(np.nanmean(a)) if np.isfinite(a).any() else math.nan

            lse_surf = mean("surfaced_lse_rms_m")
            after = mean("after_mpp_rms_m")
            target = f"{_num(after)} (≤ {_num(1.5 * lse_surf)})" if math.isfinite(after) else "–"
            dive = _arr(cols, "submerged_mpp_max_m", sel)
            dive_max = float(np.nanmax(dive)) if np.isfinite(dive).any() else math.nan
            wrong = sum(int(_arr(cols, f"wrong_lane_{p}", sel).sum())
                        for p in ("surfaced", "after"))
            upd = float(_arr(cols, "fix_updates", sel).sum())
            rej = float(_arr(cols, "lom_rejected", sel).sum())
            lom = 100.0 * rej / upd if upd else math.nan
            lines.append(
                f"| {_md(name)} | {_md(v)} | {n} | {_num(mean('surfaced_mpp_cover95', 100))} | "
                f"{_num(mean('submerged_mpp_cover95', 100))} | "
                f"{_num(mean('after_mpp_cover95', 100))} | {_num(mean('all_mpp_cover95', 100))} | "
                f"{_num(mean('all_mpp_nees'), 2)} | {_num(mean('surfaced_mpp_rms_m'))} / "
                f"{_num(lse_surf)} | {target} | {_num(dive_max, 0)} | {wrong} | {_num(lom)} |")
    return lines


def _worst(cols: Mapping[str, Sequence[Any]], masks: Mapping[str, np.ndarray]) -> list[str]:
    lines = ["## Worst runs", "", "| variant | by | scenario | seed | value |",
             "|---|---|---|---:|---:|"]
    scen = np.asarray(cols["scenario"])
    seed = np.asarray(cols["seed"])
    for v, sel in masks.items():
        idx = np.flatnonzero(sel)
        for col, label, low, scale in (("all_mpp_cover95", "lowest MPP coverage %", True, 100.0),
                                       ("all_mpp_max_m", "largest MPP error m", False, 1.0)):
            vals = np.asarray(cols[col], dtype=float)[idx]
            ok = np.isfinite(vals)
            order = idx[ok][np.argsort(vals[ok] if low else -vals[ok], kind="stable")][:WORST]
            for i in order:
                value = float(cols[col][i]) * scale
                lines.append(f"| {_md(v)} | {label} | {_md(str(scen[i]))} | {int(seed[i])} | "
                             f"{value:.1f} |")
    return lines


def _failed(cols: Mapping[str, Sequence[Any]]) -> list[str]:
    status = np.asarray(cols["status"])
    bad = np.flatnonzero(status != "ok")
    if bad.size == 0:
        return []
    lines = [f"## Failed runs ({bad.size})", "", "| scenario | variant | seed | error |",
             "|---|---|---:|---|"]
    for i in bad[:MAX_FAILED_LISTED]:
        lines.append(f"| {_md(str(cols['scenario'][i]))} | {_md(str(cols['variant'][i]))} | "
                     f"{int(cols['seed'][i])} | {_md(str(cols['error'][i]))} |")
    if bad.size > MAX_FAILED_LISTED:
        lines.append(f"\n… and {bad.size - MAX_FAILED_LISTED} more (status = 'failed' in the "
                     "table).")
    return lines


def summary_markdown(cols: Mapping[str, Sequence[Any]], *, name: str, spec_path: str,
                     planned: int) -> str:
    """The text of ``summary.md`` for the table columns ``cols`` (see the module docstring);
    ``planned`` is the number of runs of the spec (the table may hold fewer: interrupted)."""
    n = len(cols["status"])
    ok = sum(1 for s in cols["status"] if s == "ok")
    wall = float(np.nansum(np.asarray(cols["wall_s"], dtype=float))) if n else 0.0
    cpu = float(np.nansum(np.asarray(cols["cpu_s"], dtype=float))) if n else 0.0
    lines = [f"# Campaign {_md(name)}", "",
             f"Spec `{spec_path.replace('`', '')}`: {n} of {planned} runs recorded, {ok} ok, "
             f"{n - ok} failed; "
             f"run time summed over runs {wall:.1f} s wall, {cpu:.1f} s CPU.", ""]
    if n < planned:
        lines += ["**Incomplete**: rerun the same command to finish the remaining runs.", ""]
    masks = variant_arrays(cols)
    if ok:
        lines += _distribution_table(cols, masks) + [""]
        lines += _mission_table(cols, masks) + [""]
        lines += _worst(cols, masks) + [""]
    lines += _failed(cols)
    return "\n".join(lines).rstrip() + "\n"

"""Where the MPP loses to the LSE while surfaced on randomized missions (docs/ASSESS.md,
"Randomized missions", "Why the MPP does not beat the LSE").

    .venv/bin/python -m tests.mpp_diagnose [--spec TOML] [--seeds 1-60] [--set TABLE.KEY=VALUE]
        [--oracle]

For each seed the mission is drawn, simulated and replayed exactly as a campaign run does
(``engine.campaign.run``), and once more from a twin simulation whose GPS has no white noise
(``white_sigma_m = 0``, ``white_frac = 0``; every random draw is the same, so the twin's LSE
error is the coloured part of the first run's). Over the epochs the campaign's
``fixes_mpp_rms_m`` / ``fixes_lse_rms_m`` columns use (surfaced, either surfaced phase, with an
independent LSE) it prints per mission: the systems, the drawn GPS σ, τ and white σ and the
Decca τ, the epochs, the RMS error of the MPP, of the LSE and of the LSE's coloured part, the
white share of the LSE's mean square error against the filter's modelled one (1 −
``fix_sigma_frac``), and the mission's difference of mean square errors MSE_MPP − MSE_LSE (m²)
split by where the epochs lie: the first minute and minutes 1–5 of the surfaced start, the
same after each resurfacing, and the rest (≥ 5 min into a surfaced stretch). The five parts
add up to the difference; a mission loses (MPP RMS > LSE RMS) when it is positive. Then the
share of missions won and the median ratio by fixing system and by the drawn fix-error τ.
Nothing is asserted: a diagnosis, not a test. About 10 s a mission on one core.

``--oracle`` gives the filter each mission's drawn fix-error model, which no default may take
(docs/ASSESS.md): ``filter.fix_tau_s`` the drawn τ (GPS alone: the GPS τ, and
``fix_sigma_frac`` its drawn coloured share, at most 0.99; Decca alone: the Decca τ; both: the
longer of the two, the rule of the "auto" τ). It bounds what learning or citing the fix-error
model could give the MPP.
"""

from __future__ import annotations

import argparse
import dataclasses
import re
import sys
import tempfile
import tomllib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from engine.assess.accuracy import AssessmentSeries, assess, read_nav_log, read_truth
from engine.campaign import run as crun
from engine.campaign.spec import ScenarioInputs, load_campaign, merge_overrides
from engine.run.config import config_from_data
from engine.run.cycle import filter_params_from_config
from engine.run.session import Session, read_data_dir

ROOT = Path(__file__).resolve().parent.parent
WINDOWS = ("start <1 min", "start 1-5 min", "resurf <1 min", "resurf 1-5 min", "rest")
"""The parts of MSE_MPP − MSE_LSE (module docstring)."""


def _parse_seeds(text: str) -> list[int]:
    out: list[int] = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        out += list(range(int(lo), int(hi or lo) + 1))
    return out


def _parse_set(items: Sequence[str]) -> dict[str, Any]:
    over: dict[str, Any] = {}
    for item in items:
        key, _, text = item.partition("=")
        try:
            value: Any = tomllib.loads(f"v = {text}")["v"]
        except tomllib.TOMLDecodeError:
            value = text
        node = over
        *tables, name = key.split(".")
        for t in tables:
            node = node.setdefault(t, {})
        node[name] = value
    return over


def _replay(inputs: ScenarioInputs, seed: int, over: dict[str, Any], tmp: Path
            ) -> tuple[AssessmentSeries, float]:
    """Simulate and replay one mission as a campaign run does; (series, modelled white share)."""
    tmp.mkdir()
    run_path, truth_path, _ = crun._simulate(inputs, seed, tmp)
    data = read_data_dir(crun._write_data(tmp / "run_data", inputs.run_data))
    cfg_data = merge_overrides(tomllib.loads(inputs.config_text), over)
    cfg_data["run_file"] = str(run_path)
    cfg_data["data_dir"] = str(tmp / "run_data")
    cfg = config_from_data(cfg_data, tmp, data[0].datums, data[1])
    if cfg.lsq.lop_reject == "A":
        cfg = cfg.replace(lsq=dataclasses.replace(cfg.lsq, lop_reject="N"))
    out_path = tmp / "run.OUT"
    with Session(cfg, out_path=out_path, force=True, history=1, data=data) as session:
        session.run()
    params = filter_params_from_config(cfg)
    white = 1.0 - params.fix_sigma_frac if params.coloured else 1.0
    return assess(read_nav_log(out_path), read_truth(truth_path)).series, white


def _drawn(text: str) -> dict[str, Any]:
    def num(section: str, key: str) -> float:
        body = text.split(f"[{section}]", 1)[1].split("\n[", 1)[0]
        m = re.search(rf"^{key} = (\S+)$", body, flags=re.M)
        return float(m.group(1)) if m else float("nan")

    def on(section: str) -> bool:
        return re.search(r"^on = true$", text.split(f"[{section}]", 1)[1].split("\n[", 1)[0],
                         flags=re.M) is not None

    gps, decca = on("gps"), on("decca")
    return {"system": "gps+decca" if gps and decca else "gps" if gps else "decca",
            "gps_sigma": num("gps", "sigma_m"), "gps_tau": num("gps", "tau_s"),
            "gps_white": num("gps", "white_sigma_m"), "decca_tau": num("decca", "tau_s")}


def oracle(text: str) -> dict[str, Any]:
    """The ``[filter]`` overrides of ``--oracle`` for a drawn scenario text (module docstring)."""
    d = _drawn(text)
    if d["system"] == "decca":
        return {"fix_tau_s": d["decca_tau"]}
    if d["system"] == "gps+decca":
        return {"fix_tau_s": max(d["gps_tau"], d["decca_tau"])}
    body = text.split("[gps]", 1)[1].split("\n[", 1)[0]
    m = re.search(r"^white_frac = (\S+)$", body, flags=re.M)
    white = (float(m.group(1)) if m else
             d["gps_white"] ** 2 / (d["gps_sigma"] ** 2 + d["gps_white"] ** 2))
    return {"fix_tau_s": d["gps_tau"], "fix_sigma_frac": min(0.99, 1.0 - white)}


def mission(inputs: ScenarioInputs, seed: int, over: dict[str, Any],
            use_oracle: bool = False) -> dict[str, Any] | None:
    """The figures of one seed (module docstring); None without a surfaced epoch with an LSE."""
    with tempfile.TemporaryDirectory(prefix="uvnav-mpp-") as name:
        tmp = Path(name)
        inputs = crun._drawn(inputs, seed, tmp)
        if use_oracle:
            over = merge_overrides(over, {"filter": oracle(inputs.scenario_text)})
        s, white_model = _replay(inputs, seed, over, tmp / "run")
        text = re.sub(r"^white_sigma_m = .*$", "white_sigma_m = 0.0", inputs.scenario_text,
                      flags=re.M)
        text = re.sub(r"^white_frac = .*$", "white_frac = 0.0", text, flags=re.M)
        twin, _ = _replay(dataclasses.replace(inputs, scenario_text=text), seed, over,
                          tmp / "twin")
    if not np.array_equal(s.t_ms, twin.t_ms):
        raise RuntimeError(f"seed {seed}: the twin run has other epochs")
    row = split_mse(s.t_ms / 1000.0, s.phase, s.error["mpp"], s.error["lse"], twin.error["lse"])
    if row is None:
        return None
    return {"seed": seed, **_drawn(inputs.scenario_text), **row, "white_model": white_model}


def split_mse(t_s: np.ndarray, phase: np.ndarray, mpp: np.ndarray, lse: np.ndarray,
              colour: np.ndarray) -> dict[str, Any] | None:
    """The figures of one mission from its series: time (s), phase index (0 surfaced, 1
    submerged, 2 after resurfacing), the (n, 2) grid errors (m) of the MPP, the LSE and the
    LSE's coloured part (NaN where absent). Over the surfaced epochs with all three: ``n``, the
    RMS errors ``mpp``, ``lse``, ``colour`` (m), ``white_share`` (mean |LSE − colour|² / mean
    |LSE|²) and ``parts``: MSE_MPP − MSE_LSE (m²) split over :data:`WINDOWS` (they add up to
    it). A stretch starts at the first such epoch after any other epoch. None without any."""
    m2 = np.sum(mpp ** 2, axis=1)
    l2 = np.sum(lse ** 2, axis=1)
    c2 = np.sum(colour ** 2, axis=1)
    w2 = np.sum((lse - colour) ** 2, axis=1)
    both = np.isfinite(m2) & np.isfinite(l2) & np.isfinite(c2) & ((phase == 0) | (phase == 2))
    if not both.any():
        return None
    idx = np.flatnonzero(both)
    t = t_s[idx]
    start = np.r_[True, np.diff(idx) > 1]
    into = t - np.maximum.accumulate(np.where(start, t, -np.inf))
    after = phase[idx] == 2
    parts = {
        WINDOWS[0]: ~after & (into < 60.0), WINDOWS[1]: ~after & (into >= 60.0) & (into < 300.0),
        WINDOWS[2]: after & (into < 60.0), WINDOWS[3]: after & (into >= 60.0) & (into < 300.0),
        WINDOWS[4]: into >= 300.0}
    n = idx.size
    d = m2[idx] - l2[idx]
    return {"n": n, "mpp": float(np.sqrt(m2[idx].mean())), "lse": float(np.sqrt(l2[idx].mean())),
            "colour": float(np.sqrt(c2[idx].mean())),
            "white_share": float(w2[idx].mean() / l2[idx].mean()),
            "parts": {k: float(d[v].sum() / n) for k, v in parts.items()}}


def report(rows: list[dict[str, Any]]) -> list[str]:
    """The per-mission lines (worst ratio last) and the summaries."""
    out = ["seed system     GPS σ   τ  white  Decca τ    N    MPP    LSE colour ratio "
           "white drawn/model | MSE_MPP − MSE_LSE (m²): " + " | ".join(WINDOWS)]
    for r in sorted(rows, key=lambda r: r["mpp"] / r["lse"]):
        p = r["parts"]
        out.append(f"{r['seed']:4d} {r['system']:9s} {r['gps_sigma']:6.1f} {r['gps_tau']:4.0f} "
                   f"{r['gps_white']:5.1f} {r['decca_tau']:7.0f} {r['n']:5d} {r['mpp']:6.1f} "
                   f"{r['lse']:6.1f} {r['colour']:6.1f} {r['mpp'] / r['lse']:5.3f} "
                   f"{100 * r['white_share']:5.1f}/{100 * r['white_model']:.1f} % | "
                   + " ".join(f"{p[k]:8.1f}" for k in WINDOWS))
    ratio = np.array([r["mpp"] / r["lse"] for r in rows])
    out.append(f"\n{len(rows)} missions: MPP RMS ≤ LSE RMS on {100 * np.mean(ratio <= 1):.1f} %, "
               f"median ratio {np.median(ratio):.3f}")
    out.append("\n| missions | n | MPP ≤ LSE | median ratio |\n|---|---|---|---|")
    groups: list[tuple[str, np.ndarray]] = [
        (f"{name}", np.array([r["system"] == name for r in rows]))
        for name in ("gps", "decca", "gps+decca")]
    tau = np.array([r["decca_tau"] if r["system"] == "decca" else r["gps_tau"] for r in rows])
    for lo, hi in ((0, 200), (200, 400), (400, 700), (700, 2000)):
        for name in ("gps+decca", "decca"):
            k = (tau >= lo) & (tau < hi) & np.array([r["system"] == name for r in rows])
            groups.append((f"{name}, drawn τ {lo}–{hi} s (GPS τ; Decca τ alone)", k))
    for name, k in groups:
        if k.any():
            out.append(f"| {name} | {k.sum()} | {100 * np.mean(ratio[k] <= 1):.0f} % | "
                       f"{np.median(ratio[k]):.3f} |")
    lost = [r for r in rows if r["mpp"] > r["lse"]]
    if lost:
        tot = {k: sum(r["parts"][k] for r in lost) for k in WINDOWS}
        out.append("\nmissions lost: MSE_MPP − MSE_LSE summed over them (m²): "
                   + ", ".join(f"{k} {v:.0f}" for k, v in tot.items()))
    return out


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tests.mpp_diagnose", description=__doc__)
    ap.add_argument("--spec", default=str(ROOT / "data/campaigns/random_60.toml"))
    ap.add_argument("--seeds", default=None, help="e.g. 1-60 or 1,5,9 (default: the spec's)")
    ap.add_argument("--set", action="append", default=[], metavar="TABLE.KEY=VALUE")
    ap.add_argument("--oracle", action="store_true",
                    help="give the filter each mission's drawn fix-error τ (a diagnosis only)")
    args = ap.parse_args(argv)
    spec = load_campaign(args.spec)
    bundle = spec.bundle()
    tasks = {t.seed: t for t in spec.tasks}
    seeds = _parse_seeds(args.seeds) if args.seeds else sorted(tasks)
    over = _parse_set(args.set)
    rows = []
    for seed in seeds:
        task = tasks[seed]
        row = mission(bundle.scenarios[task.scenario], seed, over, args.oracle)
        if row is not None:
            rows.append(row)
            print(f"seed {seed}: MPP {row['mpp']:.1f} m, LSE {row['lse']:.1f} m", file=sys.stderr,
                  flush=True)
    print("\n".join(report(rows)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

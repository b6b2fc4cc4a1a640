"""One campaign run: simulate → replay → assess, returned as one row (a flat dict).

:func:`run_one` is what a worker executes. It writes the simulated ``.RUN`` and truth CSV and
the replay's ``.OUT`` to a scratch directory (or the ``.OUT`` to ``tracks_dir``), replays with
:class:`engine.run.session.Session` exactly as ``uvnav replay`` does (an LOPReject "A" becomes
"N": there is no operator), scores the ``.OUT`` against the truth with
:func:`engine.assess.accuracy.assess` exactly as ``uvnav assess`` does, and adds the lane and
filter counts of the mission checks (docs/ASSESS.md, "Missions nobody tuned to"). Only the row
leaves the worker, never a track. Any exception is a ``failed`` row with its message; the
message never names the scratch directory, so a row does not depend on where it ran.

Columns (:data:`COLUMNS`, docs/CAMPAIGN.md): identity ``key, scenario, variant, seed``,
``status`` (``ok``/``failed``), ``error``, ``epochs``; per phase (``surfaced``, ``submerged``,
``after`` = after resurfacing, ``all``) ``{phase}_epochs`` and for the MPP and the LSE
``{phase}_{est}_rms_m``, ``_p95_m``, ``_max_m`` (horizontal error, m), ``_cover95`` (fraction of
epochs with the truth in the 95 % ellipse) and ``_nees`` (mean eᵀC⁻¹e, expected 2); the MPP's RMS
error by time since the last LSE (``mpp_rms_m_since_fix_A_Bmin``); counts ``fixes``,
``fix_updates``, ``lom_rejected``, ``gated``, ``recovered``,
``wrong_lane_{surfaced,submerged,after}``, ``lane_out``, ``bad_records``; the share of epochs
whose MPP error exceeds twice the filter's 95 %
semi-major axis (``{phase}_mpp_beyond2a``); the MPP and LSE RMS over the surfaced epochs with an
independent LSE (``fixes_mpp_rms_m``, ``fixes_lse_rms_m``); timing ``wall_s``, ``cpu_s`` (the
only columns that depend on the machine).
"""

from __future__ import annotations

import dataclasses
import math
import os
import tempfile
import time
import tomllib
from array import array
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from engine.assess.accuracy import Assessment, assess, read_nav_log, read_truth
from engine.campaign.spec import CampaignBundle, RunTask, ScenarioInputs, merge_overrides
from engine.run.config import config_from_data
from engine.run.cycle import CycleResult
from engine.run.session import Session, read_data_dir
from engine.sim.sampler import draw_mission
from engine.sim.scenario import parse_scenario_text
from engine.sim.simulate import format_truth_row, simulate, simulation_setup, truth_header
from engine.systems.decca import decca_geometry

__all__ = ["COLUMNS", "PHASES", "SINCE_FIX_BINS_MIN", "TIMING_COLUMNS", "blank_row", "run_one"]

PHASES: tuple[str, ...] = ("surfaced", "submerged", "after", "all")
"""Phase names of the columns (``after`` = the assessment's ``after resurfacing``)."""
_ASSESS_PHASE = {"surfaced": "surfaced", "submerged": "submerged",
                 "after": "after resurfacing", "all": "all"}
ESTIMATES = ("mpp", "lse")
STATS = (("rms_m", "rms_m"), ("p95_m", "p95_m"), ("max_m", "max_m"),
         ("cover95", "coverage"), ("nees", "nees"))
"""(column suffix, :class:`engine.assess.accuracy.ErrorStats` attribute)."""
SINCE_FIX_BINS_MIN: tuple[tuple[float, float], ...] = (
    (0.0, 1.0), (1.0, 5.0), (5.0, 15.0), (15.0, 30.0), (30.0, 60.0), (60.0, 120.0),
    (120.0, math.inf))
"""Bins (minutes, [lo, hi)) of the time since the last LSE for the error-growth columns."""
LANE_PHASES = ("surfaced", "submerged", "after")


def since_fix_column(lo: float, hi: float) -> str:
    """Column name of one time-since-fix bin, e.g. ``mpp_rms_m_since_fix_5_15min``."""
    return (f"mpp_rms_m_since_fix_{lo:g}_{hi:g}min" if math.isfinite(hi)
            else f"mpp_rms_m_since_fix_{lo:g}min_up")


def _columns() -> tuple[tuple[str, str], ...]:
    cols = [("key", "str"), ("scenario", "str"), ("variant", "str"), ("seed", "int"),
            ("status", "str"), ("error", "str"), ("epochs", "int")]
    for ph in PHASES:
        cols.append((f"{ph}_epochs", "int"))
        cols += [(f"{ph}_{est}_{suffix}", "float") for est in ESTIMATES for suffix, _ in STATS]
    cols += [(f"{ph}_mpp_beyond2a", "float") for ph in PHASES]
    cols += [("fixes_mpp_rms_m", "float"), ("fixes_lse_rms_m", "float")]
    cols += [(since_fix_column(lo, hi), "float") for lo, hi in SINCE_FIX_BINS_MIN]
    cols += [(n, "int") for n in ("fixes", "fix_updates", "lom_rejected", "gated",
                                        "recovered")]
    cols += [(f"wrong_lane_{ph}", "int") for ph in LANE_PHASES]
    cols += [("lane_out", "int"), ("bad_records", "int"), ("wall_s", "float"),
             ("cpu_s", "float")]
    return tuple(cols)


COLUMNS: tuple[tuple[str, str], ...] = _columns()
"""Every column of the table in order, with its kind (``str``, ``int``, ``float``)."""
TIMING_COLUMNS: tuple[str, ...] = ("wall_s", "cpu_s")
"""The columns that depend on the machine and the load (everything else is reproducible)."""
_BLANK = {"str": "", "int": 0, "float": math.nan}


def blank_row(task: RunTask) -> dict[str, Any]:
    """A row with the task's identity, status ``failed`` and every figure empty (NaN / 0)."""
    row = {name: _BLANK[kind] for name, kind in COLUMNS}
    row.update(key=task.key, scenario=task.scenario, variant=task.variant, seed=task.seed,
               status="failed")
    return row


@dataclasses.dataclass
class _Truth:
    """The truth in memory for the lane checks: per epoch time, working-datum lat/lon (deg),
    surfaced, and which Decca patterns were received."""

    time: list[Any] = dataclasses.field(default_factory=list)
    lat: array = dataclasses.field(default_factory=lambda: array("d"))
    lon: array = dataclasses.field(default_factory=lambda: array("d"))
    surfaced: bytearray = dataclasses.field(default_factory=bytearray)
    decca: list[tuple[bool, bool, bool]] = dataclasses.field(default_factory=list)


def _write_data(directory: Path, files: tuple[tuple[str, bytes], ...]) -> Path:
    directory.mkdir()
    for name, content in files:
        (directory / name).write_bytes(content)
    return directory


def _simulate(inputs: ScenarioInputs, seed: int, tmp: Path) -> tuple[Path, Path, _Truth]:
    """Simulate ``seed``: write the ``.RUN`` and the truth CSV; keep what the lane checks need."""
    data = read_data_dir(_write_data(tmp / "sim_data", inputs.sim_data))
    name = Path(inputs.scenario_file).name
    scenario = parse_scenario_text(inputs.scenario_text, name, tmp, known_datums=data[0].datums,
                                   known_chains=data[1])
    setup = simulation_setup(scenario, *data)
    run_path = tmp / f"{inputs.label}.RUN"
    truth_path = tmp / f"{inputs.label}.truth.csv"
    truth = _Truth()
    with open(run_path, "w", encoding="ascii", newline="\n") as run_fh, \
            open(truth_path, "w", encoding="utf-8", newline="\n") as truth_fh:
        truth_fh.write("\n".join(truth_header(scenario, setup, seed)) + "\n")
        for t, rec in simulate(scenario, *data, seed):
            run_fh.write(rec.raw + "\n")
            truth_fh.write(format_truth_row(t) + "\n")
            truth.time.append(t.time)
            truth.lat.append(t.lat_deg)
            truth.lon.append(t.lon_deg)
            truth.surfaced.append(bool(t.surfaced))
            truth.decca.append(tuple(f is not None for f in rec.decca))  # type: ignore[arg-type]
    return run_path, truth_path, truth


class _Checks:
    """The mission checks of each cycle against the truth (docs/ASSESS.md): fix updates and
    innovation-test rejections, fixes kept out by the gross-error gate, and Decca total lane
    counts used that are off the lane model at the true position by more than half a lane."""

    def __init__(self, session: Session, truth: _Truth) -> None:
        self.session = session
        self.truth = truth
        self.i = 0
        self.dived = False
        self.fix_updates = self.lom_rejected = self.gated = self.lane_out = 0
        self.recovered = 0
        self.wrong = dict.fromkeys(LANE_PHASES, 0)

    def __call__(self, r: CycleResult) -> None:
        i, tr = self.i, self.truth
        self.i += 1
        if i >= len(tr.time) or r.time != tr.time[i]:
            raise RuntimeError(f"cycle {r.n} at {r.time} does not match the truth's epoch {i}")
        surfaced = bool(tr.surfaced[i])
        self.dived |= not surfaced
        phase = "submerged" if not surfaced else ("after" if self.dived else "surfaced")
        fix = r.fix
        if any(m.startswith("Fix ") and "gross error" in m for m in r.messages):
            self.gated += 1
        self.recovered += r.fix_gate == "recovered"
        u = r.filter_update
        if u is not None and fix is not None and fix.ok:
            self.fix_updates += 1
            self.lom_rejected += u.lom.verdict == "reject"
        cfg = self.session.config
        if not (cfg.decca.on and any(tr.decca[i])):
            return
        ctx = self.session.context
        placed = ctx.placed_chain(r.cm_deg)
        if placed is None:
            return
        tx, ty = ctx.grid(r.cm_deg).forward(tr.lat[i], tr.lon[i])
        observed = (None, None, None) if fix is None else fix.decca_observed
        geom = None
        for k, pattern in enumerate(("red", "green", "purple")):
            if pattern not in cfg.decca.select or not tr.decca[i][k]:
                continue
            if observed[k] is None:
                self.lane_out += 1
                continue
            if geom is None:
                geom = decca_geometry(placed, tx, ty, ctx.geodesic)
            if abs(float(observed[k]) - float(geom.n_calc[k])) > 0.5:  # type: ignore[arg-type]
                self.wrong[phase] += 1
                break


def _replay(inputs: ScenarioInputs, overrides: Mapping[str, Any], run_path: Path,
            out_path: Path, tmp: Path, truth: _Truth) -> tuple[Session, _Checks]:
    """Replay the ``.RUN`` with the scenario's configuration and the overrides."""
    data = read_data_dir(_write_data(tmp / "run_data", inputs.run_data))
    cfg_data = merge_overrides(tomllib.loads(inputs.config_text), overrides)
    cfg_data["run_file"] = str(run_path)
    cfg_data["data_dir"] = str(tmp / "run_data")
    cfg = config_from_data(cfg_data, tmp, data[0].datums, data[1])
    if cfg.lsq.lop_reject == "A":  # no operator to ask: keep the LOP, flagged (uvnav replay)
        cfg = cfg.replace(lsq=dataclasses.replace(cfg.lsq, lop_reject="N"))
    session = Session(cfg, out_path=out_path, force=True, history=1, data=data)
    checks = _Checks(session, truth)
    with session:
        session.run(progress=checks)
    return session, checks


def _since_fix(a: Assessment) -> dict[str, float]:
    """The MPP's RMS error (m) by time since the last LSE, per bin (NaN for an empty bin)."""
    s = a.series
    t = s.t_ms.astype(float) / 60_000.0
    has_fix = np.all(np.isfinite(s.error["lse"]), axis=1)
    idx = np.where(has_fix, np.arange(t.size), -1)
    last = np.maximum.accumulate(idx) if idx.size else idx
    since = np.where(last >= 0, t - t[np.maximum(last, 0)], np.nan)
    err = np.hypot(s.error["mpp"][:, 0], s.error["mpp"][:, 1])
    out = {}
    for lo, hi in SINCE_FIX_BINS_MIN:
        m = (since >= lo) & (since < hi) & np.isfinite(err)
        out[since_fix_column(lo, hi)] = (float(np.sqrt(np.mean(err[m] ** 2))) if m.any()
                                         else math.nan)
    return out


def _beyond(a: Assessment) -> dict[str, float]:
    """Per phase, the share of epochs whose MPP error exceeds twice the filter's 95 %
    semi-major axis (epochs with both; NaN without any), and the MPP and LSE RMS errors (m)
    over the surfaced epochs (either surfaced phase) that have an independent LSE."""
    s = a.series
    err = np.hypot(s.error["mpp"][:, 0], s.error["mpp"][:, 1])
    ok = np.isfinite(err) & np.isfinite(s.kf_a95_m)
    over = ok & (err > 2.0 * np.where(ok, s.kf_a95_m, 0.0))
    out: dict[str, float] = {}
    for i, ph in enumerate(PHASES):
        m = ok if ph == "all" else ok & (s.phase == i)
        out[f"{ph}_mpp_beyond2a"] = float(over[m].sum() / m.sum()) if m.any() else math.nan
    lse = np.hypot(s.error["lse"][:, 0], s.error["lse"][:, 1])
    both = np.isfinite(err) & np.isfinite(lse) & ((s.phase == 0) | (s.phase == 2))
    out["fixes_mpp_rms_m"] = float(np.sqrt(np.mean(err[both] ** 2))) if both.any() else math.nan
    out["fixes_lse_rms_m"] = float(np.sqrt(np.mean(lse[both] ** 2))) if both.any() else math.nan
    return out


def _figures(a: Assessment, session: Session, checks: _Checks) -> dict[str, Any]:
    row: dict[str, Any] = {}
    spans = {p.name: p.n for p in a.phases}
    for ph in PHASES:
        name = _ASSESS_PHASE[ph]
        row[f"{ph}_epochs"] = int(spans.get(name, 0))
        for est in ESTIMATES:
            st = a.stat(name, est)
            for suffix, attr in STATS:
                row[f"{ph}_{est}_{suffix}"] = float(getattr(st, attr))
    row.update(_since_fix(a))
    row.update(_beyond(a))
    summary = session.summary()
    row.update(epochs=int(a.n_matched), fixes=int(summary.fixes),
               fix_updates=checks.fix_updates, lom_rejected=checks.lom_rejected,
               gated=checks.gated, recovered=checks.recovered, lane_out=checks.lane_out,
               bad_records=int(summary.skipped_records))
    row.update({f"wrong_lane_{ph}": n for ph, n in checks.wrong.items()})
    return row


def _drawn(inputs: ScenarioInputs, seed: int, tmp: Path) -> ScenarioInputs:
    """The sampler's mission for ``seed`` in place of the spec's placeholder texts (a draw the
    engine refuses raises :class:`engine.sim.sampler.SamplerError`: a failed row)."""
    data = read_data_dir(_write_data(tmp / "draw_data", inputs.sim_data))
    mission = draw_mission(seed, data[0], data[1], inputs.sampler)
    return dataclasses.replace(inputs, scenario_text=mission.scenario_text,
                               config_text=mission.config_text)


def _message(exc: BaseException, tmp: str) -> str:
    text = str(exc) or type(exc).__name__
    if not isinstance(exc, ValueError | OSError | RuntimeError):
        text = f"{type(exc).__name__}: {text}"
    return text.replace(tmp + os.sep, "").replace(tmp, "")


def run_one(bundle: CampaignBundle, task: RunTask, tracks_dir: str | None = None
            ) -> dict[str, Any]:
    """Do one run and return its row (:data:`COLUMNS`); never raises for a failed run (the
    row says ``failed`` and why). ``tracks_dir``: keep the run's ``.OUT`` there as
    ``KEY.OUT`` (else it lives in the scratch directory and is removed)."""
    wall0, cpu0 = time.perf_counter(), time.thread_time()
    row = blank_row(task)
    with tempfile.TemporaryDirectory(prefix="uvnav-campaign-") as tmp_name:
        tmp = Path(tmp_name)
        try:
            inputs = bundle.scenarios[task.scenario]
            if inputs.sampler is not None:
                inputs = _drawn(inputs, task.seed, tmp)
            variant = bundle.variants[task.variant]
            run_path, truth_path, truth = _simulate(inputs, task.seed, tmp)
            out_path = (Path(tracks_dir) / f"{task.key}.OUT" if tracks_dir is not None
                        else tmp / f"{inputs.label}.OUT")
            session, checks = _replay(inputs, variant.overrides, run_path, out_path, tmp, truth)
            a = assess(read_nav_log(out_path), read_truth(truth_path))
            row.update(_figures(a, session, checks))
            row["status"] = "ok"
        except Exception as exc:  # a failed run is a row, and the campaign goes on
            row["error"] = _message(exc, tmp_name)
    row["wall_s"] = time.perf_counter() - wall0
    row["cpu_s"] = time.thread_time() - cpu0
    return row

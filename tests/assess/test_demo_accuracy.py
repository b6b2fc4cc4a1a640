"""End to end on the bundled demo: the filter beats the raw LSE, the smoother beats the filter,
and the whole 2-h mission replays with an honest MPP ellipse and a fix-less dive.

data/DEMO.RUN (surfaced with GPS + Decca and SA-era correlated GPS errors, a dive with dead
reckoning only, resurfacing) against data/DEMO.truth.csv. The numbers are deterministic (fixed
data); the assertions are the claims the program and issue 4 make, not fitted values. The errors
are computed here directly from the cycle results (each cycle's grid, its own covariance), not
through engine.assess.accuracy, so the two are independent checks of each other (docs/ASSESS.md
shows
the same figures from `uvnav assess`).
"""

from __future__ import annotations

import csv
import math

import numpy as np

from engine.run.config import load_config
from engine.run.session import Session
from tests.paths import DATA

N = 1800
K95_SQ = -2.0 * math.log(0.05)  # 2-D 95 % ellipse: eᵀC⁻¹e ≤ 5.991
SENSOR_ROWS = {"z_p", "v_m", "psi_m", "eps_m"}  # filter rows of the bounded sensors (no fix)


def _truth() -> dict[str, tuple[float, float, bool]]:
    """time → (lat, lon on ED50, surfaced)."""
    with open(DATA / "DEMO.truth.csv", encoding="utf-8") as fh:
        rows = csv.DictReader(line for line in fh if not line.startswith("#"))
        return {r["time"]: (float(r["lat"]), float(r["lon"]), r["surfaced"] == "1")
                for r in rows}


def _rms(a: list[float]) -> float:
    return float(np.sqrt(np.mean(np.square(a))))


def test_filter_and_smoother_beat_the_lse_on_the_demo() -> None:
    """The first 30 min (surfaced)."""
    truth = _truth()
    s = Session(load_config(DATA / "DEMO.toml"), collect_smoother=True, history=N)
    results = [s.step() for _ in range(N)]
    smoothed = s.smooth()
    assert len(smoothed) == N  # the whole run is smoothed, across the CM change too
    grid_end = s.context.grid(s.nav.cm_deg)
    e_mpp, e_lse, e_smo = [], [], []
    for r, p in zip(results, smoothed, strict=True):
        lat, lon, _surfaced = truth[r.time.strftime("%Y-%m-%dT%H:%M:%SZ")]
        tx, ty = s.context.grid(r.cm_deg).forward(lat, lon)
        e_mpp.append(math.hypot(r.mpp.x_m - tx, r.mpp.y_m - ty))
        if r.fix is not None and r.fix.ok:
            e_lse.append(math.hypot(r.fix.x_m - tx, r.fix.y_m - ty))
        sx, sy = grid_end.forward(lat, lon)  # smoothed states are on the final CM
        e_smo.append(math.hypot(p.x_m - sx, p.y_m - sy))

    # Measured: LSE 27.3 m, filtered MPP 19.2 m, smoothed 10.6 m.
    assert len(e_lse) == N
    assert _rms(e_mpp) < 0.85 * _rms(e_lse)
    assert _rms(e_smo) < 0.75 * _rms(e_mpp)


def test_whole_demo_replays_with_an_honest_mpp_and_a_dead_reckoning_dive() -> None:
    """All 7200 records through engine.run.session (~8 s), against the truth (issue 4):

    * surfaced before the dive, and over every epoch with a fix, the MPP RMS error is below the
      LSE's (after resurfacing alone it is not on this seed: see below);
    * over the whole run the truth lies inside the MPP's 95 % ellipse in 92–98.5 % of the
      epochs (the all-epoch coverage target of docs/ASSESS.md, "Randomized missions";
      eᵀC⁻¹e ≤ 5.991 with the cycle's own 2×2 covariance);
    * the fix-less phase is dead reckoning only: no GPS, no Decca, no LSE, and a filter that
      sees only its bounded-sensor rows (pressure depth etc.). It lasts 48.3 min (10:45:00 to
      11:33:17), not the 45 min of the submerged legs: the climb back to the fix depth
      (0.5 m, 198 s at 0.25 m/s) is fix-less too.

    Measured with the DEMO.toml of this commit (`uvnav replay` + `uvnav assess`,
    docs/ASSESS.md): MPP RMS 22.3 m against the LSE's 28.7 m surfaced, 29.2 against 29.0 m
    after resurfacing; coverage 93.5 % (92.7 % since the current's random walk is the tide over an
    hour, THEORY §8.9). This is one realisation (seed 1993, the lowest LSE
    coverage of 20 seeds): with errors correlated over 3–4 min a phase holds only ~10
    independent samples, so per-phase claims belong to the multi-seed test
    (tests/assess/test_demo_seeds.py); here only the targets are asserted, not these values.
    """
    truth = _truth()
    s = Session(load_config(DATA / "DEMO.toml"), history=1)
    phase_names = ("surfaced", "submerged", "after resurfacing")
    err: dict[str, dict[str, list[float]]] = {p: {"mpp": [], "lse": []} for p in phase_names}
    inside: list[bool] = []
    submerged_times = []
    dived = False
    n = 0
    while (r := s.step()) is not None:
        n += 1
        stamp = r.time.strftime("%Y-%m-%dT%H:%M:%SZ")
        lat, lon, surfaced = truth[stamp]
        dived |= not surfaced
        phase = "submerged" if not surfaced else ("after resurfacing" if dived else "surfaced")
        tx, ty = s.context.grid(r.cm_deg).forward(lat, lon)
        e = np.array([r.mpp.x_m - tx, r.mpp.y_m - ty])
        assert np.all(np.isfinite(r.mpp.cov)), stamp
        inside.append(float(e @ np.linalg.solve(r.mpp.cov, e)) <= K95_SQ)
        err[phase]["mpp"].append(math.hypot(*e))
        if r.fix is not None and r.fix.ok and not r.fix.uses_prior:
            err[phase]["lse"].append(math.hypot(r.fix.x_m - tx, r.fix.y_m - ty))
        if phase == "submerged":
            submerged_times.append(r.time)
            assert r.gps is None and r.decca_fractions == (None, None, None), stamp
            assert r.fix is None, stamp
            labels = set(r.filter_update.labels) if r.filter_update is not None else set()
            assert labels <= SENSOR_ROWS, (stamp, labels)
            assert r.mpp.source in ("KF", "DR"), stamp
    assert n == 7200 and not s.bad_records
    # 2898 fix-less epochs = 48.3 min (dive at 10:45:00Z, GPS and Decca back at 11:33:18Z).
    assert len(submerged_times) == 2898
    assert (submerged_times[0].strftime("%H:%M:%S"), submerged_times[-1].strftime("%H:%M:%S")) \
        == ("10:45:00", "11:33:17")
    for phase in ("surfaced", "after resurfacing"):
        assert len(err[phase]["lse"]) == len(err[phase]["mpp"]) > 1500  # an LSE every epoch
    assert _rms(err["surfaced"]["mpp"]) < _rms(err["surfaced"]["lse"])
    fixed = {k: err["surfaced"][k] + err["after resurfacing"][k] for k in ("mpp", "lse")}
    assert _rms(fixed["mpp"]) < _rms(fixed["lse"])
    coverage = float(np.mean(inside))
    assert 0.92 <= coverage <= 0.985, coverage

"""The demo's filter over independent realisations: issue 7's targets, with seeds as the unit.

One realisation (data/DEMO.RUN, seed 1993) cannot support per-phase claims: the GPS error is
Gauss–Markov with τ = 240 s and the Decca sky-wave error τ = 180 s, so a 45-min phase holds
about T/(2τ) ≈ 6 independent samples, and a dive holds one (its dead-reckoning error is one
slowly growing draw). Here K = 10 seeds of the demo scenario are simulated in memory
(:func:`engine.sim.simulate.simulate`), written to a ``.RUN`` in a temporary directory, replayed
through :class:`engine.run.session.Session` with data/DEMO.toml's settings (nothing changed but the
``run_file``), and scored against the simulator's own truth rows: each cycle's MPP (and LSE,
``CycleResult.fix``) against the true position projected on that cycle's grid, with the MPP's own
2×2 covariance (not through engine.assess.accuracy, as in tests/assess/test_demo_accuracy.py).

**The mission** is data/DEMO.scenario.toml with every leg halved (1 h instead of 2 h, so ten
seeds replay in about 30 s on one core): 22.5 min surfaced with all four course changes, the
dive to 50 m and its three legs (fix-less 25.8 min, the 198-s climb included), 11.7 min of
fixes after resurfacing. Same error models, same filter settings.

**Tolerances.** The seeds are the independent unit: for a per-seed figure with mean m and
standard deviation s over K seeds, the two-sided 95 % Student interval of the mean is
m ± t₀.₉₇₅(K − 1)·s/√K (t = 2.262 for K = 10). A target is *consistent* with the runs when it
lies in (or, for the band 93–97 %, overlaps) that interval; each such assertion holds with
probability 0.95 when the target is true. The interval is computed from the runs themselves,
so it narrows as the filter's seed-to-seed spread does. Measured per-seed spreads (150 seeds
of this mission, first settings below): all-epoch coverage s = 15 % (±10.7 % at K = 10: the
dive is nearly all-in or all-out per seed), surfaced 9.7 %, after resurfacing 13.6 %, dive
30 %; all-epoch NEES s = 1.3. Per phase, the coverage is asserted for the two phases with
fixes (several independent samples per seed); the dive's (one sample per seed, half-width
±21 %) is only reported.

**What the runs say (not asserted).** With the first DEMO.toml filter settings (fix_sigma_frac
0.9, gyro-bias random walk 0.7 °/√h), 150 seeds gave mean coverage 89.5 % (standard error
1.2 %: below the issue's 93 %) and NEES 2.55 ± 0.11, mostly from overconfident dives. Those
settings did not match the simulated errors: the fix error is 99 % Gauss–Markov (GPS 35 m
against 3 m white), and a Gauss–Markov gyro error (0.5°, τ 20 min) grows like a random walk of
√(2σ²/τ) = 1.22 °/√h. With those values (fix_sigma_frac 0.99, 1.2 °/√h), 100 seeds of this
mission give coverage 93.3 ± 1.1 % over all epochs (surfaced 93.7 %, dive 91.7 %, after
resurfacing 96.4 %), NEES 2.21 ± 0.11, and the MPP beats the LSE on 80 % of the seeds surfaced
(by 2.7 m on average) and 82 % after resurfacing (by 5.0 m); 12 seeds of the full 2-h demo give
coverage 98.1 % and NEES 1.72 (the longer dive makes the random walk conservative). But 0.99
left no white part for the Decca lanes' 0.003-lane jitter (3–9 % of their variance), and the
filter's innovation test rejected 28.5 % of the fix updates (60 seeds) instead of α = 5 %. With
fix_sigma_frac 0.95 (the current DEMO.toml) seeds 1–60 give coverage 93.4 ± 1.3 % (surfaced
92.2, dive 93.0, after resurfacing 96.7), NEES 2.24 ± 0.14, 3.9 % of the updates rejected, and
the same RMS errors (MPP better than the LSE on 87 % / 78 % of the seeds, by 3.1 / 5.2 m); on
seeds 1–10 here: coverage 94.1 %, NEES 2.24. The assertions fail on a wrong model (measured
with the first settings): with
``model = "thesis"`` the coverage and NEES ones fail (coverage 5 %, NEES 103); with
``gps_se_sf = 0.1`` (coverage 52 %, NEES 7.9) too; with the gyro bias a random constant
(``bias_noise = false``) the dive coverage falls to 75 % and the NEES test fails (3.02 ± 0.82).
Rerun the per-seed table with ``pytest -s tests/assess/test_demo_seeds.py``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import t as student_t

from engine.io.datumfile import DatumFile
from engine.io.deccafile import DeccaChain
from engine.run.config import load_config
from engine.run.session import Session, read_data_dir
from engine.sim.scenario import Scenario, load_scenario
from engine.sim.simulate import simulate
from tests.paths import DATA

pytestmark = pytest.mark.slow  # ten seeds simulated and replayed: > 2 min under load

SEEDS = tuple(range(1, 11))
"""Fixed seeds: the figures are reproducible; the list was not chosen by looking at results."""

K95_SQ = -2.0 * math.log(0.05)  # 2-D 95 % ellipse: eᵀC⁻¹e ≤ 5.991
BAND = (0.93, 0.97)  # issue 7: the MPP's 95 % ellipse holds the truth in 93–97 % of epochs
PHASES = ("surfaced", "submerged", "after resurfacing")
FIX_PHASES = ("surfaced", "after resurfacing")


@dataclass(frozen=True)
class SeedFigures:
    """One replayed realisation, per phase (``PHASES`` plus ``"all"`` where noted).

    ``epochs`` and ``lse_epochs`` count epochs (with an independent LSE for the latter);
    ``coverage`` the fraction of epochs whose truth lies in the MPP's 95 % ellipse (with
    ``"all"``), ``nees`` the mean eᵀC⁻¹e of the MPP (with ``"all"``); ``rms_mpp``/``rms_lse``
    the RMS horizontal error in m (``rms_lse`` only for the phases with fixes).
    ``bad_records`` counts skipped ``.RUN`` records (none expected).
    """

    seed: int
    epochs: dict[str, int]
    lse_epochs: dict[str, int]
    coverage: dict[str, float]
    nees: dict[str, float]
    rms_mpp: dict[str, float]
    rms_lse: dict[str, float]
    bad_records: int


def _half_demo() -> Scenario:
    """data/DEMO.scenario.toml with every leg's duration halved (all multiples of 1 s)."""
    scenario = load_scenario(DATA / "DEMO.scenario.toml")
    legs = tuple(dataclasses.replace(leg, duration_s=leg.duration_s // 2)
                 for leg in scenario.legs)
    return dataclasses.replace(scenario, legs=legs)


def _rms(errors: list[float]) -> float:
    return float(np.sqrt(np.mean(np.square(errors))))


def _replay(
    scenario: Scenario,
    seed: int,
    data: tuple[DatumFile, dict[str, DeccaChain]],
    run_dir: Path,
) -> SeedFigures:
    """Simulate ``seed``, replay it with DEMO.toml's settings and score every cycle."""
    pairs = list(simulate(scenario, *data, seed))
    run_path = run_dir / f"SEED{seed}.RUN"
    run_path.write_text("".join(rec.raw + "\n" for _truth, rec in pairs), encoding="ascii")
    cfg = load_config(DATA / "DEMO.toml").replace(run_file=str(run_path))
    session = Session(cfg, history=1, data=data)
    err: dict[str, dict[str, list[float]]] = {p: {"mpp": [], "lse": []} for p in PHASES}
    quad: dict[str, list[float]] = {p: [] for p in PHASES}
    dived = False
    for truth, _rec in pairs:
        r = session.step()
        assert r is not None and r.time == truth.time, (seed, truth.time)
        dived |= not truth.surfaced
        phase = "submerged" if not truth.surfaced else (
            "after resurfacing" if dived else "surfaced")
        tx, ty = session.context.grid(r.cm_deg).forward(truth.lat_deg, truth.lon_deg)
        e = np.array([r.mpp.x_m - tx, r.mpp.y_m - ty])
        quad[phase].append(float(e @ np.linalg.solve(r.mpp.cov, e)))
        err[phase]["mpp"].append(math.hypot(*e))
        if r.fix is not None and r.fix.ok and not r.fix.uses_prior:
            err[phase]["lse"].append(math.hypot(r.fix.x_m - tx, r.fix.y_m - ty))
    assert session.step() is None
    every = [q for p in PHASES for q in quad[p]]
    coverage = {p: float(np.mean(np.array(quad[p]) <= K95_SQ)) for p in PHASES}
    coverage["all"] = float(np.mean(np.array(every) <= K95_SQ))
    nees = {p: float(np.mean(quad[p])) for p in PHASES}
    nees["all"] = float(np.mean(every))
    return SeedFigures(
        seed=seed,
        epochs={p: len(quad[p]) for p in PHASES},
        lse_epochs={p: len(err[p]["lse"]) for p in PHASES},
        coverage=coverage,
        nees=nees,
        rms_mpp={p: _rms(err[p]["mpp"]) for p in PHASES},
        rms_lse={p: _rms(err[p]["lse"]) for p in FIX_PHASES},
        bad_records=session.skipped_records,
    )


def _mean_ci(values: list[float]) -> tuple[float, float]:
    """Mean over seeds and the half-width of its two-sided 95 % Student interval."""
    a = np.asarray(values, dtype=float)
    k = a.size
    return float(a.mean()), float(student_t.ppf(0.975, k - 1) * a.std(ddof=1) / math.sqrt(k))


def _table(figs: list[SeedFigures]) -> str:
    """Per-seed and mean figures: MPP coverage (%) and NEES per phase and over all epochs, RMS
    error (m) of the MPP against the LSE in the phases with fixes, the MPP's in the dive; the
    last row is the half-width of the 95 % Student interval of the mean (:func:`_mean_ci`)."""
    keys = (*PHASES, "all")

    def numbers(f: SeedFigures) -> list[float]:
        return [*(100 * f.coverage[k] for k in keys), *(f.nees[k] for k in keys),
                f.rms_mpp["surfaced"], f.rms_lse["surfaced"], f.rms_mpp["after resurfacing"],
                f.rms_lse["after resurfacing"], f.rms_mpp["submerged"]]

    def line(label: str, v: list[float]) -> str:
        cov = " ".join(f"{x:6.1f}" for x in v[0:4])
        nees = " ".join(f"{x:5.2f}" for x in v[4:8])
        rms = f"{v[8]:5.1f} {v[9]:5.1f}   {v[10]:5.1f} {v[11]:5.1f}   {v[12]:5.1f}" \
            if len(v) > 8 else ""
        return f"{label:>4} | {cov} | {nees} | {rms}".rstrip()

    rows = [
        "     | coverage %: surf, dive, after, all | NEES: surf, dive, after, all"
        " | RMS m: surf MPP LSE, after MPP LSE, dive MPP",
    ]
    table = [numbers(f) for f in figs]
    rows += [line(str(f.seed), v) for f, v in zip(figs, table, strict=True)]
    rows.append(line("mean", [float(np.mean(col)) for col in zip(*table, strict=True)]))
    rows.append(line("±t", [_mean_ci(list(col))[1] for col in zip(*table, strict=True)][:8]))
    return "\n".join(rows)


@pytest.fixture(scope="module")
def figures(tmp_path_factory: pytest.TempPathFactory) -> list[SeedFigures]:
    """The K realisations, simulated and replayed once for the module (~3 s each)."""
    scenario = _half_demo()
    data = read_data_dir(DATA)
    run_dir = tmp_path_factory.mktemp("demo_seeds")
    figs = [_replay(scenario, seed, data, run_dir) for seed in SEEDS]
    print("\n" + _table(figs))  # shown with pytest -s, and under a failure's captured output
    return figs


def test_the_half_demo_keeps_its_three_phases(figures: list[SeedFigures]) -> None:
    """Every realisation has the surfaced phase, a fix-less dive long enough for dead reckoning
    to matter, and fixes again after resurfacing, with an LSE at every fix epoch.

    1350 s surfaced (10:00:00–10:22:29); fix-less 1548 s = 25.8 min (the 1350 s of dived legs
    plus the 198 s the 0.25 m/s climb from 50 m takes to reach fix_depth_max_m = 0.5 m; the
    MPP's RMS error over it is ~60 m against ~25 m with fixes); 702 s of fixes after it. The
    phases come from the mission, not the noise, so they are the same for every seed.
    """
    for f in figures:
        assert f.bad_records == 0, f.seed
        assert f.epochs == {"surfaced": 1350, "submerged": 1548, "after resurfacing": 702}
        assert f.lse_epochs == {"surfaced": 1350, "submerged": 0, "after resurfacing": 702}


def test_mpp_ellipse_coverage_is_consistent_with_the_93_to_97_percent_target(
    figures: list[SeedFigures],
) -> None:
    """The MPP's 95 % ellipse coverage over all epochs, averaged over the seeds, is consistent
    with issue 7's 93–97 %: the band overlaps the 95 % Student interval of the mean (module
    docstring). Per phase, the same for the two phases with fixes; the dive is reported only.

    A filter whose ellipse were ~2× too small in σ (coverage ~50 %) or ~2× too large (~100 %,
    spread ~0) fails; the thesis' white-noise model (coverage 5 % here) fails by far. The
    interval is wide (±8.6 % over all epochs on these seeds) because a seed's dive is nearly
    all-in or all-out: over 150 seeds the all-epoch mean is 89.5 %, below the band (module
    docstring), which ten seeds cannot show.
    """
    table = _table(figures)
    for key in ("all", *FIX_PHASES):
        m, h = _mean_ci([f.coverage[key] for f in figures])
        assert m + h >= BAND[0] and m - h <= BAND[1], (key, m, h, table)


def test_mpp_beats_the_lse_on_average_and_on_most_seeds(figures: list[SeedFigures]) -> None:
    """Surfaced and after resurfacing, the MPP's RMS error averaged over the seeds is below the
    LSE's, and it is below on a majority of the seeds.

    Why only this much: per seed the improvement LSE − MPP (RMS) is positive on ~80 % of seeds
    (150-seed reference: 2.9 ± 3.2 m surfaced, 5.8 ± 7.8 m after resurfacing, mean ± s), so the
    mean over ten seeds is positive with probability ≥ 0.99 and a majority (≥ 6 of 10) holds
    with ≥ 0.97 (random 10-seed draws from the reference); a one-sided 95 % lower bound above
    zero would hold for only 0.83 (surfaced) and 0.69 (after resurfacing, 11.7 min ≈ 1.5
    independent samples per seed) of the draws and is not asserted.
    """
    table = _table(figures)
    for phase in FIX_PHASES:
        gain = [f.rms_lse[phase] - f.rms_mpp[phase] for f in figures]
        assert float(np.mean(gain)) > 0.0, (phase, gain, table)
        assert sum(g > 0.0 for g in gain) > len(gain) / 2, (phase, gain, table)


def test_mpp_nees_is_consistent_with_two(figures: list[SeedFigures]) -> None:
    """The MPP's mean NEES over all epochs (2 dof: expected 2 for an honest covariance),
    averaged over the seeds, has 2 inside its 95 % Student interval (module docstring).

    The per-seed mean NEES is a time average of correlated χ²(2) values (about ten effective
    samples per seed), so its spread is estimated from the seeds themselves rather than from
    χ²(2N)/N with N = 3600 epochs per seed, whose band 1.94–2.07 would pretend the epochs are
    independent. The 150-seed reference (2.55 ± 0.11) is not consistent with 2; at K = 10 the
    interval is about ±0.8 wide and holds 2 for 87 % of random 10-seed draws, so this is a test
    against gross overconfidence (it catches ``bias_noise = false``), not a proof of honesty.
    Below 2 is the cautious side (the current's random walk allows the thesis' tide to change
    over an hour, the demo's current is constant: measured 1.09 ± 0.27), allowed down to 0.5,
    an ellipse whose σ is twice what the errors show (an over-large ellipse is a small fault, a
    useless one is not).
    """
    m, h = _mean_ci([f.nees["all"] for f in figures])
    assert m - 2.0 <= h and m >= 0.5, (m, h, _table(figures))

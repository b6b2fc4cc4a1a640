"""Issue 11: the default filter on missions nobody tuned it to, over ten seeds each.

The six missions of ``data/scenarios/`` (tests/missions.py: simulated with the simulator's
documented error models, replayed with start-up values only, no ``[filter]`` table) against
the issue's targets:

* the MPP's 95 % ellipse holds the truth in 90–99 % of the surfaced epochs and in ≥ 90 % of all
  epochs;
* the MPP's RMS error is at most the LSE's while surfaced;
* after resurfacing the MPP's RMS error is at most 1.5 × the surfaced LSE RMS;
* no epoch after a dive uses a wrong Decca integer lane.

**Tolerances.** The seeds are the independent unit (a 20-min phase holds only about T/(2τ) ≈ 2–5
independent samples of a Gauss–Markov fix error with τ 180–240 s), so a coverage target is
asserted *consistent* with the runs: the band must meet the two-sided 95 % Student interval of
the mean over the K = 10 seeds, m ± t₀.₉₇₅(9)·s/√10 (t = 2.262); such an assertion holds with
probability 0.95 when the target is true. RMS targets are asserted on the means over the seeds
(each seed's RMS is a time average over the whole phase). Lane errors are counted, not
averaged: one wrong lane in any epoch after any dive fails. The figures of the last run are in
docs/ASSESS.md ("Missions nobody tuned to"); rerun them with ``python -m tests.missions``.

A wrong model fails: the thesis preset (white fix noise, P0 = I) holds the truth in 0–13 % of
the epochs here (docs/ASSESS.md).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import t as student_t

from engine.run.session import read_data_dir
from tests.missions import (
    DATA,
    HEADER,
    MISSIONS,
    MissionFigures,
    mean_figures,
    replay_mission,
    row,
)

SEEDS = tuple(range(1, 11))
"""Fixed seeds, not chosen by looking at results."""
DIVES = ("M5_DIVE30", "M6_DIVE150")

pytestmark = pytest.mark.slow


def _mean_ci(values: list[float]) -> tuple[float, float]:
    a = np.asarray(values, dtype=float)
    return float(a.mean()), float(student_t.ppf(0.975, a.size - 1) * a.std(ddof=1)
                                  / math.sqrt(a.size))


@pytest.fixture(scope="module")
def figures(tmp_path_factory: pytest.TempPathFactory) -> dict[str, list[MissionFigures]]:
    """Every mission over the ten seeds, simulated and replayed once for the module."""
    data = read_data_dir(DATA)
    run_dir = tmp_path_factory.mktemp("missions")
    out: dict[str, list[MissionFigures]] = {}
    lines = [HEADER]
    for name in MISSIONS:
        out[name] = [replay_mission(name, seed, data, Path(run_dir)) for seed in SEEDS]
        lines += [row(f) for f in out[name]] + [row(mean_figures(out[name]), "mean")]
    print("\n" + "\n".join(lines))  # with pytest -s, and under a failure's captured output
    return out


@pytest.mark.parametrize("name", MISSIONS)
def test_mpp_ellipse_coverage_at_least_90_percent(figures: dict[str, list[MissionFigures]],
                                                  name: str) -> None:
    """Surfaced and all-epoch coverage consistent with ≥ 90 % (the safety side)."""
    figs = figures[name]
    for phase in ("surfaced", "all"):
        m, h = _mean_ci([f.coverage[phase] for f in figs])
        assert m + h >= 0.90, (name, phase, m, h)


@pytest.mark.parametrize("name", MISSIONS)
def test_mpp_ellipse_coverage_at_most_99_percent(figures: dict[str, list[MissionFigures]],
                                                 name: str) -> None:
    """Surfaced coverage consistent with ≤ 99 % (an ellipse not uselessly large)."""
    m, h = _mean_ci([f.coverage["surfaced"] for f in figures[name]])
    assert m - h <= 0.99, (name, "surfaced", m, h)


@pytest.mark.parametrize("name", MISSIONS)
def test_mpp_no_worse_than_the_lse_while_surfaced(figures: dict[str, list[MissionFigures]],
                                                  name: str) -> None:
    """Mean over seeds of the surfaced RMS error: MPP ≤ LSE."""
    figs = figures[name]
    mpp = float(np.mean([f.rms_mpp["surfaced"] for f in figs]))
    lse = float(np.mean([f.rms_lse["surfaced"] for f in figs]))
    assert mpp <= lse, (name, mpp, lse)


@pytest.mark.parametrize("name", DIVES)
def test_after_resurfacing(figures: dict[str, list[MissionFigures]], name: str) -> None:
    """After the dive: MPP RMS ≤ 1.5 × the surfaced LSE RMS (means over seeds), and not one
    epoch on any seed with a wrong Decca integer lane; each seed has fixes again."""
    figs = figures[name]
    assert all(f.epochs["after"] > 0 and f.epochs["submerged"] > 0 for f in figs)
    after = float(np.mean([f.rms_mpp["after"] for f in figs]))
    lse = float(np.mean([f.rms_lse["surfaced"] for f in figs]))
    assert after <= 1.5 * lse, (name, after, lse)
    assert [f.wrong_lane["after"] for f in figs] == [0] * len(figs)


def test_lanes_are_right_after_a_dive_even_with_the_thesis_filter(
    tmp_path: Path,
) -> None:
    """Lane integrity does not rest on the filter being honest: with the thesis preset (whose
    DR ellipse after the 30-min dive is far too small) GPS settles the lanes when the boat
    resurfaces. Before issue 11 the lanes were identified from the DR position, 3.6 km off
    the truth, and the LSE followed them (the issue's table)."""
    data = read_data_dir(DATA)
    for seed in (1, 2):
        f = replay_mission("M5_DIVE30", seed, data, tmp_path,
                           {"preset": "thesis", "model": "thesis", "p0": "thesis",
                            "bias_noise": False})
        assert f.wrong_lane == {"surfaced": 0, "submerged": 0, "after": 0}, (seed, row(f))
        assert f.rms_lse["after"] < 100.0, (seed, row(f))

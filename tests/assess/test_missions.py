"""Issue 11: the default filter on missions nobody tuned it to, over ten seeds each.

The six missions of ``data/scenarios/`` (the campaign ``data/campaigns/missions.toml``, run here
by a plain loop of the campaign's run function, tests/missions.py: simulated with the
simulator's documented error models, replayed with start-up values only, the ``.OUT`` scored
against the truth as ``uvnav assess`` does) against the issue's targets:

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
docs/ASSESS.md ("Missions nobody tuned to"); rerun them with
``uvnav campaign data/campaigns/missions.toml --out DIR``.

A wrong model fails: the thesis preset (white fix noise, P0 = I) holds the truth in 0–13 % of
the epochs here (docs/ASSESS.md).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import t as student_t

from tests.missions import MISSIONS, Row, mission_rows, summary

SEEDS = tuple(range(1, 11))
"""Fixed seeds, not chosen by looking at results."""
DIVES = ("M5_DIVE30", "M6_DIVE150")

pytestmark = pytest.mark.slow


def _mean_ci(values: list[float]) -> tuple[float, float]:
    a = np.asarray(values, dtype=float)
    return float(a.mean()), float(student_t.ppf(0.975, a.size - 1) * a.std(ddof=1)
                                  / math.sqrt(a.size))


@pytest.fixture(scope="module")
def figures() -> dict[str, list[Row]]:
    """Every mission over the ten seeds, simulated, replayed and assessed once for the module."""
    out = mission_rows(MISSIONS, SEEDS)
    print("\n" + summary(r for rows in out.values() for r in rows))  # pytest -s, or a failure
    for name, rows in out.items():
        assert [r["status"] for r in rows] == ["ok"] * len(SEEDS), (name, rows[0]["error"])
    return out


@pytest.mark.parametrize("name", MISSIONS)
def test_mpp_ellipse_coverage_at_least_90_percent(figures: dict[str, list[Row]],
                                                  name: str) -> None:
    """Surfaced and all-epoch coverage consistent with ≥ 90 % (the safety side)."""
    rows = figures[name]
    for phase in ("surfaced", "all"):
        m, h = _mean_ci([r[f"{phase}_mpp_cover95"] for r in rows])
        assert m + h >= 0.90, (name, phase, m, h)


WINTER_DECCA = pytest.mark.xfail(strict=True, reason=(
    "over-coverage by the thesis' seasons: M1 is an October afternoon, a winter day for "
    "lsq.decca_cf = 'auto' (σ ×4 on the summer day, thesis L8352), while the simulator draws "
    "its Decca errors with the summer-day CF 64 (docs/ASSESS.md, 'Decca at night')"))


@pytest.mark.parametrize("name", [pytest.param(n, marks=WINTER_DECCA) if n == "M1_SURF9B"
                                  else n for n in MISSIONS])
def test_mpp_ellipse_coverage_at_most_99_percent(figures: dict[str, list[Row]],
                                                 name: str) -> None:
    """Surfaced coverage consistent with ≤ 99 % (an ellipse not uselessly large)."""
    m, h = _mean_ci([r["surfaced_mpp_cover95"] for r in figures[name]])
    assert m - h <= 0.99, (name, "surfaced", m, h)


@pytest.mark.parametrize("name", MISSIONS)
def test_mpp_no_worse_than_the_lse_while_surfaced(figures: dict[str, list[Row]],
                                                  name: str) -> None:
    """Mean over seeds of the surfaced RMS error: MPP ≤ LSE."""
    rows = figures[name]
    mpp = float(np.mean([r["surfaced_mpp_rms_m"] for r in rows]))
    lse = float(np.mean([r["surfaced_lse_rms_m"] for r in rows]))
    assert mpp <= lse, (name, mpp, lse)


@pytest.mark.parametrize("name", DIVES)
def test_after_resurfacing(figures: dict[str, list[Row]], name: str) -> None:
    """After the dive: MPP RMS ≤ 1.5 × the surfaced LSE RMS (means over seeds), and not one
    epoch on any seed with a wrong Decca integer lane; each seed has fixes again."""
    rows = figures[name]
    assert all(r["after_epochs"] > 0 and r["submerged_epochs"] > 0 for r in rows)
    after = float(np.mean([r["after_mpp_rms_m"] for r in rows]))
    lse = float(np.mean([r["surfaced_lse_rms_m"] for r in rows]))
    assert after <= 1.5 * lse, (name, after, lse)
    assert [r["wrong_lane_after"] for r in rows] == [0] * len(rows)


def test_lanes_are_right_after_a_dive_even_with_the_thesis_filter() -> None:
    """Lane integrity does not rest on the filter being honest: with the thesis preset (whose
    DR ellipse after the 30-min dive is far too small) GPS settles the lanes when the boat
    resurfaces. Before issue 11 the lanes were identified from the DR position, 3.6 km off
    the truth, and the LSE followed them (the issue's table)."""
    rows = mission_rows(["M5_DIVE30"], (1, 2), {"preset": "thesis", "model": "thesis",
                                                "p0": "thesis", "bias_noise": False})
    for r in rows["M5_DIVE30"]:
        assert r["status"] == "ok", r["error"]
        lanes = [r[f"wrong_lane_{p}"] for p in ("surfaced", "submerged", "after")]
        assert lanes == [0, 0, 0], (r["seed"], lanes)
        assert r["after_lse_rms_m"] < 100.0, (r["seed"], r["after_lse_rms_m"])

"""The default filter on sixty randomized missions (data/campaigns/random_60.toml: the sampler of
engine/sim/sampler.py, start-up values only), against the targets of docs/ASSESS.md
("Randomized missions"):

* MPP 95 % coverage ≥ 85 % in every phase of ≥ 300 epochs on ≥ 95 % of the missions;
* median all-epoch coverage 92–98.5 %;
* ≤ 0.5 % of the epochs (all missions pooled) with an MPP error beyond twice the 95 %
  semi-major axis;
* MPP RMS ≤ LSE RMS while surfaced on ≥ 90 % of the missions with an LSE;
* no epoch using a wrong Decca lane; no failed run (a refused draw is a sampler bug).

The missions are the unit: each target is a share or a quantile over missions, asserted as is
(the sixty seeds are fixed, not chosen by looking at results). The runs are a plain loop of the
campaign's run function; ``uvnav campaign data/campaigns/random_60.toml --out DIR`` gives the
same rows and ``python -m tests.random_missions DIR`` the tables. Targets the default filter
does not meet yet are marked xfail (not strict), with the measured figure in docs/ASSESS.md
(the epochs beyond 2 × a95 and no wrong Decca lane are met and asserted). The median all-epoch
coverage is above the band (100 %: over-coverage, the small fault) since the Decca VCV follows
the thesis' day/night and season (``lsq.decca_cf = "auto"``, docs/ASSESS.md "Decca at night"):
the sampler's Decca errors are summer-day ones but for its night sky-wave episodes.
"""

from __future__ import annotations

import pytest

from engine.campaign.run import run_one
from engine.campaign.spec import load_campaign
from tests import random_missions as rm
from tests.paths import DATA

pytestmark = pytest.mark.slow

SPEC = DATA / "campaigns" / "random_60.toml"
NOT_YET = pytest.mark.xfail(strict=False,
                            reason="issue targets not met yet by the default filter")


@pytest.fixture(scope="module")
def rows() -> list[dict]:
    spec = load_campaign(SPEC)
    bundle = spec.bundle()
    out = [run_one(bundle, task) for task in spec.tasks]
    print("\n" + rm.tables(out))  # pytest -s, or a failure
    return out


def test_every_drawn_mission_runs(rows: list[dict]) -> None:
    assert len(rows) == 60
    assert [r["error"] for r in rows if r["status"] != "ok"] == []


@NOT_YET
def test_coverage_at_least_85_percent_in_every_phase_on_95_percent(rows: list[dict]) -> None:
    assert rm.figures(rows).share_phases_ok >= rm.SHARE_MISSIONS


@pytest.mark.xfail(strict=False, reason="over-coverage: the thesis' night and winter Decca "
                   "VCV against the sampler's summer-day Decca errors (docs/ASSESS.md)")
def test_median_all_epoch_coverage_92_to_98_5_percent(rows: list[dict]) -> None:
    lo, hi = rm.MEDIAN_ALL
    assert lo <= rm.figures(rows).median_all_cover <= hi


def test_errors_beyond_twice_the_semi_major_axis_at_most_half_a_percent(
        rows: list[dict]) -> None:
    assert rm.figures(rows).beyond_2a <= rm.BEYOND_2A


@NOT_YET
def test_mpp_no_worse_than_the_lse_while_surfaced_on_90_percent(rows: list[dict]) -> None:
    assert rm.figures(rows).mpp_le_lse_share >= rm.MPP_LE_LSE


def test_no_wrong_decca_lane(rows: list[dict]) -> None:
    assert rm.figures(rows).wrong_lanes == 0

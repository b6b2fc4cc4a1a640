"""Campaigns: many simulate → replay → assess runs from one spec (``uvnav campaign``).

``spec`` reads the campaign spec (TOML) into runs keyed by a hash of their inputs, ``run`` is the
function that does one run and returns its row, ``store`` records rows as they come and writes
the table, ``summary`` the distributions per variant and phase. No scheduler here: the caller
(a plain loop, or Dask in ``uvnav_tui/cli/campaign.py``) maps :func:`engine.campaign.run.run_one`
over the runs. docs/CAMPAIGN.md.
"""

from engine.campaign.run import (
    COLUMNS,
    SINCE_FIX_BINS_MIN,
    TIMING_COLUMNS,
    blank_row,
    run_one,
    since_fix_column,
)
from engine.campaign.spec import CampaignSpec, RunTask, load_campaign
from engine.campaign.store import CHANGED_SPEC_MESSAGE, CampaignStore, read_table
from engine.campaign.summary import SUMMARY_COLUMNS, summary_markdown, variant_arrays

__all__ = [
    "CHANGED_SPEC_MESSAGE",
    "COLUMNS",
    "SINCE_FIX_BINS_MIN",
    "SUMMARY_COLUMNS",
    "TIMING_COLUMNS",
    "CampaignSpec",
    "CampaignStore",
    "RunTask",
    "blank_row",
    "load_campaign",
    "read_table",
    "run_one",
    "since_fix_column",
    "summary_markdown",
    "variant_arrays",
]

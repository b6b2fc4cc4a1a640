"""The campaign's results store and summary (engine/campaign/store.py, summary.py), without a
cluster: a line cut short by a killed client, a run recorded twice, the table's order and types,
and text from a run's error kept as data in ``summary.md``."""

from __future__ import annotations

import math
from pathlib import Path

import pyarrow.parquet as pq

from engine.campaign.run import COLUMNS, blank_row
from engine.campaign.spec import load_campaign
from engine.campaign.store import CampaignStore
from engine.campaign.summary import summary_markdown
from tests.paths import DATA

SHORT = DATA / "campaigns" / "scenarios" / "SHORT_DIVE.scenario.toml"


def _spec(tmp_path: Path) -> Path:
    p = tmp_path / "c.toml"
    p.write_text(f'scenarios = ["{SHORT}"]\nseeds = "1-4"\n', encoding="utf-8")
    return p


def test_torn_line_and_duplicates_and_order(tmp_path: Path) -> None:
    spec = load_campaign(_spec(tmp_path))
    store = CampaignStore(tmp_path / "out")
    store.open(spec)
    t1, t2, t3, t4 = spec.tasks
    for task, wall in ((t3, 1.0), (t1, 2.0), (t3, 3.0)):  # t3 twice: the last one counts
        row = blank_row(task)
        row.update(status="ok", wall_s=wall, all_mpp_rms_m=float(task.seed))
        store.append(row)
    store.close()
    part = next((tmp_path / "out" / "parts").glob("*.jsonl"))
    with open(part, "ab") as fh:  # a client killed in the middle of a line
        fh.write(b'{"key": "' + t4.key.encode() + b'", "scen')
    assert store.finished() == {t1.key, t3.key}
    assert store.write_table(spec) == 2
    table = pq.read_table(tmp_path / "out" / "runs.parquet")
    assert table.column_names == [n for n, _k in COLUMNS]
    rows = table.to_pylist()
    assert [(r["seed"], r["wall_s"]) for r in rows] == [(1, 2.0), (3, 3.0)]  # spec order
    assert math.isnan(rows[0]["all_lse_rms_m"]) and rows[0]["all_mpp_rms_m"] == 1.0
    assert str(table.schema.field("seed").type) == "int64"
    # a second store (the next call) writes a new part beside the old one
    again = CampaignStore(tmp_path / "out")
    again.open(spec)
    again.append({**blank_row(t2), "status": "failed", "error": "x"})
    again.close()
    assert len(list((tmp_path / "out" / "parts").glob("*.jsonl"))) == 2
    assert again.finished() == {t1.key, t2.key, t3.key}


def test_an_error_text_is_data_in_the_summary(tmp_path: Path) -> None:
    spec = load_campaign(_spec(tmp_path))
    rows = [blank_row(t) for t in spec.tasks[:1]]
    rows[0]["error"] = "bad | cell <b>bold</b> **x**\nnext"
    cols = {n: [r[n] for r in rows] for n, _k in COLUMNS}
    text = summary_markdown(cols, name="t", spec_path="c.toml", planned=4)
    line = next(ln for ln in text.splitlines() if "bad" in ln)
    assert "bad \\| cell \\<b\\>bold\\</b\\> \\*\\*x\\*\\* next" in line
    assert "1 of 4 runs recorded, 0 ok, 1 failed" in text and "**Incomplete**" in text

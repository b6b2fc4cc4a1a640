"""Issue 15 item 6: a fix that fails every test is not taken at face value.

The issue's case: DECCA.CHN cut so the 9B propagation speed read 29955 km/s. Every Decca LOP then
fails the w-test and S² is ~10⁵, yet the run reported "rejected LOPs 0" and a 7 × 2 m ellipse 24 km
off. The parser now refuses that file (tests/io/test_datafile_damage.py); here the chain is damaged
in memory to exercise the cycle's own defence.
"""

from __future__ import annotations

import dataclasses
import json
import pathlib

import numpy as np
import pytest
from scipy.stats import chi2

from engine.io.outlog import read_out_log
from engine.run.cycle import build_context, fix_fit
from engine.run.session import Session, load_run_config
from tests.paths import DATA


def _session(tmp_path: pathlib.Path, speed: float | None, lane_rule: str | None = None
             ) -> Session:
    cfg, (datums, chains) = load_run_config(DATA / "920917_1.toml")
    if lane_rule is not None:
        cfg = cfg.replace(decca=dataclasses.replace(cfg.decca, lane_rule=lane_rule))
    if speed is not None:
        chains = dict(chains)
        chains["9B"] = dataclasses.replace(chains["9B"], speed_km_s=speed)
    return Session(cfg, data=(datums, chains), history=20, out_path=tmp_path / "R.OUT",
                   jsonl_path=tmp_path / "R.jsonl")


def test_damaged_chain_fixes_are_flagged_and_deweighted(tmp_path: pathlib.Path) -> None:
    with _session(tmp_path, 29955.0) as s:
        summary = s.run()
    results = list(s.history)
    assert summary.epochs == 10 and summary.failed_fixes == 10
    # The 2-dof unit-variance bound from scipy, independently of engine.lsq.statistics: S² > 3.689.
    upper = chi2.ppf(0.975, 2) / 2
    for r in results:
        assert r.fix is not None and r.fix.s2 is not None and r.fix.s2 > upper
        assert r.fix_fails_tests and r.fix_cov_scale == r.fix.s2
        assert any(m.startswith("Fix fails its tests (S²") for m in r.messages)
    # Cycle 1: the MPP is the LSE, its VCV S² times the fix's (not the 3 × 0.7 m of before).
    first = results[0]
    assert first.mpp.source == "LSE" and first.fix is not None
    np.testing.assert_allclose(first.mpp.cov, first.fix.cov * first.fix.s2, rtol=1e-12)
    assert first.mpp.ellipse is not None and first.mpp.ellipse.a_m > 300.0
    # The logs say so too.
    log = read_out_log(tmp_path / "R.OUT")
    assert all(c.first("LSE")["tests"] == "fail" for c in log.cycles)
    rows = [json.loads(line) for line in (tmp_path / "R.jsonl").read_text().splitlines()]
    assert all(row["fix_tests"]["failed"] for row in rows)
    assert rows[0]["fix_tests"]["cov_scale"] == pytest.approx(first.fix.s2, rel=1e-5)


def test_filter_gain_shrinks_by_the_variance_factor(tmp_path: pathlib.Path) -> None:
    # Five good cycles, then the chain is damaged under a confident filter. With R = S²·C the
    # Kalman gain on the position is P(P + S²C)⁻¹ ~ P/(S²C): the filter moves by ~1/S² of the
    # innovation instead of taking a kilometres jump as a fix (1 s of sailing is ~6 m).
    # The former lane rule ("sigma"), which lets GPS correct the damage's integer part; the
    # default rule leaves a pattern GPS cannot settle out of the fix instead (THEORY §3.3),
    # and this test is about the fix's weight, not its lanes.
    with _session(tmp_path, None, lane_rule="sigma") as s:
        s.run(max_cycles=5)
        ctx = s.context
        chains = dict(ctx.chains)
        # 295 000 km/s: 1.5 % slow. The GPS lane check (issue 11) corrects the integer part of
        # the damage (Red -1, Green -4 lanes), so the fix jumps ~400 m rather than 4.4 km; the
        # fractional part still fails the unit-variance test by an order of magnitude.
        chains["9B"] = dataclasses.replace(chains["9B"], speed_km_s=295_000.0)
        s.context = build_context(ctx.config, ctx.datums, chains)
        before = s.nav.filter
        r = s.step()
    assert r is not None and r.fix is not None and r.fix_fails_tests and before is not None
    assert r.filter_update is not None and r.fix.s2 is not None and r.fix.s2 > 10.0 * 3.689
    assert r.lane_slips > 0
    k = np.asarray(r.filter_update.K)[:2, :2]
    assert np.abs(k).max() < 10.0 / r.fix.s2
    jump = np.hypot(r.fix.x_m - before.x[0], r.fix.y_m - before.x[1])
    moved = np.hypot(r.mpp.x_m - before.x[0], r.mpp.y_m - before.x[1])
    assert jump > 300.0 and moved < 20.0


def test_good_run_has_no_failed_fixes(tmp_path: pathlib.Path) -> None:
    with _session(tmp_path, None) as s:
        summary = s.run()
    assert summary.fixes == 10 and summary.failed_fixes == 0
    assert all(not r.fix_fails_tests and r.fix_cov_scale == 1.0 for r in s.history)
    assert fix_fit(None) == (1.0, None)


def test_replay_summary_counts_failed_fixes() -> None:
    from engine.run.session import RunSummary
    from uvnav_tui.cli.replay import _summary_lines

    s = RunSummary(epochs=10, fixes=10, rejected_lops=0, skipped_records=0, last=None,
                   out_path=None, jsonl_path=None, eof=True, failed_fixes=10)
    assert any(line.startswith("fixes failing their tests 10 of 10") for line in
               _summary_lines(s, None))

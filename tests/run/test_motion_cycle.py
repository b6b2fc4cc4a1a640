"""The COG/SOG stand-in's learnt process noise in the cycle and its reports (engine.filter.motion,
docs/GNSS_WEIGHTS.md), on the first 40 minutes of the bundled Baltic log (RMC only: COG/SOG
stand in for the missing gyro and log): it leaves the cap after MIN_S, shows in the ``.OUT``
(MOTION line with ADAPT) and the JSON lines, is off in the thesis preset, and the ellipse of
a GNSS outage still grows with the time since the last fix."""

from __future__ import annotations

import pytest

from engine.assess.denied import clean_records, hide_positions, run_records
from engine.filter.motion import MIN_S
from engine.run.cycle import build_context, initial_state, step
from engine.run.records import cycle_block, cycle_json
from tests.denied_tables import STANDIN, _merge, load

BALTIC = "avnav-baltic-20130731"
RECORDS = 2400  # 40 minutes at one record a second


def _run(overrides: dict[str, object], n: int = RECORDS) -> tuple[object, object, list]:
    cfg, data = load(BALTIC, _merge(STANDIN, overrides))
    ctx = build_context(cfg, *data)
    nav = initial_state(ctx.config)
    out = []
    recs = clean_records(run_records(cfg))[0][:n]
    for rec in recs:
        nav, r = step(ctx, nav, rec)
        out.append(r)
    return ctx, nav, out


@pytest.fixture(scope="module")
def baltic() -> tuple[object, object, list]:
    return _run({})


def test_learnt_below_the_cap_on_the_baltic(baltic: tuple[object, object, list]) -> None:
    """The cap (3°/s, σ_a² 6.04e-3) until MIN_S, then the learnt rate of turn, well below it on
    the open-water leg, and σ_a² at its floor or above; the filter's prediction uses them."""
    ctx, nav, out = baltic
    first = out[0].motion
    assert first is not None and first.turn_rate_max_deg_s == pytest.approx(3.0)
    last = out[-1].motion
    assert last is not None and last.seconds >= MIN_S
    assert 0.4 < last.turn_rate_max_deg_s < 2.0
    assert ctx.derived().motion.accel_floor <= last.sigma_a2 <= ctx.derived().motion.accel_cap
    assert ctx.motion_params(first) is ctx.filter_params  # the caps: unchanged parameters
    p = ctx.motion_params(last)
    assert p.turn_rate_max_deg_s == pytest.approx(last.turn_rate_max_deg_s, rel=0.011)
    assert p.sigma_a2 == pytest.approx(last.sigma_a2, rel=0.006)
    assert nav.motion is last


def test_reported_in_out_and_jsonl(baltic: tuple[object, object, list]) -> None:
    """Every ADAPT line has a MOTION line after it with the values in force; the JSON lines
    carry them under ``adapt``; a change of more than 5 % is logged."""
    _ctx, _nav, out = baltic
    logged = [r for r in out if r.adapt_logged]
    assert len(logged) >= 2
    turns = []
    for r in logged:
        _head, lines = cycle_block(r)
        keys = [ln[0].strip() for ln in lines]
        assert "MOTION" in keys and keys.index("MOTION") == keys.index("ADAPT") + 1
        fields = dict(lines[keys.index("MOTION")][1])
        assert fields["turn"] == r.motion.turn_rate_max_deg_s
        assert fields["skipped"] == r.motion.skipped
        turns.append(fields["turn"])
    assert turns[0] == pytest.approx(3.0) and min(turns) < 2.0
    j = cycle_json(out[-1])
    assert j["adapt"]["turn_deg_s"] == pytest.approx(out[-1].motion.turn_rate_max_deg_s,
                                                     abs=1e-4)
    assert j["adapt"]["motion_skipped"] == out[-1].motion.skipped


def test_off_in_the_thesis_preset_and_without_the_standin() -> None:
    """The thesis preset (adapt off) learns nothing; without the stand-in there is no motion
    noise to learn."""
    _ctx, _nav, out = _run({"filter": {"preset": "thesis"}}, n=60)
    assert all(r.motion is None for r in out)
    cfg, data = load(BALTIC, {})
    ctx = build_context(cfg, *data)
    assert ctx.derived().motion is None


def test_outage_ellipse_grows_with_time_since_the_last_fix(
        baltic: tuple[object, object, list]) -> None:
    """Ten minutes without fixes or COG/SOG after 40 minutes of learning: the learnt noise is
    held, and the MPP's 95 % semi-major axis grows monotonically with the time since the fix."""
    cfg, data = load(BALTIC, STANDIN)
    ctx = build_context(cfg, *data)
    nav = initial_state(ctx.config)
    recs = clean_records(run_records(cfg))[0][:RECORDS + 600]
    for rec in recs[:RECORDS]:
        nav, r = step(ctx, nav, rec)
    held = nav.motion
    assert held is not None and held.turn_rate_max_deg_s < 2.0
    a95 = []
    for rec in recs[RECORDS:]:
        nav, r = step(ctx, nav, hide_positions(rec))
        a95.append(r.mpp.ellipse.scaled(0.95)[0])
    assert nav.motion.q_turn == held.q_turn and nav.motion.seconds == held.seconds
    assert all(b > a for a, b in zip(a95, a95[1:], strict=False))
    assert a95[-1] > 5 * a95[0]


def test_shown_on_pg650_and_in_the_replay_summary(baltic: tuple[object, object, list]) -> None:
    """Pg 650 shows the learnt stand-in noise under the learnt fix factor; the replay summary
    has a line for it."""
    from uvnav_tui.cli.replay import motion_line
    from uvnav_tui.pages.p650_kalman_statistics import adapt_lines

    r = baltic[2][-1]
    m = r.motion
    text = "\n".join(adapt_lines(r))
    assert f"Learnt stand-in noise : rate of turn {m.turn_rate_max_deg_s:.3f}"[:44] in text
    assert f"{m.skipped} COG skipped" in text
    line = motion_line(m)
    assert line.startswith("learnt stand-in motion noise: rate of turn")
    assert f"{m.n} lags" in line

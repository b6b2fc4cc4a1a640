"""Randomized missions in a campaign (``[sampler]``, docs/CAMPAIGN.md) and from the command line
(``uvnav simulate --random SEED``, docs/SIMULATOR.md)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from engine.assess.accuracy import assess, read_nav_log, read_truth
from engine.campaign.run import run_one
from engine.campaign.spec import load_campaign
from engine.errors import InputError
from engine.run.config import load_config
from engine.run.session import Session
from tests.paths import DATA
from uvnav_tui.cli.simulate import run_simulate

SHORT_SEED = 59
"""A 31-min mission (GPS + Decca 2E, one dive) drawn by the sampler: quick to run."""


def _spec(tmp_path: Path, body: str) -> Path:
    p = tmp_path / "r.toml"
    p.write_text(body, encoding="utf-8")
    return p


def test_sampler_section_gives_one_run_per_seed(tmp_path: Path) -> None:
    p = _spec(tmp_path, f'seeds = "1-4"\n[sampler]\ndata_dir = "{DATA}"\nsample_interval_s = 2\n')
    spec = load_campaign(p)
    assert [(t.scenario, t.seed) for t in spec.tasks] == [("random", s) for s in (1, 2, 3, 4)]
    assert len({t.key for t in spec.tasks}) == 4
    # the same sampler options on other seeds keep the keys (random_60 is a prefix of random)
    p2 = _spec(tmp_path, p.read_text().replace('"1-4"', '"1-8"'))
    assert [t.key for t in load_campaign(p2).tasks][:4] == [t.key for t in spec.tasks]
    # another interval draws other missions: other keys
    p3 = _spec(tmp_path, p.read_text().replace("= 2", "= 1"))
    assert load_campaign(p3).tasks[0].key != spec.tasks[0].key


def test_bundled_random_campaigns_share_their_first_sixty_runs() -> None:
    small = load_campaign(DATA / "campaigns" / "random_60.toml")
    big = load_campaign(DATA / "campaigns" / "random.toml")
    assert len(small.tasks) == 60 and len(big.tasks) >= 500
    assert [t.key for t in big.tasks[:60]] == [t.key for t in small.tasks]


@pytest.mark.parametrize("body, field, message", [
    ('seeds = [1]\n[sampler]\nbogus = 1\n', "sampler.bogus", "Unknown key"),
    ('seeds = [1]\n[sampler]\nsample_interval_s = 0\n', "sampler.sample_interval_s",
     "whole number 1-60"),
    ('seeds = [1]\n[sampler]\nmax_mission_s = 99999\n', "sampler.max_mission_s",
     "whole number 60-43200"),
])
def test_bad_sampler_keys_are_located(tmp_path: Path, body: str, field: str,
                                      message: str) -> None:
    p = _spec(tmp_path, body.replace("[sampler]\n", f'[sampler]\ndata_dir = "{DATA}"\n'))
    with pytest.raises(InputError) as info:
        load_campaign(p)
    err = info.value
    assert (err.field, err.file) == (field, str(p))
    assert err.line == next(i for i, line in enumerate(p.read_text().splitlines(), 1)
                            if line.startswith(field.split(".")[1]))
    assert message in err.message


def test_a_sampler_run_is_the_drawn_mission_replayed_and_assessed(tmp_path: Path) -> None:
    """The campaign's row for a drawn mission equals ``uvnav simulate --random`` + replay +
    assess of the same seed done by hand (coverage, RMS and the new beyond-2a column)."""
    p = _spec(tmp_path, f'seeds = [{SHORT_SEED}]\n[sampler]\ndata_dir = "{DATA}"\n')
    spec = load_campaign(p)
    row = run_one(spec.bundle(), spec.tasks[0])
    assert row["status"] == "ok", row["error"]
    out = tmp_path / "R.RUN"
    assert run_simulate(["--random", str(SHORT_SEED), "--out", str(out),
                         "--data-dir", str(DATA)]) == 0
    cfg = load_config(tmp_path / "R.toml")
    log = tmp_path / "R.OUT"
    with Session(cfg, out_path=log, force=True, history=1) as session:
        session.run()
    a = assess(read_nav_log(log), read_truth(tmp_path / "R.truth.csv"))
    assert row["epochs"] == a.n_matched
    st = a.stat("all", "mpp")
    assert row["all_mpp_cover95"] == pytest.approx(st.coverage, abs=1e-12)
    assert row["all_mpp_rms_m"] == pytest.approx(st.rms_m, rel=1e-9)
    # beyond 2 × a95, counted by hand from the assessment's series
    s = a.series
    err = (s.error["mpp"][:, 0] ** 2 + s.error["mpp"][:, 1] ** 2) ** 0.5
    n = sum(1 for e, k in zip(err, s.kf_a95_m, strict=True) if math.isfinite(k) and e > 2 * k)
    m = sum(1 for e, k in zip(err, s.kf_a95_m, strict=True) if math.isfinite(k) and
            math.isfinite(e))
    assert row["all_mpp_beyond2a"] == pytest.approx(n / m, abs=1e-12)
    assert row["fixes_lse_rms_m"] > 0 and row["fixes_mpp_rms_m"] > 0


def test_simulate_random_writes_a_reproducible_mission(tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "R.RUN"
    args = ["--random", str(SHORT_SEED), "--out", str(out), "--data-dir", str(DATA),
            "--interval", "2"]
    assert run_simulate(args) == 0
    for name in ("R.RUN", "R.truth.csv", "R.scenario.toml", "R.toml"):
        assert (tmp_path / name).is_file()
    assert "random mission 59" in capsys.readouterr().out
    # the written scenario, simulated with the seed, gives the same .RUN
    again = tmp_path / "again.RUN"
    assert run_simulate([str(tmp_path / "R.scenario.toml"), "--seed", str(SHORT_SEED),
                         "--out", str(again)]) == 0
    assert again.read_bytes() == out.read_bytes()
    # an existing output is refused without --force, replaced with it
    assert run_simulate(args) == 2
    assert "File exists" in capsys.readouterr().err
    assert run_simulate([*args, "--force"]) == 0
    # --force never replaces a file that is not an earlier output
    (tmp_path / "R.toml").write_text("datum = 'ED50'\n", encoding="utf-8")
    assert run_simulate([*args, "--force"]) == 2
    assert "Not an earlier --random output" in capsys.readouterr().err


@pytest.mark.parametrize("extra, text", [
    (["--random", "-1"], "--random: Must be a whole number >= 0"),
    (["--random", "1", "--interval", "0"], "--interval: Must be a whole number 1-60"),
    (["--random", "1", "--seed", "3"], "--seed: Not with --random"),
    (["x.scenario.toml", "--random", "1"], "Give a scenario or --random, not both"),
    ([], "a scenario file or --random SEED is required"),
])
def test_simulate_random_bad_arguments(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                       extra: list[str], text: str) -> None:
    assert run_simulate([*extra, "--out", str(tmp_path / "R.RUN")]) == 2
    assert text in capsys.readouterr().err
    assert not (tmp_path / "R.RUN").exists()


def test_target_figures_of_hand_made_rows() -> None:
    """tests/random_missions.py on three rows computed by hand: a phase under 300 epochs is not
    scored, a failed run fails, the beyond-2a share is pooled over epochs."""
    from tests.random_missions import figures

    def row(**kw: object) -> dict:
        base = {"status": "ok", "all_epochs": 1000, "all_mpp_cover95": 0.95,
                "all_mpp_beyond2a": 0.0, "fixes_mpp_rms_m": 10.0, "fixes_lse_rms_m": 12.0,
                "wrong_lane_surfaced": 0, "wrong_lane_submerged": 0, "wrong_lane_after": 0}
        for ph in ("surfaced", "submerged", "after"):
            base |= {f"{ph}_epochs": 400, f"{ph}_mpp_cover95": 0.9}
        return base | kw

    rows = [row(),
            row(surfaced_epochs=299, surfaced_mpp_cover95=0.1, all_epochs=3000,
                all_mpp_beyond2a=0.01, all_mpp_cover95=0.80, fixes_mpp_rms_m=13.0,
                wrong_lane_after=2),
            row(status="failed", all_epochs=0)]
    f = figures(rows)
    assert f.share_phases_ok == pytest.approx(2 / 3)
    assert f.median_all_cover == pytest.approx(0.875)
    assert f.beyond_2a == pytest.approx(30 / 4000)
    assert f.mpp_le_lse_share == pytest.approx(0.5)
    assert (f.wrong_lanes, f.missions_with_wrong_lanes, f.failed) == (2, 1, 1)

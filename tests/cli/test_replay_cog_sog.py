"""``uvnav replay --cog-sog`` (docs/GNSS_WEIGHTS.md): sets ``sensors.cog_sog = "standin"``, says
so in the summary and in the .OUT configuration; a log with gyro and log is unchanged by it."""

from __future__ import annotations

from pathlib import Path

from engine.io.outlog import read_out_log
from tests.paths import DATA
from uvnav_tui.cli.main import main


def test_cog_sog_flag_is_logged_and_leaves_a_gyro_log_run_unchanged(tmp_path: Path,
                                                                   capsys) -> None:
    args = ["replay", str(DATA / "920917_1.RUN"), "--config", str(DATA / "920917_1.toml")]
    assert main([*args, "--out", str(tmp_path / "A.OUT")]) == 0
    plain = capsys.readouterr().out
    assert main([*args, "--out", str(tmp_path / "B.OUT"), "--cog-sog"]) == 0
    flagged = capsys.readouterr().out
    assert "dead reckoning: COG/SOG stand in" in flagged and "COG/SOG" not in plain
    a, b = read_out_log(tmp_path / "A.OUT"), read_out_log(tmp_path / "B.OUT")
    assert 'cog_sog = "standin"' in b.config_text and 'cog_sog = "off"' in a.config_text
    # The sample's records all have gyro and log: the stand-in never acts, every cycle equal.
    for ca, cb in zip(a.cycles, b.cycles, strict=True):
        assert ca.first("MPP") == cb.first("MPP") and "ref" not in cb.first("SENS")

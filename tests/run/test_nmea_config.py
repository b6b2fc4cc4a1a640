"""The [nmea] configuration table and the configuration derived from a log (docs/NMEA.md)."""

from __future__ import annotations

from datetime import date
from pathlib import Path

import pytest

from engine.errors import InputError
from engine.run.config import NmeaConfig, default_config, dump_config, parse_config_text
from engine.run.nmea_config import derive_nmea_config
from tests.nmea_lines import nmea
from tests.paths import DATA


def test_nmea_table_to_options() -> None:
    cfg = parse_config_text('[nmea]\ninterval_s = 2\ndate = "2024-02-29"\nvariation_deg = -3.5\n'
                            "heading_stale_s = 10\n")
    o = cfg.nmea.options
    assert (o.interval_s, o.date, o.variation_deg, o.heading_stale_s) == (
        2, date(2024, 2, 29), -3.5, 10.0)
    assert default_config().nmea.options.variation_deg is None
    assert parse_config_text(dump_config(cfg)) == cfg


@pytest.mark.parametrize(("text", "field", "line"), [
    ('[nmea]\ndate = "2023-02-29"\n', "nmea.date", 2),
    ('[nmea]\n\nvariation_deg = "east"\n', "nmea.variation_deg", 3),
    ("[nmea]\nvariation_deg = 181\n", "nmea.variation_deg", 2),
    ("[nmea]\ninterval_s = 1.5\n", "nmea.interval_s", 2),
    ("[nmea]\ndepth_stale_s = -1\n", "nmea.depth_stale_s", 2),
    ("[nmea]\nfoo = 1\n", "nmea.foo", 2),
])
def test_bad_nmea_keys_are_located(text: str, field: str, line: int) -> None:
    with pytest.raises(InputError) as err:
        parse_config_text(text, "X.toml")
    assert (err.value.field, err.value.line, err.value.file) == (field, line, "X.toml")


def test_default_table_is_not_dumped() -> None:
    """A .RUN run's log header (the dumped configuration) is as before the table existed."""
    assert "[nmea]" not in dump_config(default_config())
    assert "[nmea]" in dump_config(default_config().replace(nmea=NmeaConfig(interval_s=5)))


def test_derived_config(tmp_path: Path) -> None:
    log = tmp_path / "y.nmea"
    log.write_text("\n".join([
        nmea("GPRMC,120000,A,5250.0000,S,00430.0000,W,5.0,10.0,021226,,,A"),
        nmea("SDDPT,5.0,0.0"), nmea("GPRMC,120001,A,5250.0000,S,00430.0000,W,5.0,10.0,021226,,,A"),
    ]) + "\n")
    cfg, stats = derive_nmea_config(log, DATA)
    assert (cfg.datum, cfg.run_gps_datum, cfg.gps.on, cfg.decca.on, cfg.filter.on) == (
        "WGS84", "WGS84", True, False, True)
    assert (cfg.sensors.gyro, cfg.sensors.log, cfg.sensors.echosounder) == ("n/a", "n/a", "on")
    # 52°50' S, 4°30' W
    assert cfg.dr_lat_deg == pytest.approx(-52.8333333, abs=1e-6)
    assert cfg.dr_lon_deg == pytest.approx(-4.5, abs=1e-6)
    assert cfg.run_path == log and cfg.data_dir == DATA
    assert stats.epochs == 2


def test_run_path_of_a_log_without_suffix(tmp_path: Path) -> None:
    (tmp_path / "capture").write_text("x\n")
    cfg = parse_config_text('run_file = "capture"\n', base_dir=tmp_path)
    assert cfg.run_path == tmp_path / "capture"
    (tmp_path / "capture.RUN").write_text("x\n")  # both exist: the .RUN, as before
    assert cfg.run_path == tmp_path / "capture.RUN"
    assert parse_config_text('run_file = "nothing"\n', base_dir=tmp_path).run_path == \
        tmp_path / "nothing.RUN"

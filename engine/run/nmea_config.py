"""A run configuration derived from an NMEA 0183 log when none is given (docs/NMEA.md).

``uvnav replay LOG.nmea`` without ``--config`` and without ``LOG.toml`` beside the log runs with
this: working datum and GNSS datum WGS84 (NMEA positions are WGS84), DR position = the log's
first valid fix, GPS on, Decca off, gyro / log / echo sounder "on" when the log has heading /
water speed / depth sentences, else "n/a" (not connected), the filter's sensor and process
noise of a surface vessel (``filter.vessel = "surface"``, docs/CONFIG.md "The vessel
decision"), every other key at its default (the Kalman filter on, "honest" preset).
"""

from __future__ import annotations

import os
from pathlib import Path

from engine.errors import InputError
from engine.io.formatting import format_dms_input
from engine.io.nmea_epochs import NmeaStats
from engine.io.nmea_log import scan_nmea_log
from engine.run.config import (
    DeccaConfig,
    FilterConfig,
    GpsConfig,
    NmeaConfig,
    RunConfig,
    SensorsConfig,
)

__all__ = ["NO_DATE_MESSAGE", "NO_FIX_MESSAGE", "config_from_stats", "derive_nmea_config",
           "derived_config_lines"]

NO_FIX_MESSAGE = ("No valid position fix in the NMEA log: give --config FILE with a "
                  "dr_position !")
NO_DATE_MESSAGE = ("No date in the NMEA log (no RMC, no ZDA with a date): give --date "
                   "YYYY-MM-DD (or [nmea] date in a --config FILE) !")


def derive_nmea_config(
    log: str | os.PathLike[str], data_dir: str | os.PathLike[str],
    nmea: NmeaConfig | None = None,
) -> tuple[RunConfig, NmeaStats]:
    """The configuration for an NMEA log (module docstring) and what the log gave.

    ``data_dir`` holds TO_WGS84.DAT and DECCA.CHN (the bundled ``data/``). Raises
    ``InputError`` (naming the log) when the log has no valid fix: there is no DR position.
    """
    nmea = nmea if nmea is not None else NmeaConfig()
    path = Path(os.path.abspath(log))
    stats = scan_nmea_log(path, nmea.options)
    if stats.first_fix is None:
        if stats.undated_fixes:
            raise InputError(NO_DATE_MESSAGE, file=str(path), field="date")
        raise InputError(NO_FIX_MESSAGE, file=str(path), field="position")
    return config_from_stats(stats, data_dir, nmea, run_file=path.name,
                             config_dir=path.parent), stats


def config_from_stats(
    stats: NmeaStats, data_dir: str | os.PathLike[str], nmea: NmeaConfig, *, run_file: str,
    config_dir: Path,
) -> RunConfig:
    """The derived configuration (module docstring) from what a log or stream gave so far
    (``stats.first_fix`` must be set); also used by a live run without a configuration
    (engine/run/live.py)."""
    assert stats.first_fix is not None
    seen = stats.sensors

    def state(sensor: str) -> str:
        return "on" if sensor in seen else "n/a"

    return RunConfig(
        datum="WGS84",
        dr_position=format_dms_input(*stats.first_fix),
        run_file=run_file,
        run_gps_datum="WGS84",
        data_dir_text=str(Path(os.path.abspath(data_dir))),
        gps=GpsConfig(on=True),
        decca=DeccaConfig(on=False),
        sensors=SensorsConfig(gyro=state("heading"), log=state("water speed"), rudder="n/a",
                              inclinometer="n/a", pressure="n/a",
                              echosounder=state("depth")),
        filter=FilterConfig.from_vessel("surface"),
        nmea=nmea,
        config_dir=config_dir,
    )


def derived_config_lines(cfg: RunConfig) -> list[str]:
    """What a derived configuration says, one line each, for the operator."""
    s = cfg.sensors
    return [
        f"datum {cfg.datum}, GNSS datum {cfg.run_gps_datum}, DR position {cfg.dr_position} "
        "(the first valid fix)",
        f"GPS {'on' if cfg.gps.on else 'off'} ({cfg.gps.receiver}), Decca "
        f"{'on' if cfg.decca.on else 'off'}, filter {'on' if cfg.filter.on else 'off'} "
        f"({cfg.filter.preset} preset, {cfg.filter.vessel} vessel)",
        f"sensors: gyro {s.gyro}, log {s.log}, echo sounder {s.echosounder}",
    ]

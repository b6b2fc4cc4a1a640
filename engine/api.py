"""The engine's public face: everything the console (``uvnav_tui``) may use, in one module.

The user interface imports from here and nowhere else in ``engine`` (checked by
``tests/test_architecture.py``), so the engine's rooms (``io``, ``geodesy``, ``systems``,
``lsq``, ``filter``, ``run``, ``sim``, ``assess``) can be rearranged without touching the UI:
only the import lines below follow a move.

Groups, in the order of a run:

* errors: :class:`InputError` (a located input error) and :func:`read_error`;
* data files and configuration: :class:`RunConfig` and its tables, the datum and Decca chain
  files, :func:`load_config`, :func:`load_run_config`, :func:`load_data`;
* the run: :class:`Session` (one run: ``step``, ``apply``, ``predict``, ``smooth``), the
  operator commands (``Set…``, :class:`AddObservation`), :class:`CycleResult` and the views of
  it that pages show (fix, filter state, confidence regions, Pool of Errors);
* operator input parsing and display formatting (both engine rules: the ``.OUT`` and the
  console must agree);
* headless work: replay outputs, the simulator, the accuracy assessment and the exports
  (GPX, GeoJSON, CSV, KML; docs/EXPORT.md).
* live NMEA sources (:func:`open_live_run`, docs/LIVE.md), imported on first use.

One small function is defined here rather than re-exported: :func:`run_record` (a cycle's
``.RUN`` record, parsed by the run-file reader). The names of the headless assessment,
simulation and export are imported on first use (:func:`__getattr__`), so that a replay and
the console start without them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from engine.errors import InputError, read_error
from engine.filter.kalman import (
    IDEPS,
    IDPSI,
    IDV,
    STATE_LABELS,
    FilterState,
    UpdateResult,
    sensor_measurement,
)
from engine.filter.poe import PoeSample, drms, poe_states
from engine.geodesy.ellipsoid import Ellipsoid
from engine.io.datumfile import DatumFile, read_datum_file
from engine.io.deccafile import DeccaChain
from engine.io.formatting import (
    PLACEHOLDER,
    format_angle_deg,
    format_dms_input,
    format_lat_dm,
    format_lat_dms,
    format_lon_dm,
    format_lon_dms,
    format_metres,
    format_speed_kn,
    format_stat,
    format_time_z,
    format_zone_lane,
)
from engine.io.nmea_epochs import NmeaOptions, NmeaStats
from engine.io.nmea_log import CONVERTED_RUN_MARK, NmeaLog, is_nmea_file
from engine.io.operator_input import (
    ZONE_LETTERS,
    parse_bearing_deg,
    parse_datum_name,
    parse_depth_m,
    parse_direction_deg,
    parse_distance_nm,
    parse_position,
    parse_run_name,
    parse_speed_kn,
    parse_zone_lane,
)
from engine.io.outputs import EXISTS_MESSAGE, OutputFile, OutputGuard, remove_created
from engine.io.runfile import BadRecord, RunRecord, format_run_record, parse_run_line
from engine.io.tomlsource import FILE_NOT_FOUND_MESSAGE, read_text
from engine.lsq.adjustment import Adjustment
from engine.lsq.confidence import Ellipse, Ellipsoid3, error_ellipsoid
from engine.lsq.fix import (
    MAX_BRR,
    FixResult,
    LopRow,
    ManualObservation,
    lop_name,
)
from engine.lsq.statistics import REJECT_BOUND, w_critical
from engine.run.commands import (
    AddObservation,
    Command,
    SetCurrent,
    SetDatum,
    SetDecca,
    SetDRPosition,
    SetFiltering,
    SetGps,
    SetParameters,
    SetSensor,
)
from engine.run.config import (
    DECCA_CF_CONDITIONS,
    CorrectionsConfig,
    DeccaConfig,
    DemoConfig,
    FilterConfig,
    GpsConfig,
    Key,
    LsqConfig,
    NmeaConfig,
    RunConfig,
    SensorsConfig,
    decca_cf_condition,
    load_config,
    pace_factor,
    parse_decca_cf,
)
from engine.run.cycle import CycleResult, PositionEstimate, RunContext
from engine.run.nmea_config import derive_nmea_config, derived_config_lines
from engine.run.records import lse_estimate, position_json
from engine.run.session import RunSummary, Session, load_data, load_run_config, run_inputs
from engine.systems.gps import GpsWeight, quality_name
from engine.systems.registry import SLOT_LABELS, slots_of
from engine.systems.sensors import KNOT_MS, SENSOR_STATUS_WORD, knots_to_ms

if TYPE_CHECKING:
    from engine.assess.accuracy import (
        ESTIMATOR_LABELS,
        ESTIMATORS,
        PHASES,
        Assessment,
        assess,
        read_nav_log,
        read_truth,
    )
    from engine.assess.denied import (
        CHECKPOINTS_S,
        DeniedReport,
        denied_experiment,
        run_records,
        truth_reference,
    )
    from engine.io.export_geo import ELLIPSE_POINTS, Wgs84Converter, build_export
    from engine.io.export_geo import TRACKS as EXPORT_TRACKS
    from engine.io.export_read import (
        align_smoothed,
        logged_datum_file,
        read_export_log,
        read_smoothed,
    )
    from engine.io.export_write import csv_text, geojson_text, gpx_text, kml_text
    from engine.io.live_sources import SourceState, is_source_url, parse_source_url
    from engine.io.nmea_send import NmeaSender, open_nmea_sender, parse_nmea_destination
    from engine.run.live import LEARN_S, LiveCycle, LiveRun, LiveStep, open_live_run
    from engine.run.nmea_out import NmeaOutOptions, NmeaPositionOut
    from engine.sim.scenario import load_scenario
    from engine.sim.simulate import read_data_files, write_simulation

_EXPORT_NAMES = {
    "EXPORT_TRACKS": ("engine.io.export_geo", "TRACKS"),
    "ELLIPSE_POINTS": ("engine.io.export_geo", "ELLIPSE_POINTS"),
    "Wgs84Converter": ("engine.io.export_geo", "Wgs84Converter"),
    "build_export": ("engine.io.export_geo", "build_export"),
    "align_smoothed": ("engine.io.export_read", "align_smoothed"),
    "logged_datum_file": ("engine.io.export_read", "logged_datum_file"),
    "read_export_log": ("engine.io.export_read", "read_export_log"),
    "read_smoothed": ("engine.io.export_read", "read_smoothed"),
    "csv_text": ("engine.io.export_write", "csv_text"),
    "geojson_text": ("engine.io.export_write", "geojson_text"),
    "gpx_text": ("engine.io.export_write", "gpx_text"),
    "kml_text": ("engine.io.export_write", "kml_text"),
}
"""``uvnav export``'s names (docs/EXPORT.md), imported on first use like the assessment's."""
_ASSESS_NAMES = frozenset(
    {"ESTIMATOR_LABELS", "ESTIMATORS", "PHASES", "Assessment", "assess", "read_nav_log",
     "read_truth"})
_DENIED_NAMES = frozenset(
    {"CHECKPOINTS_S", "DeniedReport", "denied_experiment", "run_records", "truth_reference"})
"""``uvnav denied`` (GPS-denied experiment, docs/REALDATA.md), imported on first use."""
_SIMULATE_NAMES = frozenset({"read_data_files", "write_simulation"})
_NMEA_SEND_NAMES = frozenset({"NmeaSender", "open_nmea_sender", "parse_nmea_destination"})
_NMEA_OUT_NAMES = frozenset({"NmeaOutOptions", "NmeaPositionOut"})
_LIVE_RUN_NAMES = frozenset({"LEARN_S", "LiveCycle", "LiveRun", "LiveStep", "open_live_run"})
_LIVE_SOURCE_NAMES = frozenset({"SourceState", "is_source_url", "parse_source_url"})
"""The headless commands' names, imported on first use (:func:`__getattr__`): a replay and the
console never load the assessment or the simulator (start-up time)."""

__all__ = [
    # errors
    "InputError",
    "read_error",
    # data files and configuration
    "DECCA_CF_CONDITIONS",
    "FILE_NOT_FOUND_MESSAGE",
    "CorrectionsConfig",
    "DatumFile",
    "DeccaChain",
    "DeccaConfig",
    "DemoConfig",
    "FilterConfig",
    "GpsConfig",
    "Key",
    "LsqConfig",
    "RunConfig",
    "SensorsConfig",
    "decca_cf_condition",
    "load_config",
    "load_data",
    "load_run_config",
    "pace_factor",
    "parse_decca_cf",
    "read_datum_file",
    "read_text",
    # the run and its commands
    "AddObservation",
    "Command",
    "CycleResult",
    "PositionEstimate",
    "RunContext",
    "RunRecord",
    "BadRecord",
    "Session",
    "SetCurrent",
    "SetDRPosition",
    "SetDatum",
    "SetDecca",
    "SetFiltering",
    "SetGps",
    "SetParameters",
    "SetSensor",
    "lse_estimate",
    "run_record",
    # views of a cycle: fix, statistics, filter, confidence regions, Pool of Errors
    "IDEPS",
    "IDPSI",
    "IDV",
    "KNOT_MS",
    "MAX_BRR",
    "REJECT_BOUND",
    "STATE_LABELS",
    "Adjustment",
    "Ellipse",
    "Ellipsoid3",
    "FilterState",
    "FixResult",
    "LopRow",
    "ManualObservation",
    "PoeSample",
    "UpdateResult",
    "drms",
    "error_ellipsoid",
    "knots_to_ms",
    "SENSOR_STATUS_WORD",
    "SLOT_LABELS",
    "slots_of",
    "lop_name",
    "poe_states",
    "sensor_measurement",
    "w_critical",
    "GpsWeight",
    "quality_name",
    # operator input and display formatting
    "PLACEHOLDER",
    "ZONE_LETTERS",
    "format_angle_deg",
    "format_dms_input",
    "format_lat_dm",
    "format_lat_dms",
    "format_lon_dm",
    "format_lon_dms",
    "format_metres",
    "format_speed_kn",
    "format_stat",
    "format_time_z",
    "format_zone_lane",
    "parse_bearing_deg",
    "parse_datum_name",
    "parse_depth_m",
    "parse_direction_deg",
    "parse_distance_nm",
    "parse_position",
    "parse_run_name",
    "parse_speed_kn",
    "parse_zone_lane",
    # headless work: replay outputs, simulation, assessment
    "ESTIMATORS",
    "ESTIMATOR_LABELS",
    "EXISTS_MESSAGE",
    "PHASES",
    "Assessment",
    "Ellipsoid",
    "OutputFile",
    "OutputGuard",
    "RunSummary",
    "assess",
    "load_scenario",
    "position_json",
    "read_data_files",
    "read_nav_log",
    "read_truth",
    "remove_created",
    "run_inputs",
    "write_simulation",
    # NMEA 0183 out of the integrated position (docs/NMEA_OUT.md)
    "NmeaOutOptions",
    "NmeaPositionOut",
    "NmeaSender",
    "open_nmea_sender",
    "parse_nmea_destination",
    # live NMEA sources (docs/LIVE.md), imported on first use
    "LEARN_S",
    "LiveCycle",
    "LiveRun",
    "LiveStep",
    "SourceState",
    "is_source_url",
    "open_live_run",
    "parse_source_url",
    # NMEA 0183 logs as run input (docs/NMEA.md)
    "BadRecord",
    "NmeaConfig",
    "NmeaLog",
    "NmeaOptions",
    "NmeaStats",
    "derive_nmea_config",
    "derived_config_lines",
    "format_run_record",
    "is_nmea_file",
    "CONVERTED_RUN_MARK",
    # headless work: exports (uvnav export, imported on first use)
    "ELLIPSE_POINTS",
    "EXPORT_TRACKS",
    "Wgs84Converter",
    "align_smoothed",
    "build_export",
    "csv_text",
    "geojson_text",
    "gpx_text",
    "kml_text",
    "logged_datum_file",
    "read_export_log",
    "read_smoothed",
    # GPS-denied experiment (uvnav denied)
    "CHECKPOINTS_S",
    "DeniedReport",
    "denied_experiment",
    "run_records",
    "truth_reference",
]


def run_record(r: CycleResult) -> RunRecord | None:
    """The ``.RUN`` record of cycle ``r`` as the run-file reader parses it (raw sensor values
    before conversion); None if the line cannot be parsed."""
    try:
        return parse_run_line(r.raw, r.record)
    except (InputError, ValueError, IndexError):
        return None


def __getattr__(name: str) -> object:
    """The assessment's and the simulator's names (PEP 562), imported when first asked for."""
    if name in _EXPORT_NAMES:
        import importlib

        module, attr = _EXPORT_NAMES[name]
        return getattr(importlib.import_module(module), attr)
    if name in _ASSESS_NAMES:
        from engine.assess import accuracy

        return getattr(accuracy, name)
    if name in _DENIED_NAMES:
        from engine.assess import denied

        return getattr(denied, name)
    if name == "load_scenario":
        from engine.sim.scenario import load_scenario

        return load_scenario
    if name in _SIMULATE_NAMES:
        from engine.sim import simulate

        return getattr(simulate, name)
    if name in _NMEA_SEND_NAMES:
        from engine.io import nmea_send

        return getattr(nmea_send, name)
    if name in _NMEA_OUT_NAMES:
        from engine.run import nmea_out

        return getattr(nmea_out, name)
    if name in _LIVE_RUN_NAMES:
        from engine.run import live

        return getattr(live, name)
    if name in _LIVE_SOURCE_NAMES:
        from engine.io import live_sources

        return getattr(live_sources, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_ASSESS_NAMES, *_DENIED_NAMES, *_SIMULATE_NAMES, *_EXPORT_NAMES,
                   *_NMEA_SEND_NAMES, *_NMEA_OUT_NAMES, "load_scenario", *_LIVE_RUN_NAMES,
                   *_LIVE_SOURCE_NAMES})

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
``.RUN`` record, parsed by the run-file reader). Only the configuration, the data files and
the text rules are imported with this module; the names of the run itself (the session, the
cycle, the filter, the fix: NumPy) and of the headless assessment, simulation and export are
imported on first use (:func:`__getattr__`, :data:`_LAZY_MODULES`), so that the console paints
its first frame before NumPy loads and a replay starts without the headless commands.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from engine.errors import InputError, read_error
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
from engine.io.operator_input import (
    ZONE_LETTERS,
    parse_bearing_deg,
    parse_datum_name,
    parse_depth_m,
    parse_direction_deg,
    parse_distance_nm,
    parse_plain_number,
    parse_position,
    parse_run_name,
    parse_speed_kn,
    parse_zone_lane,
)
from engine.io.outputs import EXISTS_MESSAGE, OutputFile, OutputGuard, remove_created
from engine.io.tomlsource import FILE_NOT_FOUND_MESSAGE, read_text
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
from engine.run.setup import load_data, load_run_config, run_inputs
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
        clean_records,
        denied_experiment,
        run_records,
        truth_reference,
    )
    from engine.campaign import (
        CHANGED_SPEC_MESSAGE,
        COLUMNS,
        SINCE_FIX_BINS_MIN,
        SUMMARY_COLUMNS,
        TIMING_COLUMNS,
        CampaignSpec,
        CampaignStore,
        RunTask,
        blank_row,
        load_campaign,
        read_table,
        run_one,
        since_fix_column,
        summary_markdown,
        variant_arrays,
    )
    from engine.filter.adapt import AdaptState
    from engine.filter.explain import added_process_noise, update_matrices
    from engine.filter.horizon import DrAdaptState
    from engine.filter.kalman import (
        IDEPS,
        IDPSI,
        IDV,
        STATE_LABELS,
        FilterState,
        UpdateResult,
        sensor_measurement,
    )
    from engine.filter.motion import MotionState
    from engine.filter.poe import PoeSample, drms, poe_states
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
    from engine.io.nmea_epochs import NmeaOptions, NmeaStats
    from engine.io.nmea_log import (
        CONVERTED_RUN_MARK,
        LogSniff,
        NmeaLog,
        is_nmea_file,
        not_nmea_message,
        sniff_log,
    )
    from engine.io.nmea_send import NmeaSender, open_nmea_sender, parse_nmea_destination
    from engine.io.runfile import BadRecord, RunRecord, format_run_record
    from engine.lsq.adjustment import Adjustment
    from engine.lsq.confidence import Ellipse, Ellipsoid3, error_ellipsoid
    from engine.lsq.fix import MAX_BRR, FixResult, LopRow, ManualObservation, lop_name
    from engine.lsq.statistics import REJECT_BOUND, w_critical
    from engine.native import PURE_ENV
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
    from engine.run.cycle import CycleResult, PositionEstimate, RunContext
    from engine.run.kernels import kernel_report
    from engine.run.live import (
        LEARN_S,
        LiveCycle,
        LiveRun,
        LiveStep,
        NoFixInTime,
        open_live_run,
    )
    from engine.run.nmea_config import derive_nmea_config, derived_config_lines
    from engine.run.nmea_out import NmeaOutOptions, NmeaPositionOut
    from engine.run.records import lse_estimate, position_json
    from engine.run.session import RunSummary, Session
    from engine.sim.sampler import SamplerError, SamplerOptions, draw_mission
    from engine.sim.scenario import load_scenario
    from engine.sim.simulate import read_data_files, write_simulation
    from engine.systems.gps import GpsWeight, quality_name
    from engine.systems.registry import SLOT_LABELS, slots_of

_LAZY_MODULES: dict[str, tuple[str, ...]] = {
    # the run: NumPy, the filter, the fix, the NMEA reader (pynmea2)
    "engine.filter.adapt": ("AdaptState",),
    "engine.filter.horizon": ("DrAdaptState",),
    "engine.filter.motion": ("MotionState",),
    "engine.filter.kalman": ("IDEPS", "IDPSI", "IDV", "STATE_LABELS", "FilterState",
                             "UpdateResult", "sensor_measurement"),
    "engine.filter.poe": ("PoeSample", "drms", "poe_states"),
    "engine.filter.explain": ("added_process_noise", "update_matrices"),
    "engine.io.nmea_epochs": ("NmeaOptions", "NmeaStats"),
    "engine.io.nmea_log": ("CONVERTED_RUN_MARK", "LogSniff", "NmeaLog", "is_nmea_file",
                           "not_nmea_message", "sniff_log"),
    # the .RUN reader (the console's first paint does not read records)
    "engine.io.runfile": ("BadRecord", "RunRecord", "format_run_record", "parse_run_line"),
    "engine.lsq.adjustment": ("Adjustment",),
    "engine.lsq.confidence": ("Ellipse", "Ellipsoid3", "error_ellipsoid"),
    "engine.lsq.fix": ("MAX_BRR", "FixResult", "LopRow", "ManualObservation", "lop_name"),
    "engine.lsq.statistics": ("REJECT_BOUND", "w_critical"),
    "engine.run.commands": ("AddObservation", "Command", "SetCurrent", "SetDatum", "SetDecca",
                            "SetDRPosition", "SetFiltering", "SetGps", "SetParameters",
                            "SetSensor"),
    "engine.run.cycle": ("CycleResult", "PositionEstimate", "RunContext"),
    "engine.run.nmea_config": ("derive_nmea_config", "derived_config_lines"),
    "engine.run.records": ("lse_estimate", "position_json"),
    "engine.run.session": ("RunSummary", "Session"),
    "engine.systems.gps": ("GpsWeight", "quality_name"),
    "engine.systems.registry": ("SLOT_LABELS", "slots_of"),
    # headless work: assessment, GPS-denied experiment, simulation, NMEA out, live sources
    "engine.assess.accuracy": ("ESTIMATOR_LABELS", "ESTIMATORS", "PHASES", "Assessment",
                               "assess", "read_nav_log", "read_truth"),
    "engine.assess.denied": ("CHECKPOINTS_S", "DeniedReport", "clean_records",
                             "denied_experiment", "run_records", "truth_reference"),
    "engine.sim.scenario": ("load_scenario",),
    "engine.sim.sampler": ("SamplerError", "SamplerOptions", "draw_mission"),
    "engine.native": ("PURE_ENV",),
    "engine.run.kernels": ("kernel_report",),
    "engine.sim.simulate": ("read_data_files", "write_simulation"),
    "engine.io.nmea_send": ("NmeaSender", "open_nmea_sender", "parse_nmea_destination"),
    "engine.run.nmea_out": ("NmeaOutOptions", "NmeaPositionOut"),
    "engine.run.live": ("LEARN_S", "LiveCycle", "LiveRun", "LiveStep", "NoFixInTime",
                        "open_live_run"),
    "engine.io.live_sources": ("SourceState", "is_source_url", "parse_source_url"),
    # uvnav export (docs/EXPORT.md)
    "engine.io.export_geo": ("ELLIPSE_POINTS", "Wgs84Converter", "build_export"),
    "engine.io.export_read": ("align_smoothed", "logged_datum_file", "read_export_log",
                              "read_smoothed"),
    "engine.io.export_write": ("csv_text", "geojson_text", "gpx_text", "kml_text"),
    # uvnav campaign (docs/CAMPAIGN.md)
    "engine.campaign": ("CHANGED_SPEC_MESSAGE", "COLUMNS", "SINCE_FIX_BINS_MIN",
                        "SUMMARY_COLUMNS", "TIMING_COLUMNS", "CampaignSpec", "CampaignStore",
                        "RunTask", "blank_row", "load_campaign", "read_table", "run_one",
                        "since_fix_column", "summary_markdown", "variant_arrays"),
}
"""The modules whose names are imported on first use (:func:`__getattr__`), with those names:
everything a cycle computes (NumPy and the numeric engine) and the headless commands. The
console's first paint (the Parameter Initialization dialog) needs only the configuration, the
data files and the text rules imported above (issue 14, start-up time)."""
_LAZY: dict[str, tuple[str, str]] = {
    name: (module, name) for module, names in _LAZY_MODULES.items() for name in names}
_LAZY["EXPORT_TRACKS"] = ("engine.io.export_geo", "TRACKS")
"""Name here → (module, name there)."""

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
    "AdaptState",
    "DrAdaptState",
    "MotionState",
    "FixResult",
    "LopRow",
    "ManualObservation",
    "PoeSample",
    "UpdateResult",
    "added_process_noise",
    "drms",
    "error_ellipsoid",
    "knots_to_ms",
    "SENSOR_STATUS_WORD",
    "SLOT_LABELS",
    "slots_of",
    "lop_name",
    "poe_states",
    "update_matrices",
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
    "parse_plain_number",
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
    "SamplerError",
    "SamplerOptions",
    "draw_mission",
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
    # the compiled kernels (engine/native, docs/PERFORMANCE.md): which are in use
    "PURE_ENV",
    "kernel_report",
    # live NMEA sources (docs/LIVE.md), imported on first use
    "LEARN_S",
    "LiveCycle",
    "LiveRun",
    "LiveStep",
    "NoFixInTime",
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
    "LogSniff",
    "not_nmea_message",
    "sniff_log",
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
    "clean_records",
    "denied_experiment",
    "run_records",
    "truth_reference",
    # campaigns (uvnav campaign, docs/CAMPAIGN.md), imported on first use
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


def run_record(r: CycleResult) -> RunRecord | None:
    """The ``.RUN`` record of cycle ``r`` as the run-file reader parses it (raw sensor values
    before conversion); None if the line cannot be parsed."""
    from engine.io.runfile import parse_run_line

    try:
        return parse_run_line(r.raw, r.record)
    except (InputError, ValueError, IndexError):
        return None


def __getattr__(name: str) -> object:
    """A name of :data:`_LAZY_MODULES` (PEP 562), imported when first asked for and kept."""
    try:
        module, attr = _LAZY[name]
    except KeyError:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
    import importlib

    value = getattr(importlib.import_module(module), attr)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})

"""``uvnav export``: a replayed run's tracks as GPX, GeoJSON, CSV and KML (docs/EXPORT.md).

``uvnav export RUN.OUT|RUN.jsonl [--gpx FILE] [--geojson FILE] [--csv FILE] [--kml FILE]
[--tracks mpp,lse,gps,smoothed] [--smoothed FILE] [--datum-file TO_WGS84.DAT]
[--ellipse-points N] [--force]``: at least one output. Positions are converted from the run's
working datum to WGS84 with the run's own datum file (the ``.OUT`` log's ``data_dir``, or
``--datum-file``; JSON lines embed no configuration).

Outputs follow the ``.OUT`` rule (engine/io/outputs.py): never an input, never overwritten (a
free ``NAME_N`` is chosen), ``--force`` replaces only an earlier export of the same format.

Exit status: 0 written; 1 an output cannot be written (named); 2 bad input or a refused output
name, nothing written; 130 interrupted (Ctrl-C).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from engine.api import (
    ELLIPSE_POINTS,
    EXPORT_TRACKS,
    InputError,
    OutputGuard,
    Wgs84Converter,
    align_smoothed,
    build_export,
    csv_text,
    geojson_text,
    gpx_text,
    kml_text,
    logged_datum_file,
    read_datum_file,
    read_export_log,
    read_smoothed,
)

EXIT_OK = 0
EXIT_CANNOT_WRITE = 1
EXIT_BAD_INPUT = 2
FORMATS = ("gpx", "geojson", "csv", "kml")
"""Output options, in the order they are written; each is also its OutputGuard kind."""
WRITERS = {"gpx": gpx_text, "geojson": geojson_text, "csv": csv_text, "kml": kml_text}


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``uvnav export``."""
    p = argparse.ArgumentParser(prog="uvnav export", description=__doc__.splitlines()[0])
    p.add_argument("log", help=".OUT log or --jsonl file of a replay")
    p.add_argument("--gpx", metavar="FILE", help="GPX 1.1: one track per --tracks entry")
    p.add_argument("--geojson", metavar="FILE", help="GeoJSON (RFC 7946): a LineString per "
                   "track and per cycle the 95%% error ellipse as a Polygon with properties")
    p.add_argument("--csv", metavar="FILE", help="CSV: one row per cycle")
    p.add_argument("--kml", metavar="FILE", help="KML 2.2: a LineString per track")
    p.add_argument("--tracks", default=None, metavar="LIST",
                   help="comma-separated tracks: " + ", ".join(EXPORT_TRACKS)
                   + " (default mpp, plus smoothed with --smoothed)")
    p.add_argument("--smoothed", metavar="FILE",
                   help="smoothed positions of the same run (uvnav replay --smooth)")
    p.add_argument("--datum-file", metavar="FILE",
                   help="TO_WGS84.DAT of the run (default: the .OUT log's data_dir)")
    p.add_argument("--ellipse-points", type=int, default=ELLIPSE_POINTS, metavar="N",
                   help=f"vertices of an ellipse polygon, 8 to 720 (default {ELLIPSE_POINTS})")
    p.add_argument("--force", action="store_true",
                   help="replace earlier exports (never an input, never another file)")
    return p


def _tracks(option: str | None, smoothed: bool) -> list[str]:
    if option is None:
        return ["mpp", "smoothed"] if smoothed else ["mpp"]
    names = [t.strip().lower() for t in option.split(",") if t.strip()]
    for t in names:
        if t not in EXPORT_TRACKS:
            raise InputError(f"Unknown track (one of {', '.join(EXPORT_TRACKS)}) !",
                             field="--tracks", text=t)
    if not names:
        raise InputError("No track given !", field="--tracks", text=option)
    if "smoothed" in names and not smoothed:
        raise InputError("The smoothed track needs --smoothed FILE !", field="--tracks",
                         text=option)
    return list(dict.fromkeys(names))


def run_export(argv: list[str]) -> int:
    """Entry point of ``uvnav export``; returns the exit status (module docstring)."""
    args = build_parser().parse_args(argv)
    outputs = [(fmt, getattr(args, fmt)) for fmt in FORMATS if getattr(args, fmt)]
    try:
        if not outputs:
            raise InputError("Nothing to write: give --gpx, --geojson, --csv or --kml FILE !",
                             field="output")
        if not 8 <= args.ellipse_points <= 720:
            raise InputError("Must be between 8 and 720 !", field="--ellipse-points",
                             text=str(args.ellipse_points))
        tracks = _tracks(args.tracks, args.smoothed is not None)
        guard = OutputGuard()
        guard.protect_all([("the log", args.log), ("--smoothed", args.smoothed)])
        for fmt, path in outputs:  # refused names fail before the log is read
            guard.check(path, f"--{fmt}", kind=fmt, force=args.force)
        log = read_export_log(args.log)
        smoothed = None
        notes = list(log.problems)
        if args.smoothed is not None:
            points, problems = read_smoothed(args.smoothed)
            notes += problems
            smoothed = align_smoothed(log.epochs, points, args.smoothed)
        datum_file = (Path(args.datum_file) if args.datum_file is not None
                      else logged_datum_file(log))
        datums = read_datum_file(datum_file) if datum_file is not None else None
        guard.protect("the datum file", datum_file)
        for fmt, path in outputs:  # again: the datum file is known now
            guard.check(path, f"--{fmt}", kind=fmt, force=args.force)
        converter = Wgs84Converter(datums, None if datum_file is None else str(datum_file))
        data = build_export(log, tracks, converter, smoothed, args.ellipse_points)
        texts = [(fmt, path, WRITERS[fmt](data)) for fmt, path in outputs]
    except InputError as exc:
        print(f"uvnav export: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    for note in notes:
        print(f"uvnav export: warning: {note}", file=sys.stderr)
    for t in tracks:
        if all(p is None for p in data.tracks[t]):
            why = " (JSON lines carry no GPS input: export the .OUT log)" if (
                t == "gps" and log.kind == "jsonl") else ""
            print(f"uvnav export: warning: {t}: no point in this log{why}", file=sys.stderr)
        lost = sum(p is not None and p.a95_m is not None and p.ring is None
                   for p in data.tracks[t])
        if lost:
            print(f"uvnav export: warning: {t}: {lost} ellipses left out (the logged grid "
                  "position does not match the logged latitude/longitude on any nearby CM)",
                  file=sys.stderr)
    # The files first, the report after: a report that cannot be printed (its reader gone,
    # uvnav_tui/cli/stdout.py) does not cost the files.
    written: list[tuple[str, Path]] = []
    for fmt, path, text in texts:
        fh = None
        try:
            with guard.open(path, label=f"--{fmt}", kind=fmt, force=args.force) as fh:
                fh.write(text)
                fh.close(sync=True)
            written.append((fmt, fh.path))
        except InputError as exc:
            print(f"uvnav export: {exc}", file=sys.stderr)
            return EXIT_BAD_INPUT
        except OSError as exc:
            # A cut GeoJSON, GPX or KML is not a file any reader takes: removed, not left.
            if fh is not None:
                fh.path.unlink(missing_ok=True)
            print(f"uvnav export: {exc.filename or path}: cannot write: "
                  f"{exc.strerror or exc} !" + (" (the incomplete file removed)"
                                                 if fh is not None else ""), file=sys.stderr)
            return EXIT_CANNOT_WRITE
    print(f"cycles {len(log.epochs)}  bad records {log.bad_records}  tracks "
          + " ".join(f"{t} {sum(p is not None for p in data.tracks[t])}" for t in tracks))
    print("datum " + ", ".join(data.datums) + " -> WGS84"
          + (f" ({datum_file})" if datum_file is not None else ""))
    for fmt, done in written:
        print(f"{fmt} {done}")
    return EXIT_OK

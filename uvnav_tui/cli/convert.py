"""``uvnav convert LOG --out X.RUN``: write the ``.RUN`` equivalent of an NMEA 0183 log.

Each epoch of the log (docs/NMEA.md "Epochs") becomes one ``.RUN`` line, exactly the record a
replay of the log processes (GNSS HDOP, fix quality, satellites, course and speed over ground as
``key=value`` tokens), so replaying the log and the converted file give the same cycles. The
file starts with ``*`` comment lines naming the log and ends with the report (sentences used
and skipped per kind, events with file:line, sensors the log lacks) as comments too.

The output follows the ``.OUT`` rule (engine/io/outputs.py): never an input, an existing file is
kept (a free ``NAME_N.RUN`` is chosen), ``--force`` replaces only an earlier ``.RUN``.

Exit status: 0 written (at least one epoch); 1 the output cannot be written; 2 bad input (not
an NMEA log, unreadable, bad options or configuration); 3 the log gave no epoch (the file is
written with its report).
"""

from __future__ import annotations

import argparse
import sys
from datetime import date
from pathlib import Path

from engine.api import (
    CONVERTED_RUN_MARK,
    BadRecord,
    InputError,
    NmeaLog,
    NmeaOptions,
    OutputFile,
    OutputGuard,
    load_config,
    not_nmea_message,
    read_error,
    remove_created,
    sniff_log,
)

EXIT_OK = 0
EXIT_CANNOT_WRITE = 1
EXIT_BAD_INPUT = 2
EXIT_NO_EPOCH = 3
BAD_SHOWN = 10
"""Damaged lines printed on stderr (all are counted in the report)."""


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``uvnav convert``."""
    p = argparse.ArgumentParser(prog="uvnav convert", description=__doc__.splitlines()[0])
    p.add_argument("log", help="NMEA 0183 log (recognised by its content)")
    p.add_argument("--out", required=True, help=".RUN file to write (an existing file is kept: "
                   "a free NAME_N.RUN is chosen)")
    p.add_argument("--config", help="run configuration TOML whose [nmea] table is used")
    p.add_argument("--date", help="UTC date YYYY-MM-DD of a log that starts without RMC/ZDA "
                   "(overrides nmea.date)")
    p.add_argument("--interval", type=int, help="epoch interval in whole seconds (overrides "
                   "nmea.interval_s)")
    p.add_argument("--force", action="store_true",
                   help="replace an earlier .RUN output (never an input, never another file)")
    return p


def _options(args: argparse.Namespace) -> NmeaOptions:
    """The NMEA options: the configuration's ``[nmea]`` table, then the command-line flags."""
    base = load_config(args.config).nmea.options if args.config else NmeaOptions()
    changes: dict[str, object] = {}
    if args.date is not None:
        try:
            changes["date"] = date.fromisoformat(args.date)
        except ValueError:
            raise InputError("Must be a date YYYY-MM-DD !", field="--date",
                             text=args.date) from None
    if args.interval is not None:
        changes["interval_s"] = args.interval
    if not changes:
        return base
    try:
        return NmeaOptions(**{**base.__dict__, **changes})  # type: ignore[arg-type]
    except InputError as exc:
        field = {"nmea.interval_s": "--interval"}.get(exc.field or "", exc.field)
        raise InputError(exc.message, field=field, text=exc.text) from None


def _check_log(log: Path) -> None:
    try:
        with open(log, "rb"):
            pass
    except OSError as exc:
        raise read_error(exc, str(log)) from None
    sniff = sniff_log(log)
    if not sniff.nmea:
        raise InputError(not_nmea_message(sniff), file=str(log))


def run_convert(argv: list[str]) -> int:
    """Entry point of ``uvnav convert``; returns the exit status (module docstring)."""
    args = build_parser().parse_args(argv)
    log_path = Path(args.log)
    fh: OutputFile | None = None
    try:
        options = _options(args)
        _check_log(log_path)
        log = NmeaLog(log_path, options)
        guard = OutputGuard()
        guard.protect_all([("the NMEA log", log_path),
                           ("the configuration", Path(args.config) if args.config else None)])
        fh = guard.open(Path(args.out), label="--out", kind="run", force=args.force)
    except InputError as exc:
        print(f"uvnav convert: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as exc:
        print(f"uvnav convert: {exc.filename or args.out}: cannot write: "
              f"{exc.strerror or exc} !", file=sys.stderr)
        return EXIT_CANNOT_WRITE
    epochs = 0
    shown = 0
    try:
        fh.write(f"{CONVERTED_RUN_MARK} {_comment(str(log_path))} "
                 "(uvnav convert, docs/NMEA.md)\n")
        for item in log:
            if isinstance(item, BadRecord):
                if shown < BAD_SHOWN:
                    print(f"skipped: {item.error}", file=sys.stderr)
                shown += 1
                continue
            fh.write(item.raw + "\n")
            epochs += 1
        for line in log.stats.summary_lines():
            fh.write(f"* {_comment(line)}\n")
        fh.close(sync=True)
    except OSError as exc:
        remove_created([fh], args.force)
        print(f"uvnav convert: {exc.filename or fh.path}: cannot write: {exc.strerror or exc} !",
              file=sys.stderr)
        return EXIT_CANNOT_WRITE
    if shown > BAD_SHOWN:
        print(f"skipped: … and {shown - BAD_SHOWN} more damaged lines shown in the report",
              file=sys.stderr)
    for line in log.stats.summary_lines():
        print(f"nmea: {line}")
    print(f"wrote {epochs} records to {fh.path}")
    if epochs == 0:
        print(f"uvnav convert: {log_path}: no epoch in the log !", file=sys.stderr)
        return EXIT_NO_EPOCH
    return EXIT_OK


def _comment(text: str) -> str:
    """``text`` on one comment line (control characters escaped)."""
    return "".join(ch if ch.isprintable() else repr(ch)[1:-1] for ch in text)


if __name__ == "__main__":
    raise SystemExit(run_convert(sys.argv[1:]))

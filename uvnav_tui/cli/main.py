"""Command line entry point ``uvnav``.

``uvnav [--config FILE.toml]`` opens the console; sub-commands: ``replay`` (headless run),
``simulate`` (generate a .RUN from a scenario), ``script`` (scripted console tour),
``assess`` (accuracy against truth), ``convert`` (an NMEA 0183 log to its .RUN
equivalent), ``export`` (GPX, GeoJSON, CSV, KML), ``denied`` (GPS-denied experiment),
``live`` (headless run on a live NMEA source), ``campaign`` (many simulate → replay → assess
runs on Dask).  Ctrl-C in a sub-command prints one line and
exits 130 (a replay's logs keep every completed cycle; a simulation writes nothing).  Each
sub-command lives in its own module and is imported only when used, so ``uvnav replay`` never
loads Textual.
"""

from __future__ import annotations

import gc
import importlib
import os
import sys

from uvnav_tui.cli.stdout import (
    StdoutFailed,
    guarded_stdout,
    literal_stderr,
    silence_stdout,
)

# One OpenBLAS thread (numpy's and SciPy's bundled OpenBLAS read this when they load): every
# matrix of the engine is at most 13×13, below the sizes at which OpenBLAS splits a routine
# between threads, so the results are the same bits; but with a thread pool each library starts
# helper threads that spin, waiting for work, for a while after it loads (numpy's import, the
# kernels' first BLAS binding), taking a core from the start-up on a small machine (uvnav
# replay of the thesis sample: -0.08 to -0.12 s wall, bench/bench_startup.py). A value set by
# the user is kept.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

SUBCOMMANDS = {
    "replay": ("uvnav_tui.cli.replay", "run_replay"),
    "simulate": ("uvnav_tui.cli.simulate", "run_simulate"),
    "script": ("uvnav_tui.cli.script", "run_script"),
    "assess": ("uvnav_tui.cli.assess", "run_assess"),
    "convert": ("uvnav_tui.cli.convert", "run_convert"),
    "export": ("uvnav_tui.cli.export", "run_export"),
    "denied": ("uvnav_tui.cli.denied", "run_denied"),
    "live": ("uvnav_tui.cli.live", "run_live"),
    "campaign": ("uvnav_tui.cli.campaign", "run_campaign"),
}

EXIT_INTERRUPTED = 130
"""Exit status after Ctrl-C (128 + SIGINT, as a shell reports it)."""
INTERRUPTED_NOTE = {
    "replay": "; the logs keep every cycle completed before it",
    "simulate": "; nothing written",
    "convert": "; the .RUN keeps the records written before it",
    "live": "; the logs keep every cycle completed and every line received before it",
    "export": "; the file being written may be incomplete",
    "campaign": "; runs.parquet holds every run finished before it (rerun to finish)",
}
"""What is left on disk after Ctrl-C, per sub-command."""

USAGE = """usage: uvnav --version                                    version and compiled kernels
       uvnav [--config FILE.toml] [--dev] [--hardcopy-dir DIR]   open the console
                    [--nmea-out udp://HOST:PORT] [--live URL]
       uvnav replay RUN_or_NMEA_LOG [--config TOML] [--out FILE.OUT | --no-out] [--jsonl FILE]
                        [--smooth [FILE]] [--force] [--nmea-out udp://HOST:PORT|FILE]
                        [--date YYYY-MM-DD] [--lop-reject Y|N] [--cog-sog]
       uvnav simulate SCENARIO.toml --out NAME.RUN [--truth NAME.truth.csv] [--seed N]
                      [--nmea NAME.nmea]
       uvnav script FILE [--headless]
       uvnav assess OUT_or_JSONL TRUTH.csv [--svg FILE] [--phases auto|none] [--poe-rate M_H]
       uvnav convert NMEA_LOG --out NAME.RUN [--config TOML] [--date YYYY-MM-DD]
                     [--interval S] [--force]
       uvnav export OUT_or_JSONL [--gpx F] [--geojson F] [--csv F] [--kml F]
                    [--tracks mpp,lse,gps,smoothed] [--smoothed F] [--datum-file F] [--force]
       uvnav denied RUN [--config TOML] [--window S ...] [--start T ...] [--every S]
                        [--warmup S] [--checkpoint S ...] [--truth CSV] [--cog-sog] [--windows]
                        [--markdown]
       uvnav live URL [--config TOML] [--out FILE.OUT | --no-out] [--jsonl FILE] [--force]
                      [--cycles N] [--seconds S] [--learn S] [--quiet]   (URL: udp://0.0.0.0:10110,
                      tcp://HOST:10110, gpsd://HOST:2947, serial:///dev/ttyUSB0?baud=4800)
       uvnav campaign SPEC.toml --out DIR [--workers N] [--scheduler tcp://HOST:8786]
                      [--resume | --restart]   (many simulate/replay/assess runs on Dask)
"""


def _import_quietly(module: str) -> object:
    """Import ``module`` with the cyclic garbage collector paused, then freeze what the
    imports made (start-up time: the collector otherwise scans the tens of thousands of
    long-lived objects that NumPy, Textual and the engine create while they load, several
    times over). Nothing is collected later that could have been collected here: module-level
    objects live as long as the process."""
    gc.disable()
    try:
        return importlib.import_module(module)
    finally:
        gc.freeze()
        gc.enable()


def version_text() -> str:
    """``uvnav --version``: the package version and, per compiled kernel (engine/native), whether
    it is in use ("compiled") or why the engine runs that part in Python (the reference, which
    the compiled path agrees with within the tolerance contract of docs/PERFORMANCE.md)."""
    from importlib.metadata import PackageNotFoundError, version

    from engine.api import kernel_report

    try:
        v = version("uvnav")
    except PackageNotFoundError:
        v = "(not installed)"
    kernels = "\n".join(f"  {n}: {why}" for n, why in kernel_report()) or "  none"
    return f"uvnav {v}\ncompiled kernels (engine/native, docs/PERFORMANCE.md):\n{kernels}"


EXIT_CANNOT_WRITE = 1
"""Exit status when standard output (or an output file) cannot be written."""
EXIT_BROKEN_PIPE = 128 + 13
"""Exit status when standard output's reader went away (as a process killed by SIGPIPE)."""


def main(argv: list[str] | None = None) -> int:
    """Dispatch to the sub-command (or the console); returns the exit status. A headless
    command's standard output is guarded (uvnav_tui/cli/stdout.py): when its reader closes
    early (``uvnav --help | head -3``) the command ends quietly with :data:`EXIT_BROKEN_PIPE`,
    and when it cannot be written otherwise (``> /dev/full``) with one line naming standard
    output and :data:`EXIT_CANNOT_WRITE`, never a traceback; files the command writes (``.OUT``)
    are closed by the command as on any error."""
    args = list(sys.argv[1:] if argv is None else argv)
    command = args[0] if args and args[0] in SUBCOMMANDS else None
    headless = command is not None or (bool(args) and args[0] in ("-h", "--help", "--version"))
    try:
        if not headless:  # the console draws on its own terminal stream (Textual's driver)
            return _dispatch(args)
        with guarded_stdout(), literal_stderr():
            return _dispatch(args)
    except StdoutFailed as exc:
        silence_stdout()
        if isinstance(exc.error, BrokenPipeError):
            return EXIT_BROKEN_PIPE
        name = "uvnav" if command is None else f"uvnav {command}"
        print(f"{name}: standard output: cannot write: {exc.error.strerror or exc.error} !",
              file=sys.stderr)
        return EXIT_CANNOT_WRITE
    except BrokenPipeError:
        silence_stdout()
        return EXIT_BROKEN_PIPE


def _dispatch(args: list[str]) -> int:
    """:func:`main` without its standard-output handling."""
    if args and args[0] in ("-h", "--help"):
        print(USAGE)
        return 0
    if args and args[0] == "--version":
        print(version_text())
        return 0
    if args and args[0] in SUBCOMMANDS:
        module, func = SUBCOMMANDS[args[0]]
        try:
            mod = _import_quietly(module)
        except ModuleNotFoundError as exc:
            if exc.name != module:
                raise
            print(f"uvnav {args[0]}: not available in this build", file=sys.stderr)
            return 2
        try:
            return int(getattr(mod, func)(args[1:]))
        except KeyboardInterrupt:
            print(f"uvnav {args[0]}: interrupted (Ctrl-C){INTERRUPTED_NOTE.get(args[0], '')}",
                  file=sys.stderr)
            return EXIT_INTERRUPTED
    try:
        mod = _import_quietly("uvnav_tui.cli.console")
    except ModuleNotFoundError as exc:
        if exc.name != "uvnav_tui.cli.console":
            raise
        print("uvnav: the console is not available in this build", file=sys.stderr)
        return 2
    return int(mod.run_console(args))


if __name__ == "__main__":
    raise SystemExit(main())

"""``uvnav [--config FILE.toml] [--dev] [--live URL] [--nmea-out udp://HOST:PORT]``: open the
navigation console.

``--live URL`` runs on a live NMEA source instead of the configuration's run file
(docs/LIVE.md). ``--nmea-out`` sends the MPP of every cycle as NMEA 0183 to a UDP port
(docs/NMEA_OUT.md), e.g. to OpenCPN on the same machine: ``--nmea-out udp://127.0.0.1:10110``.

Without ``--config`` the demo ``data/DEMO.toml`` is used: first ``./data/DEMO.toml`` of the
current directory, then the one bundled next to the installed package. The console names the
configuration it uses on its message line at start. Each run's ``.OUT`` goes to ``--out-dir``
if given, else beside the run file when that folder is writable, else to the current directory;
the bundled demo's always to the current directory (never into the install tree). Bad input is
reported with file, line and field and exit status 2, never a traceback.
"""

from __future__ import annotations

import argparse
import gc
import sys
from pathlib import Path

from engine.api import (
    DatumFile,
    DeccaChain,
    InputError,
    RunConfig,
    load_run_config,
)

DEFAULT_CONFIG_NAME = "DEMO.toml"


BUNDLED_DATA = Path(__file__).resolve().parents[2] / "data"
"""The ``data`` directory next to the installed package (the repository checkout's)."""


def default_config_path() -> Path | None:
    """The demo configuration: ``./data/DEMO.toml`` of the current directory, else the bundled
    one; None if neither exists."""
    candidates = [
        Path.cwd() / "data" / DEFAULT_CONFIG_NAME,
        BUNDLED_DATA / DEFAULT_CONFIG_NAME,
    ]
    for path in candidates:
        if path.is_file():
            return path.resolve()
    return None


def console_out_dir(config_path: Path | None, out_dir: str | None) -> Path | None:
    """Where the console writes the ``.OUT`` logs: ``--out-dir`` if given; the current
    directory for the bundled demo used from outside the checkout it belongs to (never the
    install tree); else None, beside each run file when its folder is writable
    (:func:`uvnav_tui.run_control.out_folder`)."""
    if out_dir is not None:
        return Path(out_dir)
    if config_path is not None and config_path.parent == BUNDLED_DATA \
            and Path.cwd().resolve() != BUNDLED_DATA.parent:
        return Path.cwd()
    return None


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the console command."""
    p = argparse.ArgumentParser(prog="uvnav", description="Open the UVNAV navigation console.")
    p.add_argument("--config", help=f"run configuration TOML (default: data/{DEFAULT_CONFIG_NAME})")
    p.add_argument("--dev", action="store_true", help="start in developer mode (A4)")
    p.add_argument("--live", metavar="URL",
                   help="run on a live NMEA source instead of the configuration's run file: "
                   "udp://0.0.0.0:10110, tcp://HOST:10110, serial:///dev/ttyUSB0?baud=4800 "
                   "(docs/LIVE.md)")
    p.add_argument("--hardcopy-dir", default="hardcopy",
                   help="directory for Edit ▸ Hardcopy files (default: ./hardcopy)")
    p.add_argument("--out-dir", metavar="DIR",
                   help="directory for the runs' .OUT logs (default: beside the run file when "
                   "that folder is writable, else the current directory; the bundled demo's: "
                   "the current directory)")
    p.add_argument("--nmea-out", metavar="udp://HOST:PORT",
                   help="send the MPP of every cycle as NMEA 0183 (GGA, RMC, GST, HDT on "
                   "WGS84) to this UDP port, e.g. a chart plotter on udp://127.0.0.1:10110")
    return p


CONSOLE_UDP_ONLY = ("The console sends to udp://HOST:PORT only (an NMEA file: uvnav replay "
                    "--nmea-out FILE) !")


def resolve_config(
    config: str | None,
) -> tuple[RunConfig, tuple[DatumFile, dict[str, DeccaChain]]]:
    """Load ``config`` (or the bundled demo) and the data files it names, every name checked
    (:func:`engine.run.session.load_run_config`); raises InputError with file and line."""
    path = Path(config) if config is not None else default_config_path()
    if path is None:
        raise InputError("File not found !", file=f"data/{DEFAULT_CONFIG_NAME}",
                         text=DEFAULT_CONFIG_NAME)
    return load_run_config(path)


def run_console(argv: list[str]) -> int:
    """Open the console; returns the exit status."""
    args = build_parser().parse_args(argv)
    sender = None
    config_path = Path(args.config).resolve() if args.config is not None \
        else default_config_path()
    out_dir = console_out_dir(config_path, args.out_dir)
    try:
        if out_dir is not None and not out_dir.is_dir():
            raise InputError("Not a directory !", field="--out-dir", text=str(out_dir))
        cfg, data = resolve_config(args.config)
        if args.live is not None:
            from engine.api import parse_source_url  # only when asked for (start-up time)

            cfg = cfg.replace(run_file=parse_source_url(args.live).url)
        if args.nmea_out is not None:
            from engine.api import open_nmea_sender, parse_nmea_destination

            dest = parse_nmea_destination(args.nmea_out)
            if dest.kind != "udp":
                raise InputError(CONSOLE_UDP_ONLY, field="--nmea-out", text=args.nmea_out)
            sender = open_nmea_sender(dest)
    except (InputError, OSError) as exc:
        print(f"uvnav: {exc}", file=sys.stderr)
        return 2
    collector_on = gc.isenabled()
    gc.disable()  # the import and the construction too (UVNAVApp.hold_collector_until_painted)
    try:
        from uvnav_tui.app import UVNAVApp

        app = UVNAVApp(cfg, dev_mode=args.dev, hardcopy_dir=Path(args.hardcopy_dir),
                       data=data, nmea_sender=sender, config_path=config_path,
                       out_dir=out_dir)
    except BaseException:
        if collector_on:
            gc.enable()
        raise
    if collector_on:
        app.hold_collector_until_painted()
    try:
        app.run()
    finally:
        if sender is not None:
            sender.close()
        app.release_collector()
    return 0


if __name__ == "__main__":
    raise SystemExit(run_console(sys.argv[1:]))

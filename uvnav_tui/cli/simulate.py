"""``uvnav simulate``: turn a scenario (TOML) into a ``.RUN`` file and its truth CSV.

Usage::

    uvnav simulate SCENARIO.toml --out NAME.RUN [--truth NAME.truth.csv] [--seed N]
                   [--nmea NAME.nmea] [--data-dir DIR] [--force]
    uvnav simulate --random SEED --out NAME.RUN [--interval S] [--data-dir DIR] [...]

``--random SEED`` draws a randomized mission (engine/sim/sampler.py, docs/SIMULATOR.md
"Randomized missions") instead of reading a scenario, simulates it with that seed, and also
writes the drawn scenario ``NAME.scenario.toml`` and the operator's start-up configuration
``NAME.toml`` beside the ``.RUN`` (so ``uvnav replay NAME.RUN --config NAME.toml`` replays it).

Exit status 0 on success, 2 for bad input (scenario, data files, arguments, a refused output),
1 when an output cannot be written (the message names it), 130 on Ctrl-C (nothing written).
Errors are one line on stderr in the form ``file:line: field: message`` — never a traceback.
See docs/SIMULATOR.md.

``--nmea`` also writes the same readings as an NMEA 0183 log (engine/sim/nmea.py,
docs/NMEA_OUT.md).

Outputs (engine/io/outputs.py, docs/CLI.md "Output files"): an existing ``--out``, ``--truth`` or
``--nmea`` is refused unless ``--force``, which replaces only an earlier simulator output (a
``.RUN`` file, a truth CSV, an NMEA log), never the scenario or a data file (compared by
device and inode, so links do not hide them), never a device, pipe or directory.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Iterable
from pathlib import Path

from engine.api import (
    EXISTS_MESSAGE,
    InputError,
    OutputGuard,
    SamplerError,
    SamplerOptions,
    draw_mission,
    load_scenario,
    read_data_files,
    write_simulation,
)
from uvnav_tui.cli.replay import bundled_data_dir

__all__ = ["build_parser", "run_simulate"]

PROG = "uvnav simulate"


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the sub-command."""
    p = argparse.ArgumentParser(
        prog=PROG,
        description="Simulate a mission: write a .RUN file (thesis A8.4 grammar) and the truth.",
    )
    p.add_argument("scenario", nargs="?",
                   help="scenario file (TOML, see docs/SIMULATOR.md); not with --random")
    p.add_argument("--random", metavar="SEED",
                   help="draw a randomized mission from SEED (a whole number >= 0) instead of "
                   "reading a scenario; also writes NAME.scenario.toml and NAME.toml")
    p.add_argument("--interval", default="1", metavar="S",
                   help="with --random: the epoch interval in whole seconds, 1-60 (default 1)")
    p.add_argument("--out", required=True, help="the .RUN file to write")
    p.add_argument(
        "--truth",
        help="the truth CSV to write (default: the --out name with .truth.csv instead of .RUN)",
    )
    p.add_argument("--nmea", metavar="FILE",
                   help="also write the mission as an NMEA 0183 log (GGA, RMC, ZDA, HDT, VHW, "
                   "DBT from the same readings; no Decca: NMEA has no sentence for it)")
    p.add_argument("--seed", default="0", help="random seed, a whole number >= 0 (default 0)")
    p.add_argument(
        "--data-dir",
        help="directory of TO_WGS84.DAT and DECCA.CHN (default: the scenario's data_dir; "
        "with --random the bundled data/)",
    )
    p.add_argument("--force", action="store_true",
                   help="replace an earlier .RUN / truth output (never an input)")
    return p


def _truth_default(out: Path) -> Path:
    stem = out.name[:-4] if out.name.upper().endswith(".RUN") else out.name
    return out.with_name(stem + ".truth.csv")


def _err(message: str) -> int:
    print(f"{PROG}: {message}", file=sys.stderr)
    return 2


def _check_outputs(scenario: str, data_dir: Path, outputs: Iterable[tuple[Path, str, str]],
                   force: bool) -> None:
    """Refuse an output that is an input (scenario, data files) or the other output, a
    device, pipe or directory, or an existing file without ``force`` (InputError)."""
    guard = OutputGuard()
    guard.protect_all([("the scenario", scenario),
                       ("the data file TO_WGS84.DAT", data_dir / "TO_WGS84.DAT"),
                       ("the data file DECCA.CHN", data_dir / "DECCA.CHN")])
    for path, label, kind in outputs:
        guard.check(path, label, kind=kind, force=force)
        if not force and os.path.lexists(path):
            raise InputError(EXISTS_MESSAGE, file=str(path), field=label)


def _whole(text: str, field: str, lo: int, hi: int | None = None) -> int:
    """A whole number lo ≤ n ≤ hi from an argument (InputError naming the option)."""
    t = str(text).strip()
    if not (t.isascii() and t.isdigit()) or int(t) < lo or (hi is not None and int(t) > hi):
        bound = f"{lo}-{hi}" if hi is not None else f">= {lo}"
        raise InputError(f"Must be a whole number {bound} !", field=field, text=text)
    return int(t)


SCENARIO_MARK = "# Randomized mission, seed"
CONFIG_MARK = "# Start-up values only: what an operator enters for randomized mission"
"""First lines of the drawn scenario and configuration (``--force`` replaces only those)."""


def _first_line(path: Path) -> str:
    try:
        with open(path, encoding="utf-8", errors="replace") as fh:
            return fh.readline()
    except OSError:
        return ""


def _random_mission(args: argparse.Namespace, out: Path, truth: Path) -> int:
    """``--random SEED``: draw, write the scenario and configuration, simulate."""
    try:
        seed = _whole(args.random, "--random", 0)
        interval = _whole(args.interval, "--interval", 1, 60)
        if args.seed != "0" or args.nmea:
            raise InputError("Not with --random (the seed draws the mission and its noise) !",
                             field="--seed" if args.seed != "0" else "--nmea")
        data_dir = Path(args.data_dir) if args.data_dir else bundled_data_dir()
        datums, chains = read_data_files(data_dir)
        stem = out.name[:-4] if out.name.upper().endswith(".RUN") else out.stem
        scen_path = out.with_name(stem + ".scenario.toml")
        cfg_path = out.with_name(stem + ".toml")
        rel = os.path.relpath(data_dir.resolve(), out.parent.resolve())
        opts = SamplerOptions(sample_interval_s=interval, data_dir=Path(rel).as_posix())
        mission = draw_mission(seed, datums, chains, opts, run_file=out.name,
                               base_dir=out.parent)
        outputs = [(out, "--out", "run"), (truth, "--truth", "truth")]
        _check_outputs(str(data_dir / "TO_WGS84.DAT"), data_dir, outputs, args.force)
        guard = OutputGuard()
        guard.protect_all([("the data file TO_WGS84.DAT", data_dir / "TO_WGS84.DAT"),
                           ("the data file DECCA.CHN", data_dir / "DECCA.CHN"),
                           ("--out", out), ("--truth", truth)])
        for path, label, mark in ((scen_path, "the drawn scenario", SCENARIO_MARK),
                                  (cfg_path, "the configuration", CONFIG_MARK)):
            guard.check(path, label, force=args.force)
            if os.path.lexists(path):
                if not args.force:
                    raise InputError(EXISTS_MESSAGE, file=str(path), field=label)
                if not _first_line(path).startswith(mark):
                    raise InputError(f"Not an earlier --random output (first line '{mark}…'): "
                                     "not replaced !", file=str(path), field=label)
        started = time.perf_counter()
        summary = write_simulation(mission.scenario, out, truth, seed, datums=datums,
                                   chains=chains)
        scen_path.write_text(mission.scenario_text, encoding="utf-8", newline="\n")
        cfg_path.write_text(mission.config_text, encoding="utf-8", newline="\n")
    except InputError as err:
        return _err(str(err))
    except SamplerError as err:
        return _err(str(err))
    except OSError as err:
        print(f"{PROG}: {err.filename or out}: cannot write: {err.strerror or err} !",
              file=sys.stderr)
        return 1
    g = mission.drawn
    print(f"{PROG}: random mission {seed}: {g['mission_s']} s, {g['dives']} dive(s), chain "
          f"{g['chain']}, fixes {g['systems']}; wrote {summary.n_records} records to {out}, "
          f"the truth to {truth}, the scenario to {scen_path} and the start-up configuration "
          f"to {cfg_path} ({time.perf_counter() - started:.1f} s)")
    return 0


def run_simulate(argv: list[str]) -> int:
    """Run ``uvnav simulate`` with the arguments after the sub-command; returns the exit status."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse has printed the usage and the problem
        return exc.code if isinstance(exc.code, int) else 2
    out = Path(args.out)
    truth = Path(args.truth) if args.truth else _truth_default(out)
    if args.random is not None:
        if args.scenario is not None:
            return _err(str(InputError("Give a scenario or --random, not both !",
                                       field="--random", text=args.random)))
        return _random_mission(args, out, truth)
    if args.scenario is None:
        return _err("a scenario file or --random SEED is required")
    seed_text = str(args.seed).strip()
    if not (seed_text.isascii() and seed_text.isdigit()):
        return _err(str(InputError("Must be a whole number >= 0 !", field="--seed",
                                   text=args.seed)))
    seed = int(seed_text)
    try:
        scenario = load_scenario(args.scenario)
        data_dir = Path(args.data_dir) if args.data_dir else scenario.data_dir
        datums, chains = read_data_files(data_dir)
        scenario = load_scenario(args.scenario, known_datums=datums.datums, known_chains=chains)
        nmea = Path(args.nmea) if args.nmea else None
        outputs = [(out, "--out", "run"), (truth, "--truth", "truth")]
        if nmea is not None:
            outputs.append((nmea, "--nmea", "nmea"))
        _check_outputs(args.scenario, data_dir, outputs, args.force)
        started = time.perf_counter()
        summary = write_simulation(scenario, out, truth, seed, datums=datums, chains=chains,
                                   nmea_path=nmea)
    except InputError as err:
        return _err(str(err))
    except OSError as err:
        print(f"{PROG}: {err.filename or out}: cannot write: {err.strerror or err} !",
              file=sys.stderr)
        return 1
    seconds = time.perf_counter() - started
    cm = summary.cm_deg
    print(
        f"{PROG}: wrote {summary.n_records} records to {out} and the truth to {truth} "
        f"(seed {seed}, CM {abs(cm):g}{'W' if cm < 0 else 'E'}, {seconds:.1f} s)"
    )
    if summary.nmea_path is not None:
        print(f"{PROG}: wrote {summary.n_sentences} NMEA sentences to {summary.nmea_path} "
              "(no Decca: NMEA 0183 has no sentence for it)")
    return 0


if __name__ == "__main__":
    raise SystemExit(run_simulate(sys.argv[1:]))

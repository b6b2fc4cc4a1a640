"""``uvnav simulate``: turn a scenario (TOML) into a ``.RUN`` file and its truth CSV.

Usage::

    uvnav simulate SCENARIO.toml --out NAME.RUN [--truth NAME.truth.csv] [--seed N]
                   [--data-dir DIR] [--force]

Exit status 0 on success, 2 for bad input (scenario, data files, arguments, an existing output
without ``--force``), 1 when an output cannot be written. Errors are one line on stderr in the
form ``file:line: field: message`` — never a traceback. See docs/SIMULATOR.md.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from engine.errors import InputError
from engine.scenario import load_scenario
from engine.simulate import read_data_files, write_simulation

__all__ = ["build_parser", "run_simulate"]

PROG = "uvnav simulate"


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the sub-command."""
    p = argparse.ArgumentParser(
        prog=PROG,
        description="Simulate a mission: write a .RUN file (thesis A8.4 grammar) and the truth.",
    )
    p.add_argument("scenario", help="scenario file (TOML, see docs/SIMULATOR.md)")
    p.add_argument("--out", required=True, help="the .RUN file to write")
    p.add_argument(
        "--truth",
        help="the truth CSV to write (default: the --out name with .truth.csv instead of .RUN)",
    )
    p.add_argument("--seed", default="0", help="random seed, a whole number >= 0 (default 0)")
    p.add_argument(
        "--data-dir",
        help="directory of TO_WGS84.DAT and DECCA.CHN (default: the scenario's data_dir)",
    )
    p.add_argument("--force", action="store_true", help="overwrite existing output files")
    return p


def _truth_default(out: Path) -> Path:
    stem = out.name[:-4] if out.name.upper().endswith(".RUN") else out.name
    return out.with_name(stem + ".truth.csv")


def _err(message: str) -> int:
    print(f"{PROG}: {message}", file=sys.stderr)
    return 2


def run_simulate(argv: list[str]) -> int:
    """Run ``uvnav simulate`` with the arguments after the sub-command; returns the exit status."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse has printed the usage and the problem
        return exc.code if isinstance(exc.code, int) else 2
    seed_text = str(args.seed).strip()
    if not (seed_text.isascii() and seed_text.isdigit()):
        return _err(str(InputError("Must be a whole number >= 0 !", field="--seed",
                                   text=args.seed)))
    seed = int(seed_text)
    out = Path(args.out)
    truth = Path(args.truth) if args.truth else _truth_default(out)
    if out.resolve() == truth.resolve():
        return _err(str(InputError("The .RUN and truth files must differ !", file=str(out))))
    for path in (out, truth):
        if not path.parent.is_dir():
            return _err(str(InputError("Directory not found !", file=str(path))))
        if path.exists() and not args.force:
            return _err(str(InputError("File exists (use --force to overwrite) !",
                                       file=str(path))))
    try:
        scenario = load_scenario(args.scenario)
        data_dir = Path(args.data_dir) if args.data_dir else scenario.data_dir
        datums, chains = read_data_files(data_dir)
        scenario = load_scenario(args.scenario, known_datums=datums.datums, known_chains=chains)
        started = time.perf_counter()
        summary = write_simulation(scenario, out, truth, seed, datums=datums, chains=chains)
    except InputError as err:
        return _err(str(err))
    except OSError as err:
        print(f"{PROG}: {err.filename or out}: cannot write: {err.strerror} !", file=sys.stderr)
        return 1
    seconds = time.perf_counter() - started
    cm = summary.cm_deg
    print(
        f"{PROG}: wrote {summary.n_records} records to {out} and the truth to {truth} "
        f"(seed {seed}, CM {abs(cm):g}{'W' if cm < 0 else 'E'}, {seconds:.1f} s)"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(run_simulate(sys.argv[1:]))

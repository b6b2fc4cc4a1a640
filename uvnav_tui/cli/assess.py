"""``uvnav assess``: accuracy of a replayed run against the simulator's truth.

``uvnav assess OUT_or_JSONL TRUTH.csv [--svg FILE.svg] [--phases auto|none] [--poe-rate M_H]
[--config TOML] [--datum-file TO_WGS84.DAT]`` prints rich tables: horizontal error per phase for
the LSE, the filter and the MPP with the 95 %-ellipse coverage and the NEES, the filter's NIS
(``.OUT`` only) and the Pool of Errors during each dive.  Definitions:
``engine/assess/accuracy.py`` and
``docs/ASSESS.md``.  Exit status 0, 2 for bad input (one line on stderr, never a traceback),
1 when the SVG cannot be written (the message names it), 130 on Ctrl-C.

The SVG follows the ``.OUT`` rule (engine/io/outputs.py, docs/CLI.md "Output files"): never one
of the inputs (compared by device and inode), an existing file is kept and a free ``NAME_N.svg`` is
used instead, ``--force`` replaces only an earlier assessment plot; devices, pipes and
directories are refused.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

from rich.console import Console
from rich.markup import escape
from rich.table import Table

from engine.api import (
    ESTIMATOR_LABELS,
    Assessment,
    Ellipsoid,
    InputError,
    OutputGuard,
    assess,
    read_error,
    read_nav_log,
    read_truth,
)
from uvnav_tui.cli.assess_svg import render_svg

PROG = "uvnav assess"


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``uvnav assess``."""
    p = argparse.ArgumentParser(prog=PROG, description=__doc__.splitlines()[0])
    p.add_argument("log", help=".OUT log or JSON-lines file written by `uvnav replay`")
    p.add_argument("truth", help="truth CSV written by `uvnav simulate`")
    p.add_argument("--svg", metavar="FILE.svg",
                   help="also write an SVG plot of the horizontal error against time")
    p.add_argument("--phases", choices=("auto", "none"), default="auto",
                   help="auto: split surfaced / submerged / after resurfacing from the truth's "
                        "'surfaced' column (default); none: whole run only")
    p.add_argument("--poe-rate", type=float, metavar="M_H",
                   help="Pool of Errors expansion rate ε in m/h (default: the log's "
                        "[demo] poe_expansion_m_h, else --config's, else 1800)")
    p.add_argument("--config", help="run configuration TOML to take poe_expansion_m_h from "
                                    "(useful with JSON lines, which do not embed it)")
    p.add_argument("--datum-file", help="TO_WGS84.DAT, for a truth header that does not state "
                                        "the working datum's ellipsoid")
    p.add_argument("--force", action="store_true",
                   help="replace an earlier plot of the same name (never an input)")
    return p


def _m(v: float, nd: int = 1) -> str:
    return "–" if not math.isfinite(v) else f"{v:.{nd}f}"


def _pct(v: float) -> str:
    return "–" if not math.isfinite(v) else f"{100.0 * v:.1f} %"


def _band(b: tuple[float, float], pct: bool = False) -> str:
    if not (math.isfinite(b[0]) and math.isfinite(b[1])):
        return "–"
    if pct:
        return f"{100.0 * b[0]:.1f}–{100.0 * b[1]:.1f}"
    return f"{b[0]:.2f}–{b[1]:.2f}"


def _nees(v: float) -> str:
    return "–" if not math.isfinite(v) else (f"{v:.2f}" if v < 1000 else f"{v:.4g}")


def _hms(t: object) -> str:
    return "–" if t is None else f"{t:%H:%M:%S}Z"


def accuracy_table(a: Assessment) -> Table:
    """Per phase and estimate: N, RMS, P95, max (m), 95 %-ellipse coverage and mean NEES."""
    t = Table(title="Horizontal error against truth (m)", title_justify="left")
    t.add_column("phase")
    t.add_column("estimate")
    for col in ("N", "RMS", "P95", "max", "in 95 % ell.", "iid band %", "NEES", "iid band"):
        t.add_column(col, justify="right")
    last = None
    for s in a.stats:
        if last is not None and s.phase != last:
            t.add_section()
        last = s.phase
        t.add_row(escape(s.phase), ESTIMATOR_LABELS[s.estimator], str(s.n), _m(s.rms_m),
                  _m(s.p95_m), _m(s.max_m), _pct(s.coverage), _band(s.coverage_band, pct=True),
                  _nees(s.nees), _band(s.nees_band))
    return t


def nis_table(a: Assessment) -> Table | None:
    """Mean NIS of the filter's fix updates per phase (None without innovations)."""
    if a.nis is None:
        return None
    t = Table(title="Filter fix updates: NIS = p·T_LOM", title_justify="left")
    for col in ("phase", "updates", "mean NIS", "expected", "iid band"):
        t.add_column(col, justify="left" if col == "phase" else "right")
    for s in a.nis:
        t.add_row(escape(s.phase), str(s.n), _nees(s.mean_nis), _m(s.mean_dof, 2), _band(s.band))
    return t


def poe_tables(a: Assessment) -> list[tuple[Table, str]]:
    """One table per dive (POE radius, filter 95 % a-axis and true errors) and a summary line."""
    out = []
    for i, d in enumerate(a.dives, start=1):
        fix = (f"a = {_m(d.a_m)} m = d_rms of the LSE at {_hms(d.fix_time)}"
               if d.fix_time is not None else "no LSE before this dive: POE undefined")
        t = Table(title=f"Pool of Errors, dive {i} ({_hms(d.start)}–{_hms(d.end)}): "
                        f"R = a + ε·Δt, {fix}, ε = {a.poe_rate_m_h:g} m/h "
                        f"({escape(a.poe_rate_source)})", title_justify="left")
        for col in ("time", "dive min", "Δt fix min", "POE R m", "filter a95 m",
                    "filter err m", "MPP err m"):
            t.add_column(col, justify="left" if col == "time" else "right")
        for r in d.rows:
            t.add_row(_hms(r.time), _m(r.t_dive_min), _m(r.dt_fix_min), _m(r.poe_m),
                      _m(r.kf_a95_m), _m(r.kf_error_m), _m(r.mpp_error_m))
        line = (f"over the dive: MPP error within the POE radius {_pct(d.frac_mpp_in_poe)} of "
                f"epochs; filter error within its 95 % semi-major axis "
                f"{_pct(d.frac_kf_in_a95)}")
        out.append((t, line))
    return out


def print_report(a: Assessment, console: Console) -> None:
    """Print the whole report (header lines, tables, notes)."""
    kind = ".OUT log" if a.log_kind == "out" else "JSON lines"
    console.print(f"[bold]uvnav assess[/bold]  {escape(a.log_path)} ({kind})  vs  "
                  f"{escape(a.truth_path)}")
    console.print(f"epochs: log {a.n_log}, truth {a.n_truth}, matched {a.n_matched}, "
                  f"log cycles without truth {a.n_log_unmatched}"
                  + (f", on another datum {a.n_log_other_datum}" if a.n_log_other_datum else ""))
    console.print(f"errors: {escape(a.frame)}")
    console.print("phases: " + "; ".join(
        f"{escape(p.name)} {_hms(p.start)}–{_hms(p.end)} ({p.n})"
        for p in a.phases if p.name != "all"
    ) if len(a.phases) > 1 else "phases: whole run only")
    console.print(accuracy_table(a))
    nt = nis_table(a)
    if nt is not None:
        console.print(nt)
    for t, line in poe_tables(a):
        console.print(t)
        console.print(line)
    notes = [
        "iid bands: 95 % ranges for independent epochs; consecutive epochs are correlated, so "
        "the bands are optimistic (too narrow). Coverage target 93–97 %, NEES target 2.",
        *a.notes,
    ]
    for n in notes:
        console.print(f"note: {escape(n)}")


def _poe_rate_from_toml(path: str) -> float:
    from engine.api import load_config

    return float(load_config(path).demo.poe_expansion_m_h)


def _ellipsoid_from_datum_file(path: str, datum: str) -> Ellipsoid:
    from engine.api import read_datum_file

    return read_datum_file(path).datum(datum).ellipsoid


def _check_readable(path: str | None, field: str) -> None:
    """An input file must be a readable file: say why not (missing, a directory, permission)
    before anything else is read."""
    if path is None:
        return
    if "\0" in path:
        raise InputError("A path cannot contain a NUL character !", field=field)
    if os.path.exists(path) and not (os.path.isfile(path) or os.path.isdir(path)):
        return  # a pipe (e.g. <(…)): opening it here would take a reader from the real one
    try:
        with open(path, "rb"):
            pass
    except OSError as exc:
        err = read_error(exc, path)
        raise InputError(err.message, file=path, field=field) from None


def run_assess(argv: list[str]) -> int:
    """Entry point of ``uvnav assess``; returns the exit status (0 ok, 2 bad input)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse has printed its message
        return int(exc.code or 0)
    if args.svg is not None and Path(args.svg).suffix.lower() != ".svg":
        # The plot is written as SVG text only: a PNG needs a rasteriser, which is not a
        # project dependency (docs/ASSESS.md). Refuse rather than write SVG under another name.
        print(f"{PROG}: --svg {args.svg}: the plot is SVG only; give a .svg name and convert it "
              "if needed, e.g. rsvg-convert -o plot.png plot.svg", file=sys.stderr)
        return 2
    if args.poe_rate is not None and not (math.isfinite(args.poe_rate) and args.poe_rate >= 0):
        print(f"{PROG}: --poe-rate must be a finite number >= 0 (got {args.poe_rate})",
              file=sys.stderr)
        return 2
    guard = OutputGuard()
    try:
        for path, field in ((args.log, "log"), (args.truth, "truth"), (args.config, "--config"),
                            (args.datum_file, "--datum-file")):
            _check_readable(path, field)
        if args.svg is not None:  # checked before the assessment: no long run for nothing
            guard.protect_all([("the log", args.log), ("the truth", args.truth),
                               ("the configuration", args.config),
                               ("the datum file", args.datum_file)])
            guard.check(args.svg, "--svg", kind="svg", force=args.force)
        log = read_nav_log(args.log)
        truth = read_truth(args.truth)
        rate, rate_src = args.poe_rate, "--poe-rate"
        if rate is None and args.config is not None:
            rate, rate_src = _poe_rate_from_toml(args.config), f"--config {args.config}"
        ell = None
        if truth.ellipsoid is None and args.datum_file is not None:
            name = truth.datum or next((d for d in log.datum if d), "")
            ell = _ellipsoid_from_datum_file(args.datum_file, name)
        result = assess(log, truth, poe_rate_m_h=rate, split_phases=args.phases == "auto",
                        ellipsoid=ell, poe_rate_source=rate_src)
        svg_text = render_svg(result) if args.svg else None
    except InputError as exc:
        print(f"{PROG}: {exc}", file=sys.stderr)
        return 2
    # The plot first, the report after: a report that cannot be printed (its reader gone,
    # ``uvnav assess … | head``: uvnav_tui/cli/stdout.py) does not cost the plot.
    plot: Path | None = None
    if svg_text is not None:
        try:
            with guard.open(args.svg, label="--svg", kind="svg", force=args.force) as fh:
                fh.write(svg_text)
            plot = fh.path
        except InputError as exc:
            print(f"{PROG}: {exc}", file=sys.stderr)
            return 2
        except OSError as exc:
            print(f"{PROG}: {exc.filename or args.svg}: cannot write: {exc.strerror or exc} !",
                  file=sys.stderr)
            return 1
    console = Console(highlight=False)
    if not console.is_terminal:
        console = Console(width=140, highlight=False)
    print_report(result, console)
    if plot is not None:
        console.print(f"plot {escape(str(plot))}")
    return 0


if __name__ == "__main__":
    raise SystemExit(run_assess(sys.argv[1:]))

"""The ``.RUN`` reader's quick parser on the compiled ``engine.native.runparse``.

:func:`quick_parser` is the kernel's ``record`` bound to :class:`~engine.io.runfile.RunRecord`:
the record of a usual line (each GPS coordinate four tokens or one ``-``, 6–9 numeric columns,
no ``key=value``) made in one call, or None for any other line, which the reference's checked
parser (:func:`engine.io.runfile.parse_run_line`) then reads, so every located error message
stays the reference's. The run passes it to :func:`engine.io.runfile.iter_run_file` as its
:data:`~engine.io.runfile.QuickParser` (``engine.run.parts.CycleParts.run_record``) once
:func:`probe` found it agreeing with the reference.
"""

from __future__ import annotations

import math
from dataclasses import fields
from datetime import UTC
from functools import cache

from engine import native
from engine.errors import InputError
from engine.io.runfile import QuickParser, RunRecord, parse_run_line

PROBE_LINES = (
    "920917 083538 52 50 33.020 N 004 31 51.134 E .862 .325 .109 232.4 12.7 -.2",
    "920917 083539 52 50 33.020 N 004 31 51.134 E .862 .325 .109 232.4 12.7 -.2 1.25\r\n",
    "920917 235959 33 05 09.5 S 151 12 00.001 W - .5 .999 0.0 60 90 -90 32768.125 12.50\n",
    "261202 120000 - - - - - 10.0 5.2 - - - 12.34",
    "000229 000000 00 00 00 N 180 00 00 W .0 .0 .0 359.9 0 0",
    "\t920917  083538 52 50 33.020 N 004 31 51.134 E .862 .325 .109 232.4 12.7 -.2\t",
)
"""Lines the quick parser takes (the thesis layout, all optional columns, south and west, a
dive without GPS, a leap day, the limits of every range, tabs and doubled blanks)."""
DECLINED_LINES = (
    "",
    "* a comment",
    "Date Time GPS lat GPS lon R G P Hdg Spd Rud",
    "920917 083538 52 50 33.020 N 004 31 51.134 E 1.0 .325 .109 232.4 12.7 -.2",
    "920917 083538 52 50 33.020 N 004 31 51.134 E .862 .325 .109 360.0 12.7 -.2",
    "920917 083538 52 60 33.020 N 004 31 51.134 E .862 .325 .109 232.4 12.7 -.2",
    "920917 083538 52 50 33.020 n 004 31 51.134 E .862 .325 .109 232.4 12.7 -.2",
    "920931 083538 52 50 33.020 N 004 31 51.134 E .862 .325 .109 232.4 12.7 -.2",
    "920917 086038 52 50 33.020 N 004 31 51.134 E .862 .325 .109 232.4 12.7 -.2",
    "920917 083538 52 50 33.020 N 004 31 51.134 E .862 .325 .109 232.4 1e1 -.2",
    "920917 083538 52 50 33.020 N 004 31 51.134 E .862 .325 .109 232.4 12.7 +.2",
    "920917 083538 52 50 33.020 N 004 31 51.134 E .862 .325 .109 232.4 12.7 -.2 0 1 2 3",
    "920917 083538 52 50 33.020 N 004 31 51.134 E .862\u00a0.325 .109 232.4 12.7 -.2",
    "261202 120000 - - - - - 10.0 5.2 - - - 12.34 hdop=1.20 q=1",
)
"""Lines it must leave to the checked parser (skipped lines, bad values of each kind, a
Unicode blank, ``key=value`` tokens)."""


@cache
def quick_parser() -> QuickParser | None:
    """The kernel's ``record`` bound to :class:`RunRecord` (None: the kernel not in use)."""
    kernel = native.kernel("runparse")
    if kernel is None:
        return None
    kernel.bind(RunRecord, tuple(f.name for f in fields(RunRecord)), UTC)
    return kernel.record  # type: ignore[no-any-return]


def _same(got: RunRecord, want: RunRecord) -> bool:
    """The same record within the tolerance contract (floats 1e-9 relative, 1e-9 absolute:
    degrees, lane fractions; everything else identical)."""
    for f in fields(RunRecord):
        a, b = getattr(got, f.name), getattr(want, f.name)
        pairs = zip(a, b, strict=True) if isinstance(b, tuple) else ((a, b),)
        for x, y in pairs:
            if isinstance(y, float):
                if type(x) is not float or not math.isclose(x, y, rel_tol=1e-9, abs_tol=1e-9):
                    return False
            elif x != y or type(x) is not type(y):
                return False
    return True


def probe(parse: QuickParser | None = None) -> str | None:
    """Why the quick parser is not used (None: it is): not built, or a probe line it reads
    otherwise than :func:`parse_run_line` (a record not the same, a line it should leave)."""
    parse = parse if parse is not None else quick_parser()
    if parse is None:
        return native.status("runparse")
    for line in PROBE_LINES:
        got, want = parse(line, 7), parse_run_line(line, 7)
        if got is None or want is None or not _same(got, want):
            return f"first-use probe failed on {line!r}"
    for line in DECLINED_LINES:
        try:
            parse_run_line(line, 7)
            ref_ok = True
        except InputError:
            ref_ok = False
        got = parse(line, 7)
        if got is not None and not ref_ok:
            return f"first-use probe: took the bad line {line!r}"
        if got is not None and not _same(got, parse_run_line(line, 7)):  # type: ignore[arg-type]
            return f"first-use probe failed on {line!r}"
    return None

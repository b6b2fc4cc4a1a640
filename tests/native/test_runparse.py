"""engine.native.runparse (the compiled ``.RUN`` quick parser, ``engine.fast.runfile``) against
the reference's checked parser :func:`engine.io.runfile.parse_run_line`: where the kernel
gives a record, the reference gives the same record (every float within the tolerance contract,
every other field identical), on the bundled files, edge lines and generated lines; and the
kernel takes every usual line of the bundled files."""

from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import fields

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine import native
from engine.errors import InputError
from engine.fast import runfile as fast_runfile
from engine.io.runfile import RunRecord, parse_run_line
from engine.run.parts import choose
from tests.paths import DATA, ROOT
from tests.run_lines import DIVE_LINES, perturbed_dive_lines

KERNEL = native.kernel("runparse")
QUICK = fast_runfile.quick_parser()
needs_kernel = pytest.mark.skipif(QUICK is None, reason="engine.native.runparse not built")

LINES = [
    *(DATA / "DEMO.RUN").read_text(encoding="utf-8").splitlines(keepends=True),
    *(DATA / "920917_1.RUN").read_text(encoding="utf-8").splitlines(keepends=True),
]
SAMPLE = ("920917 100002 52 49 56.313 N 004 29 55.439 E .876 .162 .032 232.6 10.0 .0 1.24 "
          "39937.542 70.82\n")
_TOKS = SAMPLE.split()


def _same(line: str, line_no: int = 11) -> bool:
    """The kernel's record of ``line`` is the reference's (True), or it left the line to the
    reference (False)."""
    assert QUICK is not None
    got = QUICK(line, line_no)
    if got is None:
        return False
    try:
        want = parse_run_line(line, line_no)
    except InputError as exc:
        raise AssertionError(f"the kernel took a bad line {line!r}: {exc}") from None
    assert want is not None, line
    assert fast_runfile._same(got, want), (line, got, want)
    assert got.raw == want.raw and got.time == want.time and hash(got.time) == hash(want.time)
    return True


@needs_kernel
def test_bundled_records_give_the_reference_records() -> None:
    taken = sum(_same(line, no) for no, line in enumerate(LINES, 1))
    records = sum(parse_run_line(line, 1) is not None for line in LINES)
    assert taken == records  # every record of the bundled files takes the quick parser
    assert choose().run_record is QUICK


def test_the_probe_declines_a_parser_that_reads_otherwise() -> None:
    """A quick parser whose latitude is off by 1e-8° (more than the tolerance contract), or
    which takes a bad line, fails the first-use probe; the reference's own parser passes."""
    from dataclasses import replace

    def off(line: str, line_no: int) -> RunRecord | None:
        rec = parse_run_line(line, line_no)
        if rec is None or rec.gps_lat_deg is None:
            return rec
        return replace(rec, gps_lat_deg=rec.gps_lat_deg + 1e-8)

    def lax(line: str, line_no: int) -> RunRecord | None:
        try:
            return parse_run_line(line, line_no)
        except InputError:
            return parse_run_line(fast_runfile.PROBE_LINES[0], line_no)

    assert fast_runfile.probe(off) is not None and fast_runfile.probe(off).startswith(
        "first-use probe failed")
    assert "took the bad line" in (fast_runfile.probe(lax) or "")
    def exact(line: str, line_no: int) -> RunRecord | None:
        try:
            return parse_run_line(line, line_no)
        except InputError:
            return None

    assert fast_runfile.probe(exact) is None


@needs_kernel
@pytest.mark.parametrize("line", [
    SAMPLE, SAMPLE.replace(" N ", " S ").replace(" E ", " W "), SAMPLE.replace(" N ", " n "),
    SAMPLE.replace("232.6", "-232.6"), SAMPLE.replace("232.6", "360.0"),
    SAMPLE.replace("232.6", "359.99999999999999999"), SAMPLE.replace(".876", ".99999999999999999"),
    SAMPLE.replace(".0 1.24", "-0 1.24"), SAMPLE.replace(".876", "1.000"),
    SAMPLE.replace("10.0", "1e1"), SAMPLE.replace("10.0", "1-0"), SAMPLE.replace("10.0", "."),
    SAMPLE.replace("10.0", "-"), SAMPLE.replace("10.0", "--1"), SAMPLE.replace("10.0", "5."),
    SAMPLE.replace(" 70.82", ""), SAMPLE.replace(" 70.82", " - -"),
    SAMPLE.replace(" 1.24 39937.542 70.82", ""), SAMPLE.replace(" 1.24 39937.542 70.82", " -"),
    SAMPLE.replace("100002", "250002"), SAMPLE.replace("100002", "106002"),
    SAMPLE.replace("920917", "920931"), SAMPLE.replace("920917", "000229"),
    SAMPLE.replace("920917", "010229"), SAMPLE.replace("920917", "691231"),
    SAMPLE.replace("920917", "700101"), SAMPLE.replace("920917", "a20917"),
    SAMPLE.replace("100002", "10000"), SAMPLE.replace(" 56.313", " 60.000"),
    SAMPLE.replace(" 56.313", " 59.99999999999999999"), SAMPLE.replace(" 49 ", " 60 "),
    SAMPLE.replace("52 49", "90 00").replace("56.313", "0"), SAMPLE.replace("52 49", "90 49"),
    SAMPLE.replace("004 29", "180 29"), SAMPLE.replace("004 29 55.439", "180 00 00"),
    SAMPLE.replace("52", "+52", 1), SAMPLE.replace(" ", "\t"), SAMPLE.replace(" ", "\x0c", 1),
    SAMPLE.replace(" ", "\u00a0", 1), SAMPLE.replace("\n", " hdop=1.2\n"),
    SAMPLE.replace(" 52 49 56.313 N", " -"), SAMPLE.replace(" 004 29 55.439 E", " -"),
    "*" + SAMPLE, "Date Time GPS lat\n", "\n", "", SAMPLE.replace("10.0", "１0.0"),
    SAMPLE.replace("39937.542", "0"), SAMPLE.replace("70.82", "-1"),
    SAMPLE.replace("70.82", "7.0.82"), SAMPLE.replace("\n", "\r\n"), SAMPLE.replace("\n", ""),
    SAMPLE.replace("\n", "\n\r\n"), SAMPLE.replace(" ", " \r ", 1), SAMPLE.replace("\n", " \n"),
    " \t" + SAMPLE, SAMPLE.replace("56.313", "56..313"), SAMPLE.replace("56.313", ".313"),
    SAMPLE.replace("56.313", "56."), SAMPLE.replace("56.313", "."), SAMPLE.replace(" N ", " NN "),
    SAMPLE.replace("39937.542", "1" * 70), SAMPLE.replace("39937.542", "9" * 400),
    SAMPLE.replace("\n", " 1\n"), SAMPLE.replace("\n", " 1 2\n"), SAMPLE.replace("\n", "\x7f\n"),
    SAMPLE.replace("\n", "\x00\n"),
])
def test_edge_lines_give_the_pure_outcome(line: str) -> None:
    _same(line)


@needs_kernel
@pytest.mark.parametrize("line", DIVE_LINES)
def test_lines_without_gps_agree(line: str) -> None:
    _same(line)


@needs_kernel
@settings(max_examples=300, deadline=None)
@given(perturbed_dive_lines())
def test_perturbed_lines_without_gps_agree(line: str) -> None:
    _same(line)


@needs_kernel
@settings(max_examples=400, deadline=None)
@given(st.lists(st.tuples(st.integers(0, len(_TOKS) - 1),
                          st.sampled_from(["-", "0", ".5", "-.5", "59.999", "60", "999", "1.",
                                           "-0", "00", "", "N", "S", "E", "W", "x", "1e3",
                                           "nan", "0.9999", "90", "180.000", "235959", "-1",
                                           "89.9999", "0.0", "--", "1.2.3", "a b"])),
                min_size=1, max_size=4),
       st.sampled_from([" ", "\t", "  ", " \t"]), st.sampled_from(["\n", "\r\n", "", " \n"]))
def test_perturbed_lines_give_the_pure_outcome(edits: list[tuple[int, str]], sep: str,
                                               eol: str) -> None:
    toks = list(_TOKS)
    for k, tok in edits:
        toks[k] = tok
    _same(sep.join(t for t in toks if t) + eol)


@needs_kernel
@settings(max_examples=300, deadline=None)
@given(st.integers(0, 99), st.integers(0, 99), st.integers(0, 99), st.integers(0, 99),
       st.integers(0, 99), st.integers(0, 99),
       st.lists(st.floats(-100.0, 100000.0), min_size=15, max_size=15),
       st.integers(0, 3))
def test_random_values_give_the_pure_outcome(y: int, mo: int, d: int, h: int, mi: int, s: int,
                                             vals: list[float], drop: int) -> None:
    toks = [f"{y:02d}{mo:02d}{d:02d}", f"{h:02d}{mi:02d}{s:02d}",
            f"{abs(vals[0]) % 100:.0f}", f"{abs(vals[1]) % 70:.0f}", f"{abs(vals[2]) % 70:.3f}",
            "N", f"{abs(vals[3]) % 200:.0f}", f"{abs(vals[4]) % 70:.0f}",
            f"{abs(vals[5]) % 70:.3f}", "W",
            *(f"{v:.3f}" if k % 2 else f"{v % 1.0:.4f}".lstrip("0") for k, v in
              enumerate(vals[6:]))]
    _same(" ".join(toks[:len(toks) - drop]) + "\n")


def test_pure_env_leaves_the_kernel_unloaded() -> None:
    code = ("import sys; from engine.run.parts import choose; from engine.io import runfile as r; "
            "assert choose().run_record is None; "
            "assert 'engine.native.runparse' not in sys.modules; "
            f"print(r.parse_run_line({SAMPLE!r}, 1))")
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                          text=True, timeout=120, env={**os.environ, native.PURE_ENV: "1"})
    assert done.returncode == 0, done.stderr


@needs_kernel
def test_make_builds_the_dataclass_instance() -> None:
    """runparse.make (the GPS and Decca readings' constructors) gives what __init__ gives."""
    import numpy as np

    from engine.fast.decca import maker
    from engine.run import cycle as cycle_mod
    from engine.systems import decca as decca_mod
    from engine.systems import gps as gps_mod
    from engine.systems.base import CycleInputs

    assert KERNEL is not None
    cov = np.eye(2)
    cases = [
        (gps_mod.GpsInput, maker(gps_mod.GpsInput),
         (52.1, 4.2, 52.2, 4.3, -40.5, (1.0, 2.0, 3.0), 52.0, 4.0, 1e5, 5.8e6, None)),
        (gps_mod.GpsFix, maker(gps_mod.GpsFix), (52.1, 4.2, 1e5, 5.8e6, 2500.0, -0.0, 1.5, None)),
        (decca_mod.LaneSource, maker(decca_mod.LaneSource), ("GPS", 1.0, 2.0, cov)),
        (decca_mod.DeccaReading, maker(decca_mod.DeccaReading),
         (None, (0.5, None, 0.25), (None, (1, 2), None), (True, False, True), (0.0, 0.1, 0.0),
          64.0, (44.5, None, 1.25), None)),
        (decca_mod.LaneTotals, maker(decca_mod.LaneTotals),
         ((44.5, None, 1.25), (None, None, None), ("a note",), 1)),
        (cycle_mod.CycleResult, maker(cycle_mod.CycleResult),
         tuple(object() for _ in fields(cycle_mod.CycleResult))),
        (cycle_mod.NavState, maker(cycle_mod.NavState),
         tuple(object() for _ in fields(cycle_mod.NavState))),
        (CycleInputs, maker(CycleInputs), tuple(object() for _ in fields(CycleInputs))),
    ]
    for cls, new, values in cases:
        assert new.func is KERNEL.make  # type: ignore[attr-defined]
        got, want = new(*values), cls(*values)
        # field by field, each the very object given (dataclass == compares arrays elementwise
        # from Python 3.13 on, so it is no test of the objects here)
        assert type(got) is cls and repr(got) == repr(want)
        assert all(getattr(got, f.name) is getattr(want, f.name) for f in fields(cls))
        for f in fields(cls):
            assert getattr(got, f.name) is getattr(want, f.name)
        with pytest.raises(AttributeError):
            setattr(got, fields(cls)[0].name, 0)
        with pytest.raises(TypeError):
            new(*values[:-1])
    with pytest.raises(TypeError):
        KERNEL.make(gps_mod.GpsFix, [])  # the slots must be a tuple
    assert maker(gps_mod.GpsFix).func is KERNEL.make  # type: ignore[attr-defined]


def test_slots_maker_is_the_class_without_kernel(monkeypatch: pytest.MonkeyPatch) -> None:
    from engine.fast.decca import maker
    from engine.fast.make import slots_maker
    from engine.run import cycle as cycle_mod
    from engine.systems import decca as decca_mod
    from engine.systems import gps as gps_mod
    from engine.systems.base import CycleInputs

    monkeypatch.setattr(native, "kernel", lambda name: None)
    assert maker(gps_mod.GpsFix) is gps_mod.GpsFix
    assert maker(decca_mod.LaneSource) is decca_mod.LaneSource
    for cls in (decca_mod.LaneTotals, cycle_mod.CycleResult, cycle_mod.NavState, CycleInputs):
        assert slots_maker(cls) is cls

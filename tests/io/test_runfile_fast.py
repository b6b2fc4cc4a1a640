"""The run's quick ``.RUN`` parser (``engine.run.parts.CycleParts.run_record``: the compiled one
of ``engine.fast.runfile`` where it is in use) against the checked parser, and the
per-configuration / per-epoch shortcuts of the GPS and Decca readings: same values (the
tolerance contract), same errors."""

from __future__ import annotations

import math
from dataclasses import fields

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine.errors import InputError
from engine.fast.runfile import _same as same_record
from engine.io import runfile
from engine.io.runfile import RunRecord, _parse_tokens
from engine.run.parts import choose
from engine.systems import decca as decca_mod
from engine.systems import gps as gps_mod
from tests.paths import DATA
from tests.run_lines import DIVE_LINES, perturbed_dive_lines

LINES = [
    *(DATA / "DEMO.RUN").read_text(encoding="utf-8").splitlines(keepends=True)[:400],
    *(DATA / "920917_1.RUN").read_text(encoding="utf-8").splitlines(keepends=True),
]
SAMPLE = "920917 100002 52 49 56.313 N 004 29 55.439 E .876 .162 .032 232.6 10.0 .0 1.24 " \
         "39937.542 70.82\n"


def _bits(rec: RunRecord) -> tuple[object, ...]:
    """Every field of a record, floats as their hex (so -0.0 and 0.0 differ)."""
    def one(v: object) -> object:
        if isinstance(v, float):
            return v.hex()
        if isinstance(v, tuple):
            return tuple(one(x) for x in v)
        return (type(v).__name__, v)
    return tuple(one(getattr(rec, f.name)) for f in fields(RunRecord))


def _slow(line: str, line_no: int = 7) -> RunRecord | InputError | None:
    """The checked parser alone (what parse_run_line did before the hot path)."""
    toks = line.split()
    if not toks or toks[0][0] == "*" or toks[0].lower() == "date":
        return None
    try:
        return _parse_tokens(toks, len(toks), line, line_no)
    except InputError as exc:
        return exc


QUICK = choose().run_record
"""The quick parser a run takes here (None: the reference's checked parser alone)."""


def _agrees(line: str) -> None:
    slow = _slow(line)
    quick = QUICK(line, 7) if QUICK is not None else None
    if quick is not None:
        assert isinstance(slow, RunRecord), (line, slow)
        assert same_record(quick, slow), line
    public = runfile.parse_run_line(line, 7) if not isinstance(slow, InputError) else None
    if isinstance(slow, RunRecord):
        assert public is not None and _bits(public) == _bits(slow)
    if isinstance(slow, InputError):
        # the public parser still raises the located error of the checked path
        with pytest.raises(InputError) as info:
            runfile.parse_run_line(line, 7, "X.RUN")
        assert str(info.value) == str(slow.located(file="X.RUN", line=7))


def test_fast_path_equals_checked_parser_on_the_bundled_files() -> None:
    taken = 0
    for line in LINES:
        _agrees(line)
        taken += QUICK is not None and QUICK(line, 7) is not None
    assert QUICK is None or taken >= 400  # the demo's records all take the quick parser


@pytest.mark.parametrize("line", [
    SAMPLE.replace(" N ", " S ").replace(" E ", " W "),
    SAMPLE.replace(" N ", " n "),
    SAMPLE.replace("232.6", "-232.6"), SAMPLE.replace("232.6", "360.0"),
    SAMPLE.replace(".0 1.24", "-0 1.24"), SAMPLE.replace(".876", "1.000"),
    SAMPLE.replace("10.0", "1e1"), SAMPLE.replace("10.0", "1-0"), SAMPLE.replace("10.0", "."),
    SAMPLE.replace("10.0", "-"), SAMPLE.replace(" 70.82", ""), SAMPLE.replace(" 70.82", " - -"),
    SAMPLE.replace("100002", "250002"), SAMPLE.replace("920917", "920931"),
    SAMPLE.replace("920917", "a20917"), SAMPLE.replace("100002", "10000"),
    SAMPLE.replace(" 56.313", " 60.000"), SAMPLE.replace(" 49 ", " 60 "),
    SAMPLE.replace("52 49", "90 49"), SAMPLE.replace("004 29", "180 29"),
    SAMPLE.replace("52", "+52", 1), SAMPLE.replace(" ", "\t"), SAMPLE.replace(" ", "\x0c", 1),
    SAMPLE.replace(" ", "\u00a0", 1), SAMPLE.replace("\n", " hdop=1.2\n"),
    SAMPLE.replace(" 52 49 56.313 N", " -"), SAMPLE.replace(" 004 29 55.439 E", " -"),
    "*" + SAMPLE, "Date Time GPS lat\n", "\n", SAMPLE.replace("10.0", "１0.0"),
    SAMPLE.replace("39937.542", "0"), SAMPLE.replace("70.82", "-1"),
    SAMPLE.replace("70.82", "7.0.82"), SAMPLE.replace("\n", "\r\n"),
    SAMPLE.replace("\n", ""), SAMPLE.replace("56.313", "56..313"),
])
def test_fast_path_equals_checked_parser_on_edge_lines(line: str) -> None:
    _agrees(line)


_TOKS = SAMPLE.split()


@pytest.mark.parametrize("line", DIVE_LINES)
def test_lines_without_gps_agree(line: str) -> None:
    _agrees(line)


@pytest.mark.skipif(QUICK is None, reason="no quick parser in use (not built, UVNAV_PURE=1)")
def test_dive_records_take_the_hot_path() -> None:
    """A dive's records (no GPS) are built by the quick parser, not only checked by it."""
    assert QUICK is not None
    for line in DIVE_LINES[:4]:
        assert QUICK(line, 7) is not None, line
    dives = [ln for ln in (DATA / "DEMO.RUN").read_text(encoding="utf-8").splitlines(True)
             if ln.split()[2:3] == ["-"]]
    assert len(dives) > 2000
    assert all(QUICK(ln, 7) is not None for ln in dives)


@settings(max_examples=300, deadline=None)
@given(perturbed_dive_lines())
def test_perturbed_lines_without_gps_agree(line: str) -> None:
    _agrees(line)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(st.integers(0, len(_TOKS) - 1),
                          st.sampled_from(["-", "0", ".5", "-.5", "59.999", "60", "999", "1.",
                                           "-0", "00", "", "N", "S", "E", "W", "x", "1e3",
                                           "nan", "0.9999", "90", "180.000", "235959"])),
                min_size=1, max_size=3),
       st.sampled_from([" ", "\t", "  "]))
def test_fast_path_equals_checked_parser_on_perturbed_lines(
        edits: list[tuple[int, str]], sep: str) -> None:
    toks = list(_TOKS)
    for k, tok in edits:
        toks[k] = tok
    line = sep.join(t for t in toks if t) + "\n"
    _agrees(line)


@settings(max_examples=200, deadline=None)
@given(st.floats(0.0, 0.999), st.floats(0.0, 359.9), st.floats(0.0, 60.0), st.integers(0, 3))
def test_fast_path_equals_checked_parser_on_random_values(fr: float, hdg: float, spd: float,
                                                          drop: int) -> None:
    toks = list(_TOKS)
    toks[10] = f"{fr:.3f}".lstrip("0") or ".0"
    toks[13] = f"{hdg:.1f}"
    toks[14] = f"{spd:.2f}"
    line = " ".join(toks[:len(toks) - drop]) + "\n"
    _agrees(line)




def test_fixed_gps_weight_is_computed_once_per_configuration() -> None:
    from engine.run.config import load_config

    cfg = load_config(DATA / "DEMO.toml")
    rec = runfile.parse_run_line(SAMPLE, 1)
    assert rec is not None
    w = gps_mod.gps_weight(cfg, rec)
    assert w is gps_mod.gps_weight(cfg, rec)
    expected = gps_mod.GpsWeight("fixed", math.sqrt(gps_mod.gps_variance_m2(cfg)), None, None,
                                 None, se_sf=cfg.lsq.gps_se_sf, receiver=cfg.gps.receiver)
    assert w == expected
    assert gps_mod._of_config(cfg).variance_m2 == gps_mod.gps_variance_m2(cfg)
    with_hdop = RunRecord(*[getattr(rec, f.name) for f in fields(RunRecord)][:12],
                          gps_hdop=1.5)  # type: ignore[arg-type]
    assert gps_mod.gps_weight(cfg, with_hdop).hdop == 1.5


def test_decca_gps_cov_is_eye_times_variance() -> None:
    system = decca_mod.DeccaSystem()
    for var in (2500.0, 2500.0, 79.21, 0.0, -0.0, math.nan, 2500.0):
        cov = system._gps_cov(var)
        want = decca_mod._EYE2 * var
        assert cov.tobytes() == want.tobytes()
        assert not cov.flags.writeable
    assert system._gps_cov(2500.0) is system._gps_cov(2500.0)
    assert np.array_equal(system._gps_cov(1.0), np.eye(2))

"""The .OUT log format: round trip, never overwriting, crash tolerance."""

from __future__ import annotations

import math
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from engine.errors import InputError
from engine.io.outlog import (
    OutLogWriter,
    format_line,
    free_log_path,
    parse_line,
    read_out_log,
)
from tests.paths import ROOT

scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(10**12), max_value=10**12),
    st.floats(allow_nan=False, allow_infinity=False),
    st.text(alphabet=st.characters(blacklist_categories=("Cs",)), max_size=30),
)


@given(st.dictionaries(st.from_regex(r"[a-z][a-z0-9_]{0,8}", fullmatch=True), scalars, max_size=8))
def test_line_round_trip(fields: dict) -> None:
    tag, back = parse_line(format_line("LOP", fields))
    assert tag == "LOP"
    assert set(back) == set(fields)
    for k, v in fields.items():
        if isinstance(v, bool):
            assert back[k] == int(v)
        else:
            assert back[k] == v


def test_nan_round_trips_as_nan() -> None:
    _, back = parse_line(format_line("X", {"w": math.nan}))
    assert math.isnan(back["w"])


def _write_run(path: Path, n_cycles: int, force: bool = False) -> Path:
    with OutLogWriter.create(path, header=["engine test"], config_text='datum = "ED50"\n',
                             force=force) as log:
        log.write_action({"cycle": 0, "text": "Setup > Systems > GPS on"})
        for n in range(1, n_cycles + 1):
            log.write_cycle({"n": n, "record": n + 1},
                            [("IN", {"raw": "920917 083538 52 50 33.020 N"}),
                             ("MPP", {"x": -31615.4 + n, "y": 5857300.165})])
        log.write_bad_record({"record": 99, "field": "heading", "message": "out of range"})
        return log.path


def test_write_read_round_trip(tmp_path: Path) -> None:
    p = _write_run(tmp_path / "A.OUT", 3)
    log = read_out_log(p)
    assert log.config_text == 'datum = "ED50"\n'
    assert [c.fields["n"] for c in log.cycles] == [1, 2, 3]
    assert log.cycles[2].first("MPP") == {"x": -31612.4, "y": 5857300.165}
    assert log.actions[0]["text"] == "Setup > Systems > GPS on"
    assert log.bad_records[0]["field"] == "heading"
    assert not log.truncated


def test_existing_log_is_never_overwritten(tmp_path: Path) -> None:
    first = _write_run(tmp_path / "RUN.OUT", 2)
    before = first.read_bytes()
    second = _write_run(tmp_path / "RUN.OUT", 1)
    third = _write_run(tmp_path / "RUN.OUT", 1)
    assert first.read_bytes() == before
    assert (second.name, third.name) == ("RUN_1.OUT", "RUN_2.OUT")
    assert free_log_path(tmp_path / "RUN.OUT").name == "RUN_3.OUT"
    forced = _write_run(tmp_path / "RUN.OUT", 1, force=True)
    assert forced == tmp_path / "RUN.OUT" and len(read_out_log(forced).cycles) == 1


def test_truncated_block_is_reported_not_fatal(tmp_path: Path) -> None:
    p = _write_run(tmp_path / "T.OUT", 2)
    with open(p, "a", encoding="utf-8") as fh:
        fh.write('CYCLE n=3 record=4\n  IN raw="9209')
    log = read_out_log(p)
    assert len(log.cycles) == 2 and log.truncated
    assert "incomplete" in log.problems[-1]


def test_corrupt_line_in_the_middle_names_file_and_line(tmp_path: Path) -> None:
    p = tmp_path / "C.OUT"
    p.write_text('# UVNAV output log, format 1\nACT text="a\nACT cycle=1\n', encoding="utf-8")
    with pytest.raises(InputError) as err:
        read_out_log(p)
    assert err.value.line == 2 and str(err.value).startswith(f"{p}:2:")


def test_kill_minus_nine_leaves_every_completed_cycle(tmp_path: Path) -> None:
    """A writer process killed with SIGKILL mid-run leaves a readable log of whole cycles."""
    out = tmp_path / "K.OUT"
    script = textwrap.dedent(f"""
        import sys, time
        from engine.io.outlog import OutLogWriter
        log = OutLogWriter.create({str(out)!r}, config_text="x = 1\\n")
        n = 0
        while True:
            n += 1
            log.write_cycle({{"n": n}}, [("MPP", {{"x": float(n)}})] * 20)
            if n == 200:
                print("ready", flush=True)
    """)
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE,
                            cwd=ROOT)
    assert proc.stdout is not None
    assert proc.stdout.readline().strip() == b"ready"
    proc.kill()
    proc.wait()
    log = read_out_log(out)
    assert len(log.cycles) >= 200
    ns = [c.fields["n"] for c in log.cycles]
    assert ns == list(range(1, len(ns) + 1))
    assert all(len(c.all("MPP")) == 20 for c in log.cycles)
    assert os.path.getsize(out) > 0

"""Issue 11 items 3 and 4: a fix far from the filter is said and counted; headless LOP rejection
is an explicit rule; a run without configuration is refused.

The runs are the first 150 records of data/DEMO.RUN with GPS positions moved by hand: +3″ of
latitude (93 m north at 52.8° N: 1″ = 30.9 m) at one record, +30° at another. With GPS alone
the LSE is the GPS position. The filter models the C/A error as Gauss–Markov (τ 240 s, 99 % of
the 50-m σ, the rest white), so from one second to the next the fix may move only by the white
5 m and the GM state's 1-s step (√(2500·(1 − e^{−2/240})) = 4.6 m): the innovation σ is about
9.6 m (measured: S_yy = 91.6 m²), and 93 m is w ≈ 10, T_LOM ≈ 38 over the 3 rows (fix and
pressure depth) against the 97.5 % bound 3.12 (χ²₃/3), far below the 30σ gross-error gate. The
30° one is thousands of σ: the gate keeps it out. (A 300-m jump is already beyond the gate:
SA cannot move the fix that fast.)
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from engine.run.config import load_config
from engine.run.session import Session
from tests.paths import DATA
from uvnav_tui.cli.replay import run_replay

JUMP_AT, GROSS_AT = 100, 120  # 1-based line numbers in the cut run


def _move_lat(line: str, add_deg: int = 0, add_sec: float = 0.0) -> str:
    tok = line.split(" ")
    tok[2] = f"{int(tok[2]) + add_deg:02d}"
    tok[4] = f"{float(tok[4]) + add_sec:06.3f}"
    return " ".join(tok)


def _write_run(tmp: Path, *, decca: bool, jump_sec: float = 3.0) -> Path:
    lines = (DATA / "DEMO.RUN").read_text(encoding="ascii").splitlines()[:150]
    lines[JUMP_AT - 1] = _move_lat(lines[JUMP_AT - 1], add_sec=jump_sec)
    lines[GROSS_AT - 1] = _move_lat(lines[GROSS_AT - 1], add_deg=30)
    run = tmp / "CUT.RUN"
    run.write_text("\n".join(lines) + "\n", encoding="ascii")
    text = (DATA / "DEMO.toml").read_text(encoding="utf-8")
    text = text.replace('run_file = "DEMO.RUN"', 'run_file = "CUT.RUN"')
    text = text.replace('data_dir = "."', f'data_dir = "{DATA.as_posix()}"')
    if not decca:
        text = text.replace("[decca]\non = true", "[decca]\non = false")
    (tmp / "CUT.toml").write_text(text, encoding="utf-8")
    return run


def test_a_fix_far_from_the_filter_is_said_and_counted(tmp_path: Path) -> None:
    """GPS only: the 93-m jump fails the innovation test (taken, message, fix_gate), the 30°
    jump is kept out by the gate (message, fix_gate); the session's summary counts both."""
    _write_run(tmp_path, decca=False)
    session = Session(load_config(tmp_path / "CUT.toml"), history=200)
    by_record = {r.record: r for r in iter(session.step, None)}
    jump, gross = by_record[JUMP_AT], by_record[GROSS_AT]
    assert jump.fix_gate == "innovation"
    assert any(m.startswith("Fix fails the innovation test: T = ") for m in jump.messages)
    t = float(re.search(r"T = ([0-9.]+)", " ".join(jump.messages)).group(1))  # type: ignore[union-attr]
    assert 15.0 < t < 80.0  # ≈ 38 (module docstring); the bound is 3.12
    assert gross.fix_gate == "gross"
    assert any("a gross error, not used" in m for m in gross.messages)
    s = session.summary()
    assert s.gated_fixes == 1
    # Only the jump itself by design; a neighbour may fail too by chance (α = 5 %).
    assert 1 <= s.innovation_rejects <= 8


def test_replay_summary_says_what_was_flagged_and_done(tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    """GPS + Decca (DEMO.toml, lsq.lop_reject "A"): GPS moved by 10″ (309 m, 6σ of the
    program's 50 m) fails the LSE's w-test against Decca. Headless, "A" becomes "N" (kept,
    flagged) and the summary says so; with --lop-reject Y the LOPs are rejected; both count
    the gross-error fix and the GPS-voted-out message appears in the JSON lines."""
    run = _write_run(tmp_path, decca=True, jump_sec=10.0)
    assert run_replay([str(run), "--no-out"]) == 0
    out = capsys.readouterr().out
    line = next(x for x in out.splitlines() if x.startswith("w-test: "))
    assert 'kept (lsq.lop_reject "A" with no operator = N)' in line
    flagged = int(line.split()[1])
    assert flagged >= 1
    assert "gross-error fixes kept out " in line
    jsonl = tmp_path / "cut.jsonl"
    assert run_replay([str(run), "--no-out", "--lop-reject", "Y", "--jsonl", str(jsonl)]) == 0
    out = capsys.readouterr().out
    line = next(x for x in out.splitlines() if x.startswith("w-test: "))
    assert "rejected (--lop-reject = Y)" in line and int(line.split()[1]) >= 1
    first = next(x for x in out.splitlines() if x.startswith("epochs "))
    assert int(first.split("rejected LOPs ")[1].split()[0]) >= 1
    assert "GPS voted out by the w-test against Decca" in jsonl.read_text(encoding="utf-8")


def test_replay_without_configuration_is_refused(tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    """No --config and no NAME.toml beside the run: exit 2, the file looked for is named,
    nothing is written (every system would be off: a run without a single fix)."""
    run = tmp_path / "LONE.RUN"
    run.write_text((DATA / "920917_1.RUN").read_text(encoding="ascii"), encoding="ascii")
    assert run_replay([str(run)]) == 2
    err = capsys.readouterr().err
    assert str(tmp_path / "LONE.toml") in err and "No configuration beside the run file" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["LONE.RUN"]

"""The compiled path writes the pure-Python reference's ``.OUT``, to the tolerance contract.

The pure-Python engine is the reference (docs/PERFORMANCE.md, "Compiled kernels"). For every
case of :mod:`tests.out_reference` (the thesis sample, a demo slice, every bundled NMEA log,
a simulated slice of every data/scenarios mission) the reference log is written by a process
with ``UVNAV_PURE=1`` (no kernel loaded), the same run is replayed here with the compiled
kernels, and :func:`tests.tolerance.compare_out` compares the two field by field: every number
within 1e-9 relative (or its absolute floor), every other field and the line structure
identical. Where no kernel is built (no compiler) both runs are pure and agree trivially.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from engine import native
from tests.out_reference import CASES, replay_case
from tests.paths import ROOT
from tests.tolerance import compare_lines, compare_out


@pytest.fixture(scope="module")
def pure_logs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Every case's reference log, written by the pure-Python engine in one subprocess."""
    folder = tmp_path_factory.mktemp("pure")
    env = {**os.environ, native.PURE_ENV: "1"}
    done = subprocess.run([sys.executable, "-m", "tests.out_reference", str(folder)], cwd=ROOT,
                          env=env, capture_output=True, text=True, timeout=1800)
    assert done.returncode == 0, done.stdout + done.stderr
    return folder


@pytest.mark.parametrize("name", sorted(CASES))
def test_compiled_log_agrees_with_the_pure_reference(name: str, pure_logs: Path,
                                                     tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(native.PURE_ENV, raising=False)
    got = replay_case(name, tmp_path / f"{name}.OUT")
    want = pure_logs / f"{name}.OUT"
    diffs = compare_out(got, want, same_paths=(str(tmp_path), str(pure_logs)))
    assert not diffs, f"{name}: the compiled log breaks the tolerance contract:\n" + "\n".join(
        diffs[:12])
    assert sum(1 for line in want.read_text(encoding="utf-8").splitlines()
               if line.startswith("CYCLE")) > 0


def test_the_compiled_kernels_are_in_use_where_built() -> None:
    """The comparison above means something only where the kernels run: where a compiler
    exists every kernel is built and passes its first-use check."""
    import shutil

    if shutil.which("cc") is None and shutil.which("gcc") is None:
        pytest.skip("no C compiler here: both runs are pure")
    assert all(native.status(n) == "compiled" for n in native.kernel_names()), \
        native.kernel_report()


# ------------------------------------------------------------- the comparison itself fails

SAMPLE_LINES = [
    "# run /data/920917_1.RUN",
    "CYCLE n=1 t=08:35:37",
    "  LSE x=-31671.300424580437 y=5857285.321221022 lat=52.84218931768626 ok=1 flags=ab",
    "  TEST lom=0.1941318592672007 dof=2 verdict=accept ls=0.345,0.519",
    '  MSG text="unit variance rejected: S² = 0.022 outside (0.0253, 3.689)"',
    "  MPP x=-31671.300424580437 a95=30.723841623170664 az=118.54724912392344 "
    "cxx=127.01538222611266 cxy=-56.12709813866216 cyy=54.379594630079424",
    "  KFP az=3.0055195257390137 cxx=127.01538 cxy=0.0000002 cyy=127.01537",
    "END n=1",
]


def _with(line_no: int, old: str, new: str) -> list[str]:
    lines = list(SAMPLE_LINES)
    assert old in lines[line_no]
    lines[line_no] = lines[line_no].replace(old, new)
    return lines


def test_numbers_within_the_contract_pass() -> None:
    got = _with(2, "x=-31671.300424580437", "x=-31671.300424580441")  # 1e-16 relative
    got = [re.sub("lat=52.84218931768626", "lat=52.842189317686265", g) for g in got]
    got = [g.replace("lom=0.1941318592672007", "lom=0.19413185926720075") for g in got]
    assert compare_lines(got, SAMPLE_LINES) == []


@pytest.mark.parametrize("line_no, old, new", [
    (2, "x=-31671.300424580437", "x=-31671.3005"),        # 2.4e-9 relative, 7.6e-5 m
    (2, "lat=52.84218931768626", "lat=52.8421894"),       # 1.6e-9 relative
    (3, "lom=0.1941318592672007", "lom=0.1941348"),       # 3e-6 absolute (floor 1e-6 σ)
    (5, "az=118.54724912392344", "az=118.5473"),         # 4.5e-7 relative: a sharp axis
    (5, "cxy=-56.12709813866216", "cxy=-56.127098"),      # 2.5e-9 relative
    (3, "ls=0.345,0.519", "ls=0.345,0.5191"),              # one element of a list
    (2, "ok=1", "ok=0"),                                   # a flag
    (2, "flags=ab", "flags=ba"),                           # a text field
    (3, "verdict=accept", "verdict=reject"),               # a verdict
    (3, "dof=2", "dof=3"),                                 # a count
    (4, "S² = 0.022", "S² = 0.023"),                       # a message text
    (1, "CYCLE", "CYCLES"),                                # a record word
    (2, "y=", "z="),                                       # a key
])
def test_a_real_difference_fails(line_no: int, old: str, new: str) -> None:
    diffs = compare_lines(_with(line_no, old, new), SAMPLE_LINES)
    assert len(diffs) == 1 and f":{line_no + 1}:" in diffs[0], diffs


def test_the_axis_of_a_near_circular_ellipse_is_judged_by_its_vcv() -> None:
    """A near-circular ellipse's axis turns by degrees for a 1e-9 change of its VCV: its
    azimuth's tolerance is what the VCV's own tolerance allows (tests.tolerance)."""
    assert compare_lines(_with(6, "az=3.0055195257390137", "az=3.0055195299835"),
                         SAMPLE_LINES) == []
    assert compare_lines(_with(6, "az=3.0055195257390137", "az=5.0"), SAMPLE_LINES)


def test_a_cancelling_covariance_is_judged_against_its_diagonal() -> None:
    """cxy near zero beside cxx ≈ cyy ≈ 127 m²: its tolerance is 1e-9·√(cxx·cyy) = 1.27e-7 m²
    (tests.tolerance.covariance_tolerance), not 1e-9 of itself."""
    assert compare_lines(_with(6, "cxy=0.0000002", "cxy=0.0000003"), SAMPLE_LINES) == []
    assert compare_lines(_with(6, "cxy=0.0000002", "cxy=0.0000012"), SAMPLE_LINES)


def test_a_missing_line_or_field_fails() -> None:
    assert compare_lines(SAMPLE_LINES[:-1], SAMPLE_LINES)
    assert compare_lines(_with(2, " ok=1", ""), SAMPLE_LINES)
    assert compare_lines(_with(3, "lom=0.1941318592672007", "lom=nan"), SAMPLE_LINES)


def test_json_lines_are_compared_value_by_value(tmp_path: Path) -> None:
    """compare_jsonl: numbers to the contract (metres' floor), everything else exactly."""
    from tests.tolerance import compare_jsonl

    want = tmp_path / "want.jsonl"
    want.write_text('{"t": 1, "x": 5857285.321221022, "flag": "ok"}\n', encoding="utf-8")
    near = tmp_path / "near.jsonl"
    near.write_text('{"t": 1, "x": 5857285.321221023, "flag": "ok"}\n', encoding="utf-8")
    assert compare_jsonl(near, want) == []
    for text in ('{"t": 1, "x": 5857285.331, "flag": "ok"}\n',  # 1.7e-9 relative
                 '{"t": 1, "x": 5857285.321221022, "flag": "no"}\n',
                 '{"t": 2, "x": 5857285.321221022, "flag": "ok"}\n', ""):
        far = tmp_path / "far.jsonl"
        far.write_text(text, encoding="utf-8")
        assert compare_jsonl(far, want), text

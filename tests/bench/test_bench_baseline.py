"""bench/bench_baseline.py's table, doc section and error paths (no timing is asserted: the
figures below are made up, and the table is checked to be computed from them)."""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import pytest

from bench import bench_baseline as bb

# The workloads as the bench has them, with 3 rounds (the made-up runs below).
DEMO = replace(next(w for w in bb.WORKLOADS if w.key == "demo"), rounds=3)
PAINT = replace(next(w for w in bb.WORKLOADS if w.key == "paint"), rounds=3)
CRASH = "exit 1: internal error (AttributeError: 'FilterState' object has no attribute 'x')"


def _variant(label: str, runs: list[tuple[float, float]] | None = None,
             fails: str | None = None) -> bb.Variant:
    v = bb.Variant(label, Path("py"), Path("."), pure=label == bb.BASE_PURE)
    for w in (DEMO, PAINT):
        if fails is not None:
            v.failed[w.key] = fails
        elif runs is not None:
            v.runs[w.key] = list(runs)
    return v


def _groups() -> dict[str, list[bb.Variant]]:
    # (wall, CPU): baseline CPU median 0.50 (wall median 0.9); this tree CPU median 0.40.
    return {
        "3.11.7": [_variant(bb.BASE, [(0.9, 0.5), (2.0, 0.6), (0.8, 0.45)]),
                   _variant(bb.THIS, [(0.7, 0.4), (0.6, 0.38), (3.0, 0.41)])],
        "3.13.0": [_variant(bb.BASE, fails=CRASH),
                   _variant(bb.BASE_PURE, [(2.5, 2.0), (2.4, 2.2), (2.6, 2.1)]),
                   _variant(bb.THIS, [(0.6, 0.44), (0.7, 0.46), (0.5, 0.45)])],
    }


def _row(text: str, name: str, version: str) -> list[str]:
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if cells[0] == name and cells[1] == version:
            return cells
    raise AssertionError(f"no row {name!r} {version!r} in\n{text}")


def test_table_medians_and_ratios_of_cpu_for_replays():
    t = bb.table(_groups(), (DEMO, PAINT))
    row = _row(t, DEMO.name, "3.11.7")
    assert row[2] == "0.500 s (wall 0.90)"
    assert row[3] == "0.400 s (wall 0.70)"
    assert row[4] == "0.80"  # 0.40 / 0.50, CPU medians


def test_a_cell_says_when_it_has_fewer_runs_than_rounds():
    groups = _groups()
    groups["3.11.7"][1].runs[DEMO.key] = [(0.7, 0.4)]
    assert _row(bb.table(groups, (DEMO,)), DEMO.name, "3.11.7")[3] == "0.400 s (wall 0.70, 1 run)"


def test_table_first_paint_is_wall_time():
    row = _row(bb.table(_groups(), (DEMO, PAINT)), PAINT.name, "3.11.7")
    assert row[2] == "0.900 s (CPU 0.50)"
    assert row[4] == f"{0.7 / 0.9:.2f}"


def test_table_says_the_baseline_crashes_and_what_it_compares_against():
    t = bb.table(_groups(), (DEMO, PAINT))
    row = _row(t, DEMO.name, "3.13.0")
    assert row[2] == "compiled fails [1]; pure: 2.100 s (wall 2.50)"
    # Against the baseline's compiled path on the first Python (where it runs), named.
    assert row[4] == f"{0.45 / 0.50:.2f} (vs {bb.BASELINE} on 3.11.7)"
    # The message once under the table, whichever rows it failed on.
    assert _row(t, PAINT.name, "3.13.0")[2].startswith("compiled fails [1]; pure:")
    assert t.splitlines()[-1] == f"* [1] {bb.BASELINE} compiled on Python 3.13.0: {CRASH}"
    assert t.count("* [") == 1


def test_table_numbers_distinct_failures_apart():
    groups = _groups()
    groups["3.11.7"][1].failed[PAINT.key] = "the menu bar did not appear within 60 s"
    t = bb.table(groups, (DEMO, PAINT))
    assert _row(t, PAINT.name, "3.11.7")[3] == "fails [2]"
    assert _row(t, PAINT.name, "3.11.7")[4] == "–"  # no ratio without a figure
    assert t.splitlines()[-1] == ("* [2] this tree on Python 3.11.7: the menu bar did not "
                                  "appear within 60 s")


def test_doc_section_is_replaced_between_the_markers_only():
    text = f"# P\n\nintro\n{bb.DOC_BEGIN}\nold table\n{bb.DOC_END}\nafter\n"
    new = bb.replace_doc_section(text, "| new |\n")
    assert new == f"# P\n\nintro\n{bb.DOC_BEGIN}\n| new |\n{bb.DOC_END}\nafter\n"
    assert bb.replace_doc_section(new, "| new |") == new


@pytest.mark.parametrize("text", ["no markers", f"{bb.DOC_END}\n{bb.DOC_BEGIN}\n"])
def test_doc_section_without_markers_is_an_error(text):
    with pytest.raises(ValueError, match="markers"):
        bb.replace_doc_section(text, "x")


def test_unknown_baseline_commit_is_reported_not_raised_raw():
    with pytest.raises(bb.Unavailable, match="not in this checkout's history"):
        bb.baseline_commit("0123456789abcdef0123456789abcdef01234567")


def test_a_failing_process_gives_its_last_error_line():
    with pytest.raises(RuntimeError, match=r"exit 1: boom$"):
        bb.timed_process([sys.executable, "-c", "import sys; print('x', file=sys.stderr); "
                          "sys.exit('boom')"], Path("."), {})

"""The run's input and output parts of engine.fast (the ``.RUN`` quick parser, the ``.OUT``
block writer, the untracking of kept results): chosen once per run, each declining to the
reference when its first-use probe (or, for the block writer, its first block) disagrees."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import pytest

import engine.fast as fast
from engine.fast import outlog as fast_outlog
from engine.fast import retained as fast_retained
from engine.fast import runfile as fast_runfile
from engine.run.config import load_config
from engine.run.parts import REFERENCE, choose
from engine.run.session import Session
from tests.paths import DATA

needs_outfmt = pytest.mark.skipif(fast_outlog.probe() is not None,
                                  reason="the compiled .OUT writer is not in use here")
needs_runparse = pytest.mark.skipif(fast_runfile.quick_parser() is None,
                                    reason="engine.native.runparse not in use here")


@pytest.fixture
def fresh_verdicts() -> Iterator[None]:
    """Forget the probes' verdicts before and after (they are kept per process)."""
    fast._verdict.cache_clear()
    yield
    fast._verdict.cache_clear()


def _run(tmp_path: Path, name: str, without: str | None = None, cycles: int = 25) -> Session:
    """A session of the demo's first ``cycles`` cycles writing ``name``.OUT; ``without``: the
    run's parts with that one field the reference's."""
    import engine.run.session as session_mod

    with pytest.MonkeyPatch.context() as m:
        if without is not None:
            parts = replace(choose(), **{without: getattr(REFERENCE, without)})
            m.setattr(session_mod, "choose_parts", lambda: parts)
        s = Session(load_config(DATA / "DEMO.toml"), out_path=tmp_path / f"{name}.OUT",
                    force=True, history=1)
    try:
        s.run(max_cycles=cycles)
    finally:
        s.close()
    return s


def _blocks(tmp_path: Path, name: str) -> str:
    return (tmp_path / f"{name}.OUT").read_text(encoding="utf-8").split("# config-end\n", 1)[1]


@needs_outfmt
@needs_runparse
def test_a_run_takes_the_compiled_io_parts(fresh_verdicts: None) -> None:
    parts = choose()
    assert parts.run_record is fast_runfile.quick_parser()
    assert parts.out_writer is fast_outlog.BlockWriter
    assert parts.untrack is fast_retained.untracker()


@needs_outfmt
def test_block_writer_keeps_to_the_reference_when_its_first_block_differs(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A kernel whose block differs from the reference's by one character is caught on the
    run's first block: the whole log is then the reference's, and the writer says why."""
    real = fast_outlog.cycle_text

    def off(r: object, shapes: tuple[object, ...]) -> str | None:
        text = real(r, shapes)
        return None if text is None else text.replace(" n=", " n= ", 1)

    _run(tmp_path, "ref", without="out_writer")
    want = _blocks(tmp_path, "ref")
    monkeypatch.setattr(fast_outlog, "cycle_text", off)
    s = _run(tmp_path, "off")
    writer = s._write_block
    assert isinstance(writer, fast_outlog.BlockWriter)
    assert writer.checked and writer.declined is not None
    # the first block the kernel writes: cycle 1 carries the learnt factor's first ADAPT line
    # ([filter] adapt), which the reference writes, so the check falls on cycle 2
    assert writer.declined.startswith("first-use check: cycle 2's block")
    assert _blocks(tmp_path, "off") == want


@needs_outfmt
def test_block_writer_writes_the_reference_text(tmp_path: Path) -> None:
    """With the kernel passing its check, the log is the reference's, character for character
    (the kernel copies texts: repr's digits, the reference's words)."""
    _run(tmp_path, "ref", without="out_writer")
    s = _run(tmp_path, "fast")
    assert s._write_block.declined is None  # type: ignore[attr-defined]
    assert _blocks(tmp_path, "fast") == _blocks(tmp_path, "ref")


@needs_outfmt
def test_out_writer_probe_declines_other_text(monkeypatch: pytest.MonkeyPatch,
                                              fresh_verdicts: None) -> None:
    """A writer kernel whose row text is not the reference's is not offered."""
    class Off:
        def __init__(self, k: object) -> None:
            self._k = k

        def __getattr__(self, name: str) -> object:
            return getattr(self._k, name)

        def render_rows(self, *a: object) -> str | None:
            text = self._k.render_rows(*a)  # type: ignore[attr-defined]
            return None if text is None else text.replace("0.1", "0.10")

    k = fast_outlog.kernel()
    monkeypatch.setattr(fast_outlog, "kernel", lambda: Off(k))
    assert "out_writer" not in fast.parts()
    why = {p: w for p, _k, w in fast.declined()}
    assert why["out_writer"] == "first-use probe failed (render_rows)"
    assert choose().out_writer is None


def test_untrack_probe_declines_a_walk_that_untracks_nothing(
        monkeypatch: pytest.MonkeyPatch, fresh_verdicts: None) -> None:
    monkeypatch.setattr(fast_retained, "untracker", lambda: (lambda obj: None))
    assert fast_retained.probe() == "first-use probe failed (untrack)"
    assert "untrack" not in fast.parts()


@needs_runparse
def test_run_record_probe_declines_and_the_run_reads_by_the_checked_parser(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fresh_verdicts: None) -> None:
    """A quick parser that drops the rudder fails its probe; the run then reads every line by
    the checked parser and logs the same blocks as with the quick parser."""
    real = fast_runfile.quick_parser()
    assert real is not None

    def no_rudder(line: str, line_no: int) -> object:
        rec = real(line, line_no)
        return None if rec is None else replace(rec, rudder_deg=None)

    monkeypatch.setattr(fast_runfile, "quick_parser", lambda: no_rudder)
    assert "run_record" not in fast.parts()
    assert choose().run_record is None
    s = _run(tmp_path, "checked")
    assert s.parts.run_record is None
    fast._verdict.cache_clear()
    monkeypatch.undo()
    _run(tmp_path, "fast")
    assert _blocks(tmp_path, "checked") == _blocks(tmp_path, "fast")

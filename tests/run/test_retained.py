"""The kept cycle results are off the cyclic collector's lists, and nothing is leaked by it.

``engine.fast.retained.untracker()`` (the compiled ``runparse.untrack``) takes a result and the
frozen records, tuples and all-untracked dicts under it off CPython's GC lists. The checks:
what it enters and what it leaves tracked (synthetic objects, ``gc.is_tracked``), that a
dict it untracked is tracked again by CPython when a container is stored in it, that a
session's history is untracked after a few demo cycles, and that a dropped session's memory
all comes back (``tracemalloc``), i.e. no reference cycle was hidden from the collector.
"""

from __future__ import annotations

import gc
import tracemalloc
import weakref
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

from engine import native
from engine.fast import retained as fast_retained
from engine.run import retained
from engine.run.config import load_config
from engine.run.session import Session

ROOT = Path(__file__).resolve().parents[2]
needs_kernel = pytest.mark.skipif(
    fast_retained.untracker() is None,
    reason=f"engine.native.runparse not in use: {native.status('runparse')}")


@dataclass(frozen=True, slots=True)
class _Leaf:
    value: Any


@dataclass(frozen=True)
class _Node:  # an instance dict, like the LSQ's result records
    leaves: tuple[_Leaf, ...]
    notes: list[str] = field(default_factory=list)
    table: dict[str, Any] = field(default_factory=dict)


class _Mutable:
    def __init__(self, leaf: _Leaf) -> None:
        self.leaf = leaf


def _untrack(obj: object) -> None:
    untrack = fast_retained.untracker()
    assert untrack is not None
    untrack(obj)


@needs_kernel
def test_walk_enters_frozen_records_tuples_and_dicts_only() -> None:
    inner = _Leaf(1.5)
    behind_mutable = _Leaf(2.5)
    mutable = _Mutable(behind_mutable)
    table = {"a": _Leaf(3.5)}
    node = _Node((inner, _Leaf(mutable)), ["x"], table)
    assert all(gc.is_tracked(o) for o in (node, inner, node.leaves, table, mutable))
    _untrack(node)
    assert not gc.is_tracked(node)
    assert not gc.is_tracked(node.leaves)
    assert not gc.is_tracked(inner)
    assert not gc.is_tracked(node.leaves[1])  # a frozen record holding a mutable object
    assert not gc.is_tracked(table) and not gc.is_tracked(table["a"])
    assert gc.is_tracked(node.notes)  # a list: left tracked, not entered
    assert gc.is_tracked(mutable)  # a plain object: left tracked ...
    assert gc.is_tracked(behind_mutable)  # ... and not entered
    # the values are untouched
    assert node.leaves[0].value == 1.5 and table["a"].value == 3.5 and node.notes == ["x"]


@needs_kernel
def test_dict_holding_a_tracked_value_stays_tracked_and_is_retracked_on_store() -> None:
    mixed = {"a": _Leaf(1.0), "b": []}
    plain = {"a": _Leaf(1.0)}
    _untrack(_Node((), [], mixed))
    _untrack(_Node((), [], plain))
    assert gc.is_tracked(mixed) and not gc.is_tracked(mixed["a"])
    assert not gc.is_tracked(plain)
    plain["later"] = []  # CPython tracks a dict again when a container is stored in it
    assert gc.is_tracked(plain)


def test_pure_path_untracks_nothing(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """Without the kernel there is no walk, and a session's kept results stay tracked."""
    import engine.run.session as session_mod
    from engine.run.parts import REFERENCE

    with monkeypatch.context() as m:
        m.setattr(native, "kernel", lambda name: None)
        assert fast_retained.untracker.__wrapped__() is None
    monkeypatch.setattr(session_mod, "choose_parts", lambda: REFERENCE)
    s = _demo_session(tmp_path, "P")
    try:
        s.run(max_cycles=5)
        result = s.history[-1]
        assert gc.is_tracked(result) and gc.is_tracked(result.sensors)
    finally:
        s.close()


def test_is_frozen_record() -> None:
    @dataclass
    class Open:
        x: int

    assert fast_retained.is_frozen_record(_Leaf) and fast_retained.is_frozen_record(_Node)
    assert not fast_retained.is_frozen_record(Open)
    assert not fast_retained.is_frozen_record(_Mutable)
    assert not fast_retained.is_frozen_record(tuple)


def _demo_session(tmp_path: Path, name: str, **kwargs: Any) -> Session:
    cfg = load_config(ROOT / "data" / "DEMO.toml")
    return Session(cfg, out_path=tmp_path / f"{name}.OUT", force=True, **kwargs)


def _tracked_frozen_under(obj: object) -> list[str]:
    """Frozen records and tuples reachable from ``obj`` through frozen records, tuples and
    dicts that the collector still tracks (type names)."""
    seen: set[int] = set()
    out: list[str] = []
    stack = [obj]
    while stack:
        o = stack.pop()
        if id(o) in seen:
            continue
        seen.add(id(o))
        t = type(o)
        if not (t is tuple or t is dict or fast_retained.is_frozen_record(t)):
            continue
        if gc.is_tracked(o) and t is not dict:
            out.append(t.__name__)
        stack.extend(gc.get_referents(o))
    return out


@needs_kernel
def test_session_history_is_off_the_collector(tmp_path: Path) -> None:
    s = _demo_session(tmp_path, "H")
    try:
        s.run(max_cycles=40)
        assert len(s.history) == 40
        fixes = [r for r in s.history if r.fix is not None]
        assert fixes, "the demo's first 40 cycles have fixes"
        for r in s.history:
            assert _tracked_frozen_under(r) == []
    finally:
        s.close()
    short = _demo_session(tmp_path, "S", history=retained.UNTRACK_MIN_HISTORY - 1)
    try:  # kept too briefly for the walk to pay: left to the collector
        short.run(max_cycles=5)
        assert gc.is_tracked(short.history[-1])
    finally:
        short.close()


def test_dropped_session_gives_its_memory_back(tmp_path: Path) -> None:
    """A session of 400 demo cycles (its history: all of them) holds several MB; once closed
    and dropped, tracemalloc's count is back within 256 kB of before (module memos keep the
    last cycle's few objects): no cycle through an untracked object kept it alive."""
    def one_run(name: str) -> tuple[weakref.ref[Session], int]:
        s = _demo_session(tmp_path, name)
        s.run(max_cycles=400)
        held = tracemalloc.get_traced_memory()[0]
        s.close()
        return weakref.ref(s), held

    tracemalloc.start()
    try:
        one_run("W")  # warm-up: module caches and memos filled once
        gc.collect()
        before = tracemalloc.get_traced_memory()[0]
        ref, held = one_run("R")
        gc.collect()
        after = tracemalloc.get_traced_memory()[0]
    finally:
        tracemalloc.stop()
    assert ref() is None
    assert held - before > 2_000_000  # the history was there: the check below can fail
    assert after - before < 256_000

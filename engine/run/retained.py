"""The cycle results a session keeps, out of the cyclic garbage collector's lists.

A session keeps its last ``history`` cycles (``Session(history=...)``, 3600 by default: the
console's pages and plots). Each
:class:`~engine.run.cycle.CycleResult` is a tree of about 45 frozen records and tuples (the
fix, its tests and ellipses, the filter's states and updates), so a session holds some 150,000
objects that CPython's cyclic collector walks again and again: each once when young, again
when promoted, and all of them at every full collection. On the demo that walking cost about
45 µs of the ~400 µs an epoch took (callbacks of :data:`gc.callbacks`, 5000 epochs), about 7 %
of the instructions and more of the time (docs/PERFORMANCE.md, "The garbage collector").

These objects cannot be part of a reference cycle: a frozen record gets its fields when it is
made and never again, so nothing it holds can refer back to it unless a *mutable* object on
the way is changed later, and the walk below does not enter mutable objects. Reference
counting frees them as before; the collector just stops looking at them. The compiled walk of
``engine.fast.retained`` takes a kept result and everything frozen under it off the
collector's lists in one call (~35 k instructions, a few µs, an epoch); a run takes it as its
``untrack`` part (``engine.run.parts.CycleParts``). The reference untracks nothing: the
results are the same either way, only the collector's work differs.

What is entered: exact tuples and instances of frozen dataclasses
(``engine.fast.retained.is_frozen_record``),
both then untracked; and exact dicts (a record's instance dict), whose values are walked and
which are untracked only when none of their keys and values is tracked any more (CPython's own
rule for dicts; CPython tracks such a dict again when a container is stored in it). What stops
the walk and stays tracked: everything else (lists, the run context, other mutable objects;
numpy arrays are not tracked at all). ``tests/run/test_retained.py`` checks both, and that a
session's objects are all freed once it is dropped (no cycle was hidden).
"""

from __future__ import annotations

UNTRACK_MIN_HISTORY = 100
"""A session untracks its results only when it keeps at least this many cycles. The walk costs
about as many instructions as the collector's work it saves (~35 k an epoch on the demo); it
pays because the collector's work is cache misses over the whole history (a full collection
of a 3600-cycle history: ~80 ms) and the walk's is not. A result kept for fewer cycles is seen
by a few young collections at most (one every ~25 demo cycles) and never by a full one: there
the walk would only cost (the replay keeps 1, ``uvnav replay``; the console 3600)."""

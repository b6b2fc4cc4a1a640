"""The session's kept results off the cyclic collector's lists, on ``engine.native.runparse``.

:func:`untracker` gives ``untrack(result)``: the kernel's ``untrack`` walk, which takes a kept
cycle result and the frozen records (:func:`is_frozen_record`), tuples
and all-untracked dicts under it off CPython's GC lists (``PyObject_GC_UnTrack``): why that
is safe and what it saves is in :mod:`engine.run.retained`. The reference untracks nothing
(same results, more collector work).
"""

from __future__ import annotations

import dataclasses
import gc
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from typing import Any

from engine import native


def is_frozen_record(tp: type) -> bool:
    """True for a frozen dataclass (its instances never change after ``__init__``): the types
    the walk enters and takes off the collector's lists."""
    params = getattr(tp, "__dataclass_params__", None)
    return isinstance(tp, type) and dataclasses.is_dataclass(tp) and bool(
        getattr(params, "frozen", False))


@cache
def untracker() -> Callable[[Any], None] | None:
    """``untrack(obj)``: the kernel's walk bound to a cache of each type's
    :func:`is_frozen_record` answer (one per process); None where the kernel is not in use."""
    walk = getattr(native.kernel("runparse"), "untrack", None)
    if walk is None:
        return None
    kinds: dict[type, bool] = {}

    def untrack(obj: Any) -> None:
        walk(obj, kinds, is_frozen_record)

    return untrack


@dataclass(frozen=True)
class _Probe:
    leaves: tuple[Any, ...]
    mutable: list[Any]


def probe() -> str | None:
    """Why the walk is not used (None: it is): not built, or on a small tree it left a frozen
    record tracked or untracked the list it must not enter."""
    untrack = untracker()
    if untrack is None:
        return native.status("runparse")
    inner = _Probe((), [])
    top = _Probe((inner, ([1.5],)), [inner])
    untrack(top)
    if gc.is_tracked(top) or gc.is_tracked(top.leaves) or not gc.is_tracked(top.mutable):
        return "first-use probe failed (untrack)"
    if gc.is_tracked(inner) or gc.is_tracked(top.leaves[1]) or not gc.is_tracked(
            top.leaves[1][0]):
        return "first-use probe failed (untrack)"
    return None

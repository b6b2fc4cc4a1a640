"""The compiled LSQ kernel (``engine/native/lsq.c``), bound to its Python objects on first use.

:func:`kernel` returns the module ready to call, or None: not built, stale, ``UVNAV_PURE=1``.
The statistics block's ``np.power(q, -0.5)`` and ``np.hypot`` are numpy's own ufuncs called
from the kernel; its small-matrix code is its own (engine/native/uvn_linalg.h). The binding
happens on the first call, not at import, so start-up does not pay for it.
"""

from __future__ import annotations

import math
from types import ModuleType
from typing import Any

import numpy as np

from engine import native

_UNSET: Any = object()
_K: Any = _UNSET
"""The resolved kernel (module or None) once :func:`kernel` has been called, else _UNSET."""
_BOUND: dict[int, ModuleType | None] = {}
"""id(module) → the bound module, or None where it cannot be used (decided once)."""
_CLASSES: dict[str, type] = {}
"""The result classes the kernel builds (``solution``: adjustment's ``_Solution``,
``ellipse``: confidence's ``Ellipse``), provided by those modules at import (:func:`provide`),
so this module imports neither (no import cycle)."""


def provide(**classes: type) -> None:
    """Register result classes for the kernel (called by adjustment.py and confidence.py)."""
    _CLASSES.update(classes)


def kernel() -> ModuleType | None:
    """``engine.native.lsq`` bound and usable, or None (callers run their pure Python).

    Resolved once per process (``UVNAV_PURE`` is read then, as by the other kernels at import);
    :func:`reset` forgets it (tests)."""
    k = _K
    if k is _UNSET:
        k = _resolve()
    return k  # type: ignore[no-any-return]


def reset() -> None:
    """Forget the resolved kernel: the next :func:`kernel` looks again (``UVNAV_PURE``)."""
    global _K
    _K = _UNSET


def _resolve() -> ModuleType | None:
    """The kernel as :func:`kernel` returns it, remembered in ``_K``."""
    global _K
    mod = native.kernel("lsq")
    if mod is None:
        _K = None
        return None
    if not {"solution", "ellipse"} <= _CLASSES.keys():
        return None  # a result module is not imported yet: pure Python now, look again later
    key = id(mod)
    if key not in _BOUND:
        _BOUND[key] = _bind(mod)
    _K = _BOUND[key]
    return _K  # type: ignore[no-any-return]


def _bind(mod: ModuleType) -> ModuleType | None:
    """Give ``mod`` its Python objects (its first argument, once routine addresses, is unused)."""
    mod._bind(None, math.hypot, _CLASSES["solution"], _CLASSES["ellipse"], np.power,
              np.hypot)
    return mod

"""The filter's compiled helpers that other rooms' kernels feed (``engine.native.kalman_predict``).

Transitional: the filter's own dispatch still lives in engine/filter; what ties the filter
kernel to the fix's kernel is made here, where both are known.
"""

from __future__ import annotations

from typing import Any

from engine import native
from engine.fast import lsq


def position_kernel(estimate_cls: type) -> Any:
    """The kernel whose ``position(source, grid._packed, x, P)`` makes the whole estimate of a
    state as an ``estimate_cls`` (``engine.run.cycle.PositionEstimate``), bound here to the
    compiled TM inverse and error ellipse that the compiled grid and fix use; None when any of
    the three kernels is not there (the Python makes it)."""
    k = native.kernel("kalman_predict")
    tm = native.kernel("tmgrid")
    fix = lsq.kernel()
    if k is None or tm is None or fix is None or not hasattr(k, "position"):
        return None
    k.bind_position(tm.inverse, fix.ellipse, estimate_cls)
    return k

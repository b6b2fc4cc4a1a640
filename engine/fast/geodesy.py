"""The TM grid with its scalar conversions in ``engine.native.tmgrid``.

:class:`FastTMGrid` is :class:`engine.geodesy.tmgrid.TMGrid` (the reference) whose forward,
inverse and convergence call the kernel on a packed copy of the grid's constants
(``_packed``, :func:`engine.native.tmgrid.pack`). Where the kernel declines (a central meridian
that is no float, a non-float argument, a math error) the reference method runs.
"""

from __future__ import annotations

import math
from typing import Any

from engine import native
from engine.geodesy.tmgrid import TMGrid

KERNEL: Any = native.kernel("tmgrid")
"""``engine.native.tmgrid``, or None (not built, stale, ``UVNAV_PURE=1``)."""


class FastTMGrid(TMGrid):
    """:class:`TMGrid` on the compiled kernel (the constants packed once per grid)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "_packed", self._pack())

    def _pack(self) -> bytearray | None:
        """The kernel's state (the constants and an empty memo of inverses), or None. Each
        constant is the float the reference computes: ``self._e**2``, the pole scale, ``A/a``,
        the factors of :func:`math.radians`/:func:`math.degrees`. A central meridian that is
        not a float or an int gets None (the reference runs)."""
        if KERNEL is None or not isinstance(self.cm_deg, (float, int)):
            return None
        try:
            cm = float(self.cm_deg)
        except OverflowError:  # an int beyond floats: the reference raises where it is used
            return None
        e, e2m = self._e, self._e2m
        k_pole = e2m**0.5 * math.exp(e * math.atanh(e))
        return KERNEL.pack((cm, e, e2m, self._A, self._A / self.ellipsoid.a_m,  # type: ignore[no-any-return]
                            e**2, k_pole, math.radians(1.0), math.degrees(1.0),
                            *self._alpha, *self._beta))

    def forward_full(self, lat_deg: float, lon_deg: float) -> tuple[float, float, float, float]:
        out = KERNEL.forward_full(self._packed, lat_deg, lon_deg)
        return super().forward_full(lat_deg, lon_deg) if out is None else out  # type: ignore[no-any-return]

    def forward(self, lat_deg: float, lon_deg: float) -> tuple[float, float]:
        out = KERNEL.forward(self._packed, lat_deg, lon_deg)
        return super().forward(lat_deg, lon_deg) if out is None else out  # type: ignore[no-any-return]

    def inverse(self, x_m: float, y_m: float) -> tuple[float, float]:
        """The kernel keeps its own memo (a ring in ``_packed``, the reference's rule)."""
        out = KERNEL.inverse(self._packed, x_m, y_m)
        return super().inverse(x_m, y_m) if out is None else out  # type: ignore[no-any-return]

    def _inverse(self, x_m: float, y_m: float) -> tuple[float, float]:
        out = KERNEL.inverse(self._packed, x_m, y_m, False)
        return super()._inverse(x_m, y_m) if out is None else out  # type: ignore[no-any-return]

    def convergence_deg(self, lat_deg: float, lon_deg: float) -> float:
        out = KERNEL.forward_full(self._packed, lat_deg, lon_deg)
        return super().convergence_deg(lat_deg, lon_deg) if out is None else out[2]  # type: ignore[no-any-return]

"""What the cycle hands out of a filter state: its position estimate (geodetic and grid, with
the error ellipse), its a priori position for the fix (thesis §6.4: the prediction as
pseudo-observations of a hybrid fix), and the arrays of a cycle's fix and updates made
read-only (a cycle's result is an immutable value).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from engine.filter.params import FilterParams
from engine.filter.predict import predict_step
from engine.filter.state import IX, IY, FilterState, estimate_parts
from engine.filter.update import UpdateResult
from engine.geodesy.tmgrid import TMGrid
from engine.lsq.confidence import Ellipse, error_ellipse
from engine.lsq.fix import FixResult
from engine.systems.base import PositionPrior


@dataclass(frozen=True, slots=True)
class PositionEstimate:
    """A position with its precision: geodetic (degrees, working datum), TM grid (m) on the
    cycle's CM, depth (m, positive down), the 2×2 horizontal VCV (m², x/y) and its ellipse."""

    source: str
    lat_deg: float
    lon_deg: float
    x_m: float
    y_m: float
    depth_m: float
    cov: np.ndarray
    ellipse: Ellipse | None


def position_estimate(source: str, grid: TMGrid, x: float, y: float, depth: float,
                      cov: np.ndarray) -> PositionEstimate:
    """A position estimate at grid (x, y) m with its 2×2 VCV ``cov`` (m², made read-only): its
    geodetic position and, when the VCV is finite, its error ellipse."""
    lat, lon = grid.inverse(x, y)
    ell = error_ellipse(cov) if all(map(math.isfinite, cov.ravel().tolist())) else None
    cov.setflags(write=False)
    if ell is not None:
        ell.eigenvectors.setflags(write=False)
    return PositionEstimate(source, lat, lon, x, y, depth, cov, ell)


def filter_estimate(source: str, grid: TMGrid, fs: FilterState) -> PositionEstimate:
    """The horizontal position of a filter state as an estimate (grid ``grid``), its depth and
    its position VCV with the error ellipse."""
    x, y, z, cov, finite = estimate_parts(fs)
    lat, lon = grid.inverse(x, y)
    ell = error_ellipse(cov) if finite else None
    if ell is not None:
        ell.eigenvectors.setflags(write=False)
    return PositionEstimate(source, lat, lon, x, y, z, cov, ell)


def predict_estimate(state: FilterState, dt: float, params: FilterParams, source: str,
                     grid: TMGrid) -> tuple[FilterState, np.ndarray, PositionEstimate]:
    """The time update over Δt s (:func:`engine.filter.predict.predict_step`) and the estimate
    of the predicted state: (state, Φ, estimate)."""
    new, phi = predict_step(state, dt, params)
    return new, phi, filter_estimate(source, grid, new)


def filter_prior(fs: FilterState) -> tuple[tuple[float, float], PositionPrior]:
    """The fix's provisional position (grid m) and the filter's a priori position: the state's
    horizontal position and a copy of its 2×2 VCV (m²)."""
    x, y = fs.x[IX:IY + 1].tolist()
    return (x, y), PositionPrior(x, y, fs.P[IX:IY + 1, IX:IY + 1].copy())


def freeze_result(fix: FixResult | None, phi: np.ndarray | None,
                  *updates: UpdateResult | None) -> None:
    """Make the arrays a cycle hands out read-only, besides its estimates and filter states
    (which already are): the fix's VCV, ellipse axes and raw LOPs, the smoother link's Φ and
    each filter update's innovation, S, K and LS factors (the per-slot arrays inside
    ``fix.tested`` belong to engine.lsq.snooping)."""
    if fix is not None:
        fix.cov.setflags(write=False)
        if fix.ellipse is not None:
            fix.ellipse.eigenvectors.setflags(write=False)
        raw = fix.raw_lops
        if raw is not None:
            for a in (raw.A, raw.omc_m, raw.Cl, raw.x_ref):
                a.setflags(write=False)
    if phi is not None:
        phi.setflags(write=False)
    for u in updates:
        if u is not None:
            for a in (u.innovation, u.S, u.K, u.ls.l_inv, u.ls.w):
                a.setflags(write=False)

"""The collaborators a run's cycle does its hot work with, chosen once per run.

:data:`REFERENCE` holds the navigation modules' own objects (pure Python, the reference of every
number the engine logs). :func:`choose` asks :mod:`engine.fast` which of them it offers on the
compiled kernels for this run and takes those; the cycle calls whichever it is given and never
knows which it is (the model is passed in, as FilterPy's filters take theirs).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from engine.filter.estimate import filter_estimate, filter_prior, freeze_result, predict_estimate
from engine.filter.measurements import lse_measurement
from engine.filter.predict import predict_step
from engine.filter.update import innovation_distance, update, update_rows, update_rows_gated
from engine.geodesy.ellipsoid import Datum, Ellipsoid
from engine.geodesy.ellipsoidal import DatumShift, GeodesicSolver, datum_shift
from engine.geodesy.tmgrid import TMGrid
from engine.io.outlog import OutLogWriter
from engine.io.runfile import QuickParser
from engine.lsq.fix import FixResult, compute_fix
from engine.systems.base import NavSystem


def positional(cls: type) -> Callable[..., Any]:
    """The constructor of dataclass ``cls`` from every field positionally: the class."""
    return cls


@dataclass(frozen=True)
class CycleParts:
    """The cycle's collaborators: each field a reference object by default."""

    grid: Callable[[Ellipsoid, float], TMGrid] = TMGrid
    """The TM grid class of the run (ellipsoid, central meridian degrees)."""
    datum_shift: Callable[[Datum, Datum], DatumShift] = datum_shift
    """The datum shifts of the run (source datum, destination datum)."""
    geodesic: Callable[[Ellipsoid], GeodesicSolver] = GeodesicSolver
    """The geodesic solver of the run's working ellipsoid."""
    systems: Mapping[NavSystem, NavSystem] = field(default_factory=dict)
    """Registry system → the system the run reads it with (the registry's own where none)."""

    compute_fix: Callable[..., FixResult] = compute_fix
    """The fix of a cycle (:func:`engine.lsq.fix.compute_fix`'s arguments)."""

    predict: Callable[..., Any] = predict_step
    """The filter's time update (:func:`engine.filter.predict.predict_step`'s arguments)."""
    predict_estimate: Callable[..., Any] = predict_estimate
    """The time update and the predicted state's estimate
    (:func:`engine.filter.estimate.predict_estimate`)."""
    estimate: Callable[..., Any] = filter_estimate
    """A filter state's position estimate (:func:`engine.filter.estimate.filter_estimate`)."""
    prior: Callable[..., Any] = filter_prior
    """The fix's start and prior from the prediction
    (:func:`engine.filter.estimate.filter_prior`)."""
    update: Callable[..., Any] = update
    """The measurement update (:func:`engine.filter.update.update`)."""
    update_rows: Callable[..., Any] = update_rows
    """The update with a cycle's sensor rows (:func:`engine.filter.update.update_rows`)."""
    update_gated: Callable[..., Any] = update_rows_gated
    """The update with the depth and the fix, and the gate's distance
    (:func:`engine.filter.update.update_rows_gated`)."""
    innovation_distance: Callable[..., Any] = innovation_distance
    """The gross-error gate's distance (:func:`engine.filter.update.innovation_distance`)."""
    lse_measurement: Callable[..., Any] = lse_measurement
    """The LSE's rows for the filter (:func:`engine.filter.measurements.lse_measurement`)."""
    freeze: Callable[..., None] = freeze_result
    """A cycle's arrays made read-only (:func:`engine.filter.estimate.freeze_result`)."""
    make: Callable[[type], Callable[..., Any]] = positional
    """The constructor taking every field positionally of a result dataclass of the cycle
    (:func:`positional`: the class itself)."""
    # The run's input and output around the cycle (None: the reference's own way).
    run_record: QuickParser | None = None
    """The ``.RUN`` reader's quick parser of the usual line
    (:data:`engine.io.runfile.QuickParser`); None: every line by the checked parser."""
    out_writer: Callable[..., Callable[[OutLogWriter, Any], None]] | None = None
    """Makes the run's ``.OUT`` block writer ``write(out, result)`` from the reference's block
    (:data:`engine.run.records.BLOCK_SHAPES`, :func:`~engine.run.records.cycle_block`); None:
    the reference's writer, :func:`engine.run.records.write_block`."""
    untrack: Callable[[Any], None] | None = None
    """Takes a kept cycle result off the cyclic collector's lists (:mod:`engine.run.retained`);
    None: nothing is untracked."""

    def run_systems(self, registered: tuple[NavSystem, ...]) -> tuple[NavSystem, ...]:
        """The run's systems, in the order of ``registered`` (the registry's)."""
        return tuple(self.systems.get(s, s) for s in registered)


REFERENCE = CycleParts()
"""The pure-Python parts: what runs with ``UVNAV_PURE=1`` or without the kernels."""


def choose() -> CycleParts:
    """The parts of a run: the compiled one (:func:`engine.fast.parts`) of each part that has
    one built, current and passing its probe, the reference's otherwise."""
    from engine import fast

    return CycleParts(**fast.parts())

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

from engine.geodesy.ellipsoid import Datum, Ellipsoid
from engine.geodesy.ellipsoidal import DatumShift, GeodesicSolver, datum_shift
from engine.geodesy.tmgrid import TMGrid
from engine.io.outlog import OutLogWriter
from engine.io.runfile import QuickParser
from engine.lsq.fix import FixResult, compute_fix
from engine.systems.base import NavSystem


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

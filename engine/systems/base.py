"""The seam between one navigation system, the processing cycle and the least-squares fix.

A navigation system (GPS, Decca, the Obs-menu bearings and distances, later Loran-C …) is one
module with one object that satisfies :class:`NavSystem`, listed in the registry
``engine.systems.registry.SYSTEMS``. Each cycle it is asked twice (docs/SYSTEMS.md):

1. :meth:`NavSystem.read` — from the cycle inputs (record, run context, a priori position)
   make this cycle's reading: the value the fix takes, the operator messages, and what the
   cycle keeps (e.g. the Decca lane track);
2. :meth:`NavSystem.observations` — from that value make an :class:`ObservationSet`: its rows of
   the observation equations at a grid point (design rows, O − C, a priori VCV block; thesis
   ch. 5.3, eq. 5.1a–g) and its page data at the estimate (:class:`LopReading`).

The observation vector of the fix is the concatenation of every system's slots, in registry
order (``slot_labels`` says how many and their short names).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from datetime import datetime
from typing import Any, Protocol

import numpy as np

from engine.geodesy.ellipsoidal import GeodesicSolver
from engine.geodesy.tmgrid import TMGrid
from engine.io.runfile import RunRecord

SYSTEMS_COLUMNS = 5
"""Width of the systems string of the .OUT/JSONL (``G...D``): one column per system letter."""

EVAL_ERRORS = (ValueError, ArithmeticError, np.linalg.LinAlgError)
"""What the geodesy and the system models raise for points where they cannot be evaluated (e.g.
an OverflowError of the TM inverse far off the grid)."""


@dataclass(frozen=True, slots=True)
class PositionPrior:
    """The filter's predicted position used as two pseudo-LOPs when too few LOPs exist (THEORY
    §4.6, §9.3): grid (x, y) in metres and its 2×2 VCV (m², order x, y)."""

    x_m: float
    y_m: float
    cov: np.ndarray


@dataclass(frozen=True, slots=True)
class LopReading:
    """Page data of one observation row at the estimate (Pg 631/633), before testing.

    ``index`` is the row within its system's slots; ``read``/``correction``/``calc`` are in the
    system's own unit (degrees, lanes, metres); ``az_deg`` is the azimuth of the LOP.
    """

    index: int
    system: str
    pattern: str
    read: float
    correction: float
    calc: float
    az_deg: float


class Point:
    """A grid point (m, TM grid of the working datum) where rows are evaluated, with its geodetic
    latitude/longitude (degrees, working datum) computed once, on first use."""

    __slots__ = ("_latlon", "geodesic", "grid", "x", "y")

    def __init__(self, grid: TMGrid, geodesic: GeodesicSolver, x: float, y: float,
                 latlon: tuple[float, float] | None = None) -> None:
        self.grid = grid
        self.geodesic = geodesic
        self.x = x
        self.y = y
        self._latlon = latlon

    @property
    def latlon(self) -> tuple[float, float]:
        """Geodetic (lat, lon) of the point in degrees (the grid inverted once)."""
        if self._latlon is None:
            self._latlon = self.grid.inverse(self.x, self.y)
        return self._latlon


class ObservationError(Exception):
    """A system's observations cannot be formed for this fix (the fix fails with ``reason``);
    ``messages`` are the operator texts made before the failure."""

    def __init__(self, reason: str, messages: Sequence[str] = ()) -> None:
        super().__init__(reason)
        self.reason = reason
        self.messages = tuple(messages)


class ObservationSet(Protocol):
    """One system's observations in one fix, in the system's own slot order."""

    messages: tuple[str, ...]
    """Operator texts made while forming the observations (e.g. a half-zone warning)."""

    def available(self) -> list[bool]:
        """Which of the system's slots hold an observation to use (before exclusions)."""
        ...

    def linearise(self, p: Point, slot0: int, A: list[float], b: list[float],
                  Cl: np.ndarray) -> None:
        """Write the rows of the system's slots (first slot ``slot0``) at ``p``: design rows
        (∂/∂x, ∂/∂y, metres per metre) into the row-major flat ``A``, O − C (m) into ``b`` and
        the a priori VCV block (m²) into ``Cl`` (thesis ch. 5.3, eq. 5.1a–g)."""
        ...

    def readings(self, p: Point) -> list[LopReading]:
        """The page data of each observation at the estimate ``p`` (Pg 631/633)."""
        ...

    def nearest_station_m(self, p: Point, used: Sequence[bool]) -> float:
        """Distance (m) from ``p`` to the nearest station of a used row (``used`` per own slot;
        ``math.inf`` when the system's LOPs do not curve around a station)."""
        ...


@dataclass(frozen=True, slots=True)
class CycleInputs:
    """What a system reads in one cycle: the record, the run (``config`` is the
    ``engine.run.config.RunConfig``, ``context`` the ``engine.run.cycle.RunContext``, ``nav``
    the ``NavState`` before the cycle: typed loosely, the systems sit below the run loop), the
    cycle's grid and CM, the provisional position ``x_start`` (grid m), the filter's a priori
    position ``prior`` (None without a filter) and the readings of the systems before it in the
    registry (Decca checks its lanes against GPS)."""

    config: Any
    context: Any
    nav: Any
    record: RunRecord
    grid: TMGrid
    cm_deg: float
    x_start: tuple[float, float]
    prior: PositionPrior | None
    earlier: Mapping[str, SystemReading]

    @property
    def time(self) -> datetime:
        """Time of the record (UTC)."""
        return self.record.time


@dataclass(frozen=True, slots=True)
class SystemReading:
    """One system's outcome of :meth:`NavSystem.read`: ``value`` is what the fix takes under the
    system's name (None: nothing this cycle), ``messages`` the operator texts, ``detail`` what the
    cycle keeps of it (system-specific: the GPS input of Pg 100, the Decca lane track)."""

    value: Any = None
    messages: tuple[str, ...] = ()
    detail: Any = None
    observes: bool = False
    """Whether ``value`` holds an observation: the cycle computes a fix when any system's does."""


class NavSystem(Protocol):
    """One navigation system behind the seam (see the module docstring)."""

    name: str
    """Key of the system in the registry, the fix's inputs and :func:`slots_of` ("gps")."""
    letter: str
    """Its letter in the systems string ("G"); "" for none."""
    column: int | None
    """Its column in the systems string (0 … SYSTEMS_COLUMNS − 1); None for none."""
    slot_labels: tuple[str, ...]
    """Short names of its observation slots (Pg 821/830: "Lat", "Lon"); their number is the
    system's share of the observation vector."""

    def is_on(self, config: Any) -> bool:
        """Whether the run configuration switches the system on (its systems-string letter)."""
        ...

    def fix_source(self, config: Any) -> tuple[object, ...]:
        """What identifies the system's error process in the LSE while it is on (receiver type,
        chain and patterns; () when off or never a source): a change restarts the filter's
        fix-error states (``engine.run.cycle.fix_source``)."""
        ...

    def read(self, inputs: CycleInputs) -> SystemReading:
        """This cycle's reading of the system (see :class:`SystemReading`)."""
        ...

    def observations(self, value: Any, p0: Point) -> ObservationSet | None:
        """The observation set of ``value`` (what :meth:`read` gave, or a caller's own input) for
        a fix starting at ``p0``; None when there is nothing to observe. Raises
        :class:`ObservationError` when the observations cannot be formed."""
        ...

    def row_name(self, index: int, value: Any) -> str | None:
        """The operator's name of row ``index`` ("GPS Lat", "Decca Red"); ``value`` as for
        :meth:`observations` (for GPS the label "GPS" or "KF"); None if there is no such row."""
        ...


def set_row(rows: list[float], slot: int, d_dx: float, d_dy: float) -> None:
    """Put the design-matrix row (∂/∂x, ∂/∂y) of ``slot`` into the row-major flat ``rows``."""
    rows[2 * slot] = d_dx
    rows[2 * slot + 1] = d_dy


def lop_azimuth_deg(row: Sequence[float]) -> float:
    """Azimuth of an LOP whose metric gradient is ``row`` = (∂/∂x, ∂/∂y): gradient + 90°."""
    return (math.degrees(math.atan2(row[0], row[1])) + 90.0) % 360.0


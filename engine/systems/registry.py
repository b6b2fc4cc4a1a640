"""The registry of navigation systems and the observation-vector layout it defines.

Registry order is slot order: each system owns ``len(slot_labels)`` consecutive slots of the
fix's observation vector (Pg 821/830), and it is the order in which the cycle reads the systems
(a system may use the readings of those before it). Adding a system: one module with a
:class:`engine.systems.base.NavSystem` object, listed here (docs/SYSTEMS.md).
"""

from __future__ import annotations

import functools

from engine.systems.base import SYSTEMS_COLUMNS, NavSystem
from engine.systems.decca import DECCA
from engine.systems.gps import GPS
from engine.systems.manual import MANUAL

SYSTEMS: tuple[NavSystem, ...] = (GPS, DECCA, MANUAL)
"""Every navigation system, in slot order."""


@functools.cache
def _layout(systems: tuple[NavSystem, ...]) -> dict[str, range]:
    slots: dict[str, range] = {}
    first = 0
    for system in systems:
        slots[system.name] = range(first, first + len(system.slot_labels))
        first += len(system.slot_labels)
    return slots


def layout(systems: tuple[NavSystem, ...] | None = None) -> dict[str, range]:
    """The slots of each system in the observation vector, by system name (of ``systems``, by
    default the registry as it is now: a test may register a system of its own)."""
    return _layout(SYSTEMS if systems is None else systems)


def slots_of(name: str) -> range:
    """The observation slots of system ``name`` ("gps", "decca", "manual")."""
    return layout()[name]


def n_slots() -> int:
    """Length of the observation vector."""
    return sum(len(r) for r in layout().values())


def owner_of(slot: int) -> tuple[NavSystem, int] | None:
    """The system owning observation ``slot`` and the row within it (None: no such slot)."""
    slots = layout()
    for system in SYSTEMS:
        r = slots[system.name]
        if slot in r:
            return system, slot - r.start
    return None


N_SLOTS = n_slots()
"""Length of the observation vector of the built-in systems (10: GPS 2, Decca 3, bearings/
distances 5); the slots of systems appended later follow these."""

SLOT_LABELS: tuple[str, ...] = tuple(label for s in SYSTEMS for label in s.slot_labels)
"""Short name of every built-in slot (Pg 821/830: "Lat", "Lon", "Red", "Grn", "Prp", "BRR1" …)."""


def systems_string(config: object) -> str:
    """The systems column of .OUT/JSONL: each switched-on system's letter in its column, "."
    elsewhere (``G...D``: GPS and Decca on)."""
    chars = ["."] * SYSTEMS_COLUMNS
    for system in SYSTEMS:
        if system.column is not None and system.is_on(config):
            chars[system.column] = system.letter
    return "".join(chars)

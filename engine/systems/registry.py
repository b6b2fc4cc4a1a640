"""The registry of navigation systems and the observation-vector layout it defines.

Registry order is slot order: each system owns ``len(slot_labels)`` consecutive slots of the
fix's observation vector (Pg 821/830), and it is the order in which the cycle reads the systems
(a system may use the readings of those before it). Adding a system: one module with a
:class:`engine.systems.base.NavSystem` object, listed here (docs/SYSTEMS.md).
"""

from __future__ import annotations

from engine.systems.base import SYSTEMS_COLUMNS, NavSystem
from engine.systems.decca import DECCA
from engine.systems.gps import GPS
from engine.systems.manual import MANUAL

SYSTEMS: tuple[NavSystem, ...] = (GPS, DECCA, MANUAL)
"""Every navigation system, in slot order."""


def _layout() -> dict[str, range]:
    slots: dict[str, range] = {}
    first = 0
    for system in SYSTEMS:
        slots[system.name] = range(first, first + len(system.slot_labels))
        first += len(system.slot_labels)
    return slots


SLOTS: dict[str, range] = _layout()
"""The slots of each system in the observation vector, by system name."""

N_SLOTS = sum(len(r) for r in SLOTS.values())
"""Length of the observation vector (10: GPS 2, Decca 3, bearings/distances 5)."""

SLOT_LABELS: tuple[str, ...] = tuple(label for s in SYSTEMS for label in s.slot_labels)
"""Short name of every slot (Pg 821/830: "Lat", "Lon", "Red", "Grn", "Prp", "BRR1" …)."""


def slots_of(name: str) -> range:
    """The observation slots of system ``name`` ("gps", "decca", "manual")."""
    return SLOTS[name]


def owner_of(slot: int) -> tuple[NavSystem, int] | None:
    """The system owning observation ``slot`` and the row within it (None: no such slot)."""
    for system in SYSTEMS:
        r = SLOTS[system.name]
        if slot in r:
            return system, slot - r.start
    return None


def systems_string(config: object) -> str:
    """The systems column of .OUT/JSONL: each switched-on system's letter in its column, "."
    elsewhere (``G...D``: GPS and Decca on)."""
    chars = ["."] * SYSTEMS_COLUMNS
    for system in SYSTEMS:
        if system.column is not None and system.is_on(config):
            chars[system.column] = system.letter
    return "".join(chars)

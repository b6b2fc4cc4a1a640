"""The systems seam: the registry defines the observation-vector layout, the slot names, the
systems string and the operator's LOP names exactly as the pages and the .OUT have them."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from engine.lsq.fix import (
    N_SLOTS,
    SLOT_BRR0,
    SLOT_DECCA,
    SLOT_GPS_LAT,
    SLOT_GPS_LON,
    FixResult,
    LopRow,
    ManualObservation,
    lop_name,
)
from engine.systems.base import SYSTEMS_COLUMNS
from engine.systems.registry import SLOT_LABELS, SYSTEMS, owner_of, slots_of, systems_string


def test_layout_is_the_fixed_ten_slots() -> None:
    """GPS 0–1, Decca 2–4, bearings/distances 5–9 (Pg 821/830), now derived from the registry."""
    assert [s.name for s in SYSTEMS] == ["gps", "decca", "manual"]
    assert (SLOT_GPS_LAT, SLOT_GPS_LON, SLOT_DECCA, SLOT_BRR0, N_SLOTS) == (0, 1, (2, 3, 4), 5, 10)
    assert SLOT_LABELS == ("Lat", "Lon", "Red", "Grn", "Prp",
                           "BRR1", "BRR2", "BRR3", "BRR4", "BRR5")
    assert slots_of("decca") == range(2, 5)
    owner = owner_of(7)
    assert owner is not None and owner[0].name == "manual" and owner[1] == 2
    assert owner_of(10) is None


def test_systems_string_has_each_letter_in_its_column() -> None:
    """``G...D``: GPS in column 0, Decca in column 4 (SINS, Omega, Loran-C between)."""
    def cfg(gps: bool, decca: bool) -> SimpleNamespace:
        return SimpleNamespace(gps=SimpleNamespace(on=gps), decca=SimpleNamespace(on=decca))

    assert systems_string(cfg(True, True)) == "G...D"
    assert systems_string(cfg(False, True)) == "....D"
    assert systems_string(cfg(False, False)) == "." * SYSTEMS_COLUMNS
    columns = [s.column for s in SYSTEMS if s.column is not None]
    assert len(columns) == len(set(columns))


def test_each_system_names_its_rows() -> None:
    obs = [ManualObservation("bearing", "Heiloo", 52.6, 4.7, 90.0, 1.0, "periscope")]
    assert lop_name(0) == "GPS Lat" and lop_name(1, system="KF") == "KF Lon"
    assert lop_name(3) == "Decca Grn"
    assert lop_name(5, manual=obs) == "periscope Brg Heiloo"
    assert lop_name(6, manual=obs) == "slot 6" and lop_name(12) == "slot 12"


def test_rows_of_gives_one_systems_rows() -> None:
    rows = tuple(LopRow(slot, "x", "p", 0.0, 0.0, 0.0, 0.0, 0.0, True) for slot in (0, 1, 3, 5))
    fix = FixResult(True, None, 0.0, 0.0, 52.0, 4.0, np.eye(2), None, "I", 4, 1.0, 1.0, rows,
                    None)
    assert [r.slot for r in fix.rows_of("gps")] == [0, 1]
    assert [r.slot for r in fix.rows_of("decca")] == [3]
    assert [r.slot for r in fix.rows_of("manual")] == [5]
    assert fix.apriori_vcv("gps") is None  # no adjustment
    assert fix.lse_ok and not FixResult(False, "no", 0.0, 0.0, 0.0, 0.0, np.eye(2), None, "I",
                                        0, 0.0, None, (), None).lse_ok

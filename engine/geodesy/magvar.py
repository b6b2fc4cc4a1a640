"""Magnetic variation (declination) from the International Geomagnetic Reference Field.

A compass heading (NMEA HDG, VHW magnetic) is turned into a true heading by adding the
*variation* D, the angle from true north to the horizontal magnetic field, east positive. When a
log gives none, D is computed here from IGRF-14 (IAGA Working Group V-MOD, 2024: definitive
models 1900–2020, the 2025 model and its secular variation to 2030) through the maintained
package ``ppigrf`` (its geodetic ``igrf``: the field's east and north components Be, Bn at the
WGS84 position, 0 km height), D = atan2(Be, Bn).

Why IGRF, not the World Magnetic Model: IGRF spans every date since 1900, so a log of any
year gets a variation (the WMM covers 2010–2030 in ``pygeomag``, the Python WMM); at sea level
the two agree to a few tenths of a degree for recent years, below a yacht compass's own error.
The model is a smooth main field: local anomalies (ships' steel is deviation, not variation)
are not in it.

Plain numbers in, plain numbers out; ``ppigrf`` (which imports pandas, ~0.5 s) is imported on
the first call only.
"""

from __future__ import annotations

import math
from datetime import UTC, date, datetime

__all__ = ["MODEL", "MODEL_FIRST", "MODEL_END", "declination_deg", "model_covers"]

MODEL = "IGRF-14"
"""The model's name, as the run reports it."""
MODEL_FIRST = date(1900, 1, 1)
"""First date of the model (its first coefficient set)."""
MODEL_END = date(2030, 1, 1)
"""The model is valid before this date (the end of the 2025 model's secular variation)."""


def model_covers(day: date) -> bool:
    """True when ``day`` (UTC) is inside the model's span [MODEL_FIRST, MODEL_END)."""
    return MODEL_FIRST <= day < MODEL_END


def declination_deg(lat_deg: float, lon_deg: float, when: datetime | date) -> float | None:
    """Magnetic variation D [deg, east positive, (-180, 180]] at the geodetic WGS84 position
    (``lat_deg`` north, ``lon_deg`` east, sea level) and UTC time ``when``; None outside the
    model's span (:func:`model_covers`) or for a position that is not finite."""
    day = when.date() if isinstance(when, datetime) else when
    if not (model_covers(day) and math.isfinite(lat_deg) and math.isfinite(lon_deg)
            and -90.0 <= lat_deg <= 90.0):
        return None
    if isinstance(when, datetime):
        moment = when.astimezone(UTC).replace(tzinfo=None) if when.tzinfo else when
    else:
        moment = datetime(when.year, when.month, when.day)
    import ppigrf  # on first use (it imports pandas)

    be, bn, _bu = ppigrf.igrf(lon_deg, lat_deg, 0.0, moment)
    return math.degrees(math.atan2(float(be.flat[0]), float(bn.flat[0])))

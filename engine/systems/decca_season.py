"""Decca sky-wave conditions: the season and time of day that scale the a priori VCV.

The thesis' sky-wave standard deviations (A4.3a/b, Table A4.1) "are valid for summer night
conditions over seawater. For a Summer's day these values have to be divided by 8, for a
winter's day by 2 and for a winter's night to be multiplied by 1.5" (thesis L8352). On the
variances that is the divisor ``Decca.CF`` (A8.2, L8763–8764): 64 summer day, 4 winter day,
1 summer night, 1/2.25 winter night. The thesis' program fixes it at 64 ("Summer's day
conditions"); :func:`decca_condition` chooses it from the sun instead:

* **Night or day** by the sun's elevation at the receiver (:mod:`engine.geodesy.sun`). The
  thesis gives no sunrise/sunset rule for Decca; it says the transitions are the unstable part
  (sunrise and sunset "of intermediate stability ... particularly near the end of the sunrise
  transitions", L1023; transition conditions can be on the path while the receiver is in day,
  L1025; lane slips "most likely to occur at twilight", L3295) and that Decca is 6–8 times less
  accurate at night (L758). [choice] The cautious side: the night variance holds until the sun
  is :data:`DAY_MIN_SUN_ELEVATION_DEG` above the horizon (the 6° depth of civil twilight
  mirrored above it: at 50–55° N about 35–60 min after sunrise and before sunset).
* **Summer or winter** by the half-year of the receiver's hemisphere: summer while the sun's
  declination is on the receiver's side of the equator (the spring to the autumn equinox:
  21 March – 23 September in the north, the other half in the south); the thesis' "stronger in
  winter than in summer" (L909) names no boundary. [choice] On the equator (or at an equinox's
  instant) it is winter, the larger variance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import datetime

from engine.geodesy.sun import solar_declination_deg, solar_position_deg

DECCA_CF_CONDITIONS: dict[str, tuple[str, float]] = {
    "SD": ("summer day", 64.0),
    "WD": ("winter day", 4.0),
    "SN": ("summer night", 1.0),
    "WN": ("winter night", 1.0 / 2.25),
}
"""``Decca.CF`` per season and time of day (A8.2, thesis L8352; Pg 615 "(SD)"): the divisor of the
Decca sky-wave variances. Code → (name, CF)."""

DAY_MIN_SUN_ELEVATION_DEG = 6.0
"""Sun elevation (deg) from which the day variance applies; below it (twilight and night) the
night variance ([choice], see the module docstring)."""


@dataclass(frozen=True, slots=True)
class DeccaCondition:
    """The sky-wave condition of one epoch: ``code`` (``SD``, ``WD``, ``SN``, ``WN``), its
    ``cf`` (the divisor of the sky-wave variances) and the ``sun_deg`` it was chosen by (the
    sun's elevation at the receiver, degrees)."""

    code: str
    cf: float
    sun_deg: float

    @property
    def name(self) -> str:
        """"summer day" …"""
        return DECCA_CF_CONDITIONS[self.code][0]


def is_local_summer(t: datetime, lat_deg: float) -> bool:
    """Whether ``t`` is in the summer half-year of latitude ``lat_deg`` (degrees north): the
    sun's declination on the same side of the equator (never on the equator itself; the rule
    :func:`decca_condition` applies)."""
    return solar_declination_deg(t) * lat_deg > 0.0


def decca_condition(t: datetime, lat_deg: float, lon_deg: float) -> DeccaCondition:
    """The sky-wave condition at UTC ``t`` for a receiver at ``lat_deg``, ``lon_deg`` (degrees,
    north and east positive; any datum)."""
    decl, sun = solar_position_deg(t, lat_deg, lon_deg)
    if not math.isfinite(sun):
        raise ValueError(f"no sun elevation at {lat_deg!r}, {lon_deg!r}")
    code = ("S" if decl * lat_deg > 0.0 else "W") + (
        "D" if sun >= DAY_MIN_SUN_ELEVATION_DEG else "N")
    return DeccaCondition(code, DECCA_CF_CONDITIONS[code][1], sun)

"""What kind of input a run has, for labelling its readings (Pg 100, Pg 620): a 1993 ``.RUN``
file (the thesis' submarine: gyro, log, rudder, inclinometer, pressure, echo sounder) or an
NMEA 0183 log or live stream (docs/NMEA.md: heading from HDT (a gyro) or HDG (a magnetic
compass, made true with a variation), water speed, depth, GNSS position with COG/SOG; never a
rudder, an inclinometer or a pressure sensor).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING
from weakref import WeakKeyDictionary

if TYPE_CHECKING:
    from engine.api import NmeaStats, Session

COMPASS_SENTENCES = ("HDG",)
"""Sentences whose heading is magnetic (made true with a variation)."""
GYRO_SENTENCES = ("HDT",)
"""Sentences whose heading is true (a gyro, or a satellite compass)."""


@dataclass(frozen=True)
class InputKind:
    """``nmea``: NMEA input (no rudder, inclinometer or pressure; GNSS as lat/lon; positions
    to the precision of the fix). ``heading``: ``gyro``, ``compass`` or ``heading`` (not
    known yet). ``variation``: how a compass heading is made true ("" for a gyro)."""

    nmea: bool = False
    heading: str = "gyro"
    variation: str = ""

    @property
    def heading_short(self) -> str:
        """``GYRO``, ``COMPASS`` or ``HDG`` (Pg 100's sensor strip)."""
        return {"gyro": "GYRO", "compass": "COMPASS"}.get(self.heading, "HDG")

    @property
    def heading_name(self) -> str:
        """``Gyro``, ``Compass`` or ``Heading`` (Pg 620's rows)."""
        return {"gyro": "Gyro", "compass": "Compass"}.get(self.heading, "Heading")


RUN_FILE = InputKind()
"""A 1993 ``.RUN`` file: the thesis' labels."""


def heading_kind(used: Mapping[str, int]) -> str:
    """``gyro`` (HDT true headings used), ``compass`` (HDG magnetic ones) or ``heading``."""
    if any(used.get(s) for s in GYRO_SENTENCES):
        return "gyro"
    if any(used.get(s) for s in COMPASS_SENTENCES):
        return "compass"
    return "heading"


LIVE_STATS: WeakKeyDictionary[Session, NmeaStats] = WeakKeyDictionary()
"""The sentences a live stream gave so far, per session of a live run (the run controller
registers them: a page has the session, and a log's are its ``nmea_scan``)."""


def input_kind(session: Session | None, stats: NmeaStats | None = None) -> InputKind:
    """The kind of ``session``'s input; ``stats``: the sentences a live stream gave so far
    (else :data:`LIVE_STATS`; a log's are the session's ``nmea_scan``)."""
    if session is None:
        return RUN_FILE
    from engine.api import is_source_url  # the live-source module: not at start-up

    scan = stats if stats is not None else LIVE_STATS.get(session, session.nmea_scan)
    if scan is None and not is_source_url(session.source_name):
        return RUN_FILE
    heading = heading_kind(scan.used) if scan is not None else "heading"
    variation = ""
    if heading == "compass":
        v = session.config.nmea.variation_deg
        variation = ("variation from the sentences" if v == "none" else
                     f"variation {v}" if isinstance(v, str) else
                     f"variation {abs(v):.1f}°{'E' if v >= 0 else 'W'} configured")
    return InputKind(True, heading, variation)

"""Hand-written NMEA sentences for the tests: the checksum is computed here independently of
the code under test (XOR of the characters between ``$`` and ``*``, NMEA 0183 §5.2.1)."""

from __future__ import annotations

import operator
from functools import reduce


def nmea(body: str, start: str = "$") -> str:
    """``$BODY*HH`` with the checksum of ``body``."""
    return f"{start}{body}*{reduce(operator.xor, map(ord, body), 0):02X}"


def hhmmss(t_s: int) -> str:
    """Seconds of the day → ``hhmmss.00``."""
    return f"{t_s // 3600:02d}{t_s // 60 % 60:02d}{t_s % 60:02d}.00"


def ddmm(lat_deg: float, width: int = 2) -> str:
    """Degrees → ``ddmm.mmmm`` (``dddmm.mmmm`` with width 3), magnitude only."""
    a = abs(lat_deg)
    d = int(a)
    return f"{d:0{width}d}{(a - d) * 60:07.4f}"

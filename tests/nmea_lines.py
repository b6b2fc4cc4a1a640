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


def voyage(n_s: int, t0_s: int = 43200, day: str = "021226", lat0: float = 52.8333333333,
           lon0: float = 4.5, course_deg: float = 45.0, speed_kn: float = 6.0,
           damage: bool = True) -> list[str]:
    """``n_s`` seconds of a vessel on a steady course: GGA + RMC each second, HDT and VHW each
    second, DBT every 2 s, a GSV each second; with ``damage`` also a bad checksum, a
    truncated line, an AIS line and an empty HDT now and then. Positions from the flat-earth
    step: 1 kn = 1 arc minute of latitude per hour (good to ~1e-9° over minutes)."""
    import math

    out = []
    dn = speed_kn * math.cos(math.radians(course_deg)) / 60.0 / 3600.0  # deg lat per s
    de = speed_kn * math.sin(math.radians(course_deg)) / 60.0 / 3600.0
    for k in range(n_s):
        t = t0_s + k
        lat = lat0 + dn * k
        lon = lon0 + de * k / math.cos(math.radians(lat))
        pos = f"{ddmm(lat)},N,{ddmm(lon, 3)},E"
        out.append(nmea(f"GPGGA,{hhmmss(t)},{pos},1,09,0.8,3.0,M,46.0,M,,"))
        out.append(nmea(f"GPRMC,{hhmmss(t)},A,{pos},{speed_kn:.1f},{course_deg:.1f},{day},,,A"))
        out.append(nmea(f"HEHDT,{course_deg:.1f},T"))
        out.append(nmea(f"VWVHW,{course_deg:.1f},T,,M,{speed_kn:.1f},N,,K"))
        if k % 2 == 0:
            out.append(nmea(f"SDDBT,,f,{20.0 + k * 0.01:.2f},M,,F"))
        out.append(nmea("GPGSV,3,1,11,03,03,111,00,04,15,270,00,06,01,010,00,13,06,292,00"))
        if damage and k % 17 == 5:
            out.append(nmea("HEHDT,12.0,T")[:-2] + "00")  # bad checksum
        if damage and k % 23 == 7:
            out.append(out[-3][:20])  # truncated
        if damage and k % 29 == 3:
            out.append("!AIVDM,1,1,,A,13aEOK?P00PD2wVMdLDRhgvL289?,0*26")
        if damage and k % 31 == 11:
            out.append("$IIHDT,,T*0C")
    return out

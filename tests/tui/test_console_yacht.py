"""A yacht's NMEA 0183 log on the console (the real Markermeer log, data/nmea): readings labelled
by their source (HDG is a magnetic compass, not a gyro), COG/SOG on Pg 100, the GPS box as the
receiver gives the fix (lat/lon, quality, HDOP, satellites; not ECEF), positions to the
precision the fix supports, and no rudder, inclinometer or pressure where the source has none.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

from textual.pilot import Pilot
from textual.widgets import Static

from engine.api import run_record
from tests.paths import DATA
from tests.tui.test_console_support import drive, make_app, start, text_of, wait_for
from uvnav_tui.pages.main_page import SECOND_M

LOG = "avnav-markermeer-20160815"


def test_yacht_log_readings_labelled_by_source(data_dir: Path) -> None:
    nmea_dir = data_dir / "nmea"
    nmea_dir.mkdir()
    for suffix in (".nmea", ".toml"):
        shutil.copy(DATA / "nmea" / f"{LOG}{suffix}", nmea_dir / f"{LOG}{suffix}")
    app = make_app(nmea_dir, LOG)

    def box(name: str) -> str:
        return str(app.screen.query_one(f"#{name}", Static).render())

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 30)
        app.refresh_display()
        await pilot.pause()
        r = app.control.latest
        rec = run_record(r)
        assert rec is not None and rec.cog_deg is not None and rec.sog_kn is not None
        strip = box("sensor-strip")
        assert strip.startswith(f"COMPASS {r.sensors.heading_true_deg:.1f}°")
        assert f"COG {rec.cog_deg:.1f}°" in strip and f"SOG {rec.sog_kn:.1f}kts" in strip
        for absent in ("GYRO", "RUDR", "INCL", "PRESS"):
            assert absent not in strip, strip
        gps = box("box-gps")
        assert "X " not in gps and "Lat 52°29." in gps and "HDOP" in gps and "sats" in gps
        # precision of the MPP: the last digit of the seconds no coarser than a (95 %)
        a = r.mpp.ellipse.scaled(0.95)[0]
        m = re.search(r"Lat : 52°\d\d'\d\d(?:\.(\d+))?\" N", box("box-mpp"))
        assert m is not None, box("box-mpp")
        decimals = len(m.group(1) or "")
        assert decimals < 3
        assert SECOND_M * 10.0**-decimals <= a < SECOND_M * 10.0**-(decimals - 1)
        await pilot.press("6", "2", "0")
        await wait_for(pilot, lambda: "Sensor statistics" in text_of(app), "Pg 620")
        page = text_of(app)
        assert "Compass" in page and "HDG magnetic heading + variation" in page
        for absent in ("Gyro", "Rudder", "Incl.", "Press."):
            assert absent not in page, absent
        assert "COG" in page and "SOG" in page

    drive(app, script, size=(120, 40))


def test_run_file_labels_unchanged(data_dir: Path) -> None:
    """A 1993 .RUN keeps the thesis' strip and ECEF GPS box (Pg 100, THEORY §12.8)."""
    app = make_app(data_dir)

    async def script(pilot: Pilot[None]) -> None:
        await start(pilot, 2)
        strip = str(app.screen.query_one("#sensor-strip", Static).render())
        assert strip.startswith("GYRO ") and "RUDR" in strip and "INCL" in strip
        assert str(app.screen.query_one("#box-gps", Static).render()).startswith("X ")
        assert re.search(r"Lat : 52°\d\d'\d\d\.\d{3}\" N",
                         str(app.screen.query_one("#box-mpp", Static).render()))

    drive(app, script)

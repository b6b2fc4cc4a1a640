"""A live run's NMEA options (engine/run/live.py): today's date only as a fallback."""

from datetime import UTC, date, datetime

from engine.io.nmea_epochs import EpochBuilder, NmeaOptions
from engine.run.live import LIVE_DATE_HOLD_LINES, live_nmea_options
from tests.nmea_lines import nmea


def test_live_options_today_as_fallback_with_a_short_hold() -> None:
    o = live_nmea_options(today=datetime(2026, 12, 2, 14, 0, tzinfo=UTC))
    assert o.date == date(2026, 12, 2) and o.date_hold_lines == LIVE_DATE_HOLD_LINES
    given = live_nmea_options(NmeaOptions(date=date(2020, 5, 1)))
    assert given.date == date(2020, 5, 1) and given.date_hold_lines == LIVE_DATE_HOLD_LINES


def test_an_old_log_replayed_live_keeps_its_own_date() -> None:
    # The case found by hand: a 2016 log sent to a live port gave "time went backwards by
    # 324950400 s" and no cycle, because its first GGAs were dated today.
    b = EpochBuilder(live_nmea_options(today=datetime(2026, 12, 2, tzinfo=UTC)), "udp")
    lines = [nmea("GPGGA,114941.00,5229.6021,N,00517.7879,E,1,08,1.0,0.0,M,0.0,M,,"),
             nmea("GPRMC,114942.00,A,5229.6021,N,00517.7879,E,4.8,75.0,150816,,,A"),
             nmea("GPGGA,114943.00,5229.6022,N,00517.7890,E,1,08,1.0,0.0,M,0.0,M,,")]
    recs = [r for i, line in enumerate(lines, 1) for r in b.feed(line, i)] + b.finish()
    assert [r.time for r in recs] == [datetime(2016, 8, 15, 11, 49, s, tzinfo=UTC)
                                      for s in (41, 42, 43)]
    assert not b.stats.skipped

"""NMEA sentences → epochs (engine/io/nmea_epochs.py): interval, staleness, date, midnight,
time going backwards. Sentences are hand-written (tests/nmea_lines.py)."""

from __future__ import annotations

from datetime import UTC, date, datetime

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine.io.nmea_epochs import EpochBuilder, NmeaOptions
from engine.io.runfile import BadRecord, RunRecord, parse_run_line
from tests.nmea_lines import ddmm, hhmmss, nmea


def gga(t_s: int, lat: float = 52.8333333333, lon: float = 4.5) -> str:
    return nmea(f"GPGGA,{hhmmss(t_s)},{ddmm(lat)},N,{ddmm(lon, 3)},E,1,07,1.2,2.0,M,46.0,M,,")


def rmc(t_s: int, day: str = "021226") -> str:
    return nmea(f"GPRMC,{hhmmss(t_s)},A,5250.0000,N,00430.0000,E,6.0,45.0,{day},,,A")


def run(lines: list[str], options: NmeaOptions | None = None
        ) -> tuple[list[RunRecord], list[BadRecord], EpochBuilder]:
    b = EpochBuilder(options or NmeaOptions(), "T.nmea")
    out = []
    for i, line in enumerate(lines, 1):
        out += b.feed(line, i)
    out += b.finish()
    return ([r for r in out if isinstance(r, RunRecord)],
            [r for r in out if isinstance(r, BadRecord)], b)


def test_one_epoch_per_second_with_latest_values_and_run_line() -> None:
    lines = []
    for k in range(3):
        lines += [rmc(43200 + k), gga(43200 + k), nmea(f"HEHDT,{10 + k}.0,T"),
                  nmea("VWVHW,,T,,M,5.2,N,,K"), nmea("SDDPT,12.34,0.5")]
    recs, bad, b = run(lines)
    assert not bad and len(recs) == 3
    r = recs[0]
    assert r.time == datetime(2026, 12, 2, 12, 0, 0, tzinfo=UTC)
    assert r.line_no == 6  # closed by the RMC of the next second (line 6)
    assert (r.heading_deg, r.speed_kn, r.echo_m) == (10.0, 5.2, 12.34)
    assert (r.gps_quality, r.gps_sats, r.gps_hdop, r.cog_deg, r.sog_kn) == (1, 7, 1.2, 45.0, 6.0)
    assert r.decca == (None, None, None) and r.rudder_deg is None
    assert r.gps_lat_deg == pytest.approx(52.8333333, abs=1e-6)
    # raw is the equivalent .RUN line (GNSS values as key=value tokens); its parse is the record
    assert r.raw == ("261202 120000 52 50 00.000 N 004 30 00.000 E - - - 10.0 5.2 - - - 12.34 "
                     "hdop=1.20 q=1 sats=7 cog=45.0 sog=6.00")
    assert parse_run_line(r.raw, r.line_no, "T.nmea") == r
    assert recs[-1].line_no == 15  # the last epoch is closed by the end of the log
    assert b.stats.used == {"RMC": 3, "GGA": 3, "HDT": 3, "VHW": 3, "DPT": 3}
    assert b.stats.missing_sensors() == []


def test_stale_values_are_absent() -> None:
    # heading only at 12:00:00; position every second: heading_stale_s = 3 → present at
    # epochs 0..3 s, absent from 4 s on
    lines = [rmc(43200), nmea("HEHDT,90.0,T")] + [gga(43200 + k) for k in range(1, 7)]
    recs, _, _ = run(lines)
    assert [r.heading_deg for r in recs] == [90.0, 90.0, 90.0, 90.0, None, None, None]


def test_date_from_options_and_held_until_rmc() -> None:
    recs, _, _ = run([gga(3600), gga(3601)], NmeaOptions(date=date(2025, 1, 2)))
    assert [r.time for r in recs] == [datetime(2025, 1, 2, 1, 0, s, tzinfo=UTC) for s in (0, 1)]
    # no date: GGA lines are held until the RMC gives 2026-12-02
    recs, _, b = run([gga(3600), gga(3601), rmc(3602), gga(3603)])
    assert [r.time.second for r in recs] == [0, 1, 2, 3]
    assert recs[0].time.date() == date(2026, 12, 2)


def test_no_date_at_all_is_reported() -> None:
    recs, _, b = run([gga(3600), gga(3601)])
    assert recs == [] and b.stats.skipped["no date yet"] == 2 and b.stats.undated_fixes == 2
    assert any("no date in the log" in e and e.startswith("T.nmea:2:") for e in b.stats.events)


def test_midnight_roll_over_without_new_date() -> None:
    recs, _, b = run([rmc(86398, "311226"), gga(86399), gga(0), gga(1)])
    assert [r.time for r in recs] == [
        datetime(2026, 12, 31, 23, 59, 58, tzinfo=UTC), datetime(2026, 12, 31, 23, 59, 59,
                                                                 tzinfo=UTC),
        datetime(2027, 1, 1, 0, 0, 0, tzinfo=UTC), datetime(2027, 1, 1, 0, 0, 1, tzinfo=UTC)]
    assert any("T.nmea:3: midnight roll-over" in e for e in b.stats.events)


def test_time_backwards_skips_until_it_passes_the_last_epoch() -> None:
    """A jump back confirmed by the next sentence (its time later than the jump's): the clock
    goes back, and everything is skipped until it passes the last epoch emitted."""
    lines = [rmc(43200 + k) for k in range(5)]  # epochs 0..3 emitted when 43204 came
    lines += [rmc(43100), nmea("HEHDT,1.0,T"), rmc(43101), rmc(43102), rmc(43205), rmc(43206)]
    recs, bad, b = run(lines)
    assert [r.time.second for r in recs] == [0, 1, 2, 3, 5, 6]
    assert all(r.heading_deg is None for r in recs)  # the HDT's stamp was after the resume
    assert b.stats.skipped["time went backwards"] == 3  # 43100, 43101, 43102
    assert len(bad) == 1 and bad[0].line_no == 6 and bad[0].error.field == "time went backwards"
    assert any(e.startswith("T.nmea:6: time went backwards by 104.0 s") for e in b.stats.events)
    assert any(e.startswith("T.nmea:10: time passes the last epoch again") for e in b.stats.events)


def test_one_sentence_back_in_time_is_implausible_not_a_reset() -> None:
    """One sentence 104 s back, the next ones keep to the clock: that one is skipped (reported
    with its line), nothing else; the HDT between is used."""
    lines = [rmc(43200 + k) for k in range(5)]
    lines += [rmc(43100), nmea("HEHDT,1.0,T"), rmc(43203), rmc(43205), rmc(43206)]
    recs, bad, b = run(lines)
    assert [r.time.second for r in recs] == [0, 1, 2, 3, 4, 5, 6]
    assert [r.heading_deg for r in recs][-3:] == [1.0, 1.0, 1.0]
    assert b.stats.skipped == {"implausible time": 1}
    assert [(x.line_no, x.error.field) for x in bad] == [(6, "implausible time")]
    assert str(bad[0].error).startswith("T.nmea:6: implausible time: 2026-12-02 11:58:20 is "
                                        "-104 s from the log clock: 1 sentence not used")


def stream(first: int, n: int, day: str = "021226") -> list[str]:
    """``n`` seconds of GGA + RMC + HDT from second of day ``first``."""
    out = []
    for t in range(first, first + n):
        out += [gga(t), rmc(t, day), nmea("HEHDT,10.0,T")]
    return out


@pytest.mark.parametrize(("wild", "label"), [
    (nmea("GPZDA,120005.00,02,12,2099,00,00"), "a ZDA dated 2099"),
    (nmea("GPGGA,235960,5250.0000,N,00430.0000,E,1,07,1.2,2.0,M,46.0,M,,"), "235960 at noon"),
    (rmc(43205, "021227"), "an RMC a year ahead"),
])
def test_one_implausible_clock_sentence_does_not_stall(wild: str, label: str) -> None:
    """The cases of a hostile-input run: one such sentence used to move the clock, close
    epochs at once, and make every later sentence "go backwards" (and a year's jump gave
    false midnight roll-overs). Now it is refuted by the next sentence and skipped alone."""
    lines = [*stream(43200, 5), wild, *stream(43205, 10)]  # the wild one is line 16
    recs, bad, b = run(lines)
    assert [r.time.second for r in recs] == list(range(15)), label
    assert all(r.gps_lat_deg is not None for r in recs)
    assert b.stats.skipped == {"implausible time": 1}, label
    assert [x.line_no for x in bad] == [16]
    assert not any("roll-over" in e or "backwards" in e or "gap" in e for e in b.stats.events)


def test_year_jump_and_back_no_false_midnight_roll_overs() -> None:
    """A stream that really runs a year ahead for a while (confirmed) and comes back: the
    come-back is a reset (skipped until past the last epoch, said), never a roll-over."""
    lines = stream(43200, 5) + stream(43205, 5, "021227") + stream(43210, 30)
    recs, _, b = run(lines)
    times = [r.time for r in recs]
    assert times == sorted(set(times))
    assert not any("roll-over" in e for e in b.stats.events)
    assert any("time jumped +31535999 s to 2027-12-02 12:00:05" in e for e in b.stats.events)
    assert any("time went backwards" in e for e in b.stats.events)
    assert b.clock_trouble().startswith("CLOCK BEHIND ")  # still behind at the end: said


def test_leap_second_2359_60() -> None:
    """23:59:60 (the leap second of 2016-12-31) is 23:59:59.999: no epoch of the next day is
    closed by it, nothing is skipped and no roll-over is reported (the RMCs carry the date)."""
    leap = nmea("GPGGA,235960.00,5250.0000,N,00430.0000,E,1,07,1.2,2.0,M,46.0,M,,")
    lines = [rmc(86398, "311216"), rmc(86399, "311216"), leap, rmc(0, "010117"),
             rmc(1, "010117"), rmc(2, "010117")]
    recs, bad, b = run(lines)
    assert [r.time for r in recs] == [
        datetime(2016, 12, 31, 23, 59, 58, tzinfo=UTC),
        datetime(2016, 12, 31, 23, 59, 59, tzinfo=UTC),
        datetime(2017, 1, 1, 0, 0, 0, tzinfo=UTC), datetime(2017, 1, 1, 0, 0, 1, tzinfo=UTC),
        datetime(2017, 1, 1, 0, 0, 2, tzinfo=UTC)]
    assert not bad and not b.stats.skipped and not b.stats.events


def test_a_jump_unconfirmed_at_the_end_is_skipped() -> None:
    recs, bad, b = run(stream(43200, 3) + [rmc(50000)])
    assert [r.time.second for r in recs] == [0, 1, 2]
    assert b.stats.skipped == {"implausible time": 1}
    assert "not confirmed before the end of the log" in str(bad[0].error)


def test_late_sentence_within_tolerance_is_used() -> None:
    recs, bad, _ = run([rmc(43200), rmc(43202), gga(43201), rmc(43203)])
    assert not bad and [r.time.second for r in recs] == [0, 1, 2, 3]


def test_gap_gives_no_empty_epochs() -> None:
    recs, _, b = run([rmc(43200), rmc(43201), rmc(43500), rmc(43501)])
    assert [r.time.second for r in recs] == [0, 1, 2, 3, 4, 0, 1]  # 43500 = 12:05:00
    assert [r.time.minute for r in recs][-2:] == [5, 5]
    assert any("gap of 299 s" in e for e in b.stats.events)


def test_interval_of_two_seconds() -> None:
    recs, _, _ = run([rmc(43201 + k) for k in range(6)], NmeaOptions(interval_s=2))
    assert [r.time.second for r in recs] == [2, 4, 6]


def test_bad_lines_are_bounded_per_kind() -> None:
    lines = [rmc(43200)] + ["$GPGGA,1*00"] * 50
    _, bad, b = run(lines)
    assert len(bad) == 20 and b.stats.skipped["bad checksum"] == 50
    assert str(bad[0].error).startswith("T.nmea:2: bad checksum:")


def test_missing_sensors_report() -> None:
    _, _, b = run([rmc(43200), rmc(43201)])
    assert b.stats.missing_sensors() == [
        "no heading (HDT/HDG/VHW) in the log", "no water speed (VHW/VBW) in the log",
        "no depth (DBT/DPT) in the log"]


@pytest.mark.parametrize("bad", [{"interval_s": 0}, {"interval_s": 1.5},
                                 {"heading_stale_s": -1.0}, {"variation_deg": 200.0}])
def test_options_are_checked(bad: dict[str, object]) -> None:
    from engine.errors import InputError
    with pytest.raises(InputError):
        NmeaOptions(**bad)  # type: ignore[arg-type]


_EVENT = st.tuples(st.sampled_from(["GGA", "RMC", "ZDA", "HDT", "DBT", "NOISE"]),
                   st.integers(0, 86399), st.integers(0, 3))


@settings(max_examples=150, deadline=None)
@given(st.lists(_EVENT, max_size=60), st.booleans())
def test_any_sentence_order_gives_increasing_parsable_records(
        events: list[tuple[str, int, int]], with_date: bool) -> None:
    """Whatever the order of times and dates (resets, midnight, days apart), no exception,
    record times strictly increase (the session's rule) and each record is its .RUN line."""
    lines = []
    for kind, t, day in events:
        if kind == "GGA":
            lines.append(gga(t))
        elif kind == "RMC":
            lines.append(rmc(t, f"{1 + day:02d}1226"))
        elif kind == "ZDA":
            lines.append(nmea(f"GPZDA,{hhmmss(t)},{1 + day:02d},12,2026,00,00"))
        elif kind == "HDT":
            lines.append(nmea(f"HEHDT,{t % 360}.5,T"))
        elif kind == "DBT":
            lines.append(nmea(f"SDDBT,,f,{t % 100}.0,M,,F"))
        else:
            lines.append(nmea(f"GPGGA,{t}")[:-1])
    options = NmeaOptions(date=date(2026, 12, 1)) if with_date else NmeaOptions()
    recs, _, b = run(lines, options)
    times = [r.time for r in recs]
    assert times == sorted(set(times))
    for r in recs:
        assert parse_run_line(r.raw, r.line_no, "T.nmea") == r
    assert b.stats.epochs == len(recs)


def test_held_sentences_before_midnight_get_the_previous_day() -> None:
    # no date until the RMC of 00:00:01 on 3 Dec: the GGAs of 23:59:58/59 are on 2 Dec
    recs, _, _ = run([gga(86398), gga(86399), gga(0), rmc(1, "031226"), gga(2)])
    assert [r.time for r in recs] == [
        datetime(2026, 12, 2, 23, 59, 58, tzinfo=UTC), datetime(2026, 12, 2, 23, 59, 59,
                                                                tzinfo=UTC),
        datetime(2026, 12, 3, 0, 0, 0, tzinfo=UTC), datetime(2026, 12, 3, 0, 0, 1, tzinfo=UTC),
        datetime(2026, 12, 3, 0, 0, 2, tzinfo=UTC)]


def test_too_many_sentences_without_date_drop_the_oldest() -> None:
    recs, _, b = run([gga(43200 + k) for k in range(6)] + [rmc(43206)],
                     NmeaOptions(date_hold_lines=3))
    assert [r.time.second for r in recs] == [3, 4, 5, 6]  # the 3 newest held + the RMC's
    assert b.stats.skipped["no date yet"] == 3
    assert any(e.startswith("T.nmea:4: no date (RMC/ZDA) in the first 3") for e in b.stats.events)


def test_hdg_with_variation_from_options_in_a_record() -> None:
    # HDG 100.0 magnetic, deviation 1.0 W, no variation; options: 2.5 E → 101.5 true
    recs, _, b = run([rmc(43200), nmea("HCHDG,100.0,1.0,W,,"), rmc(43201)],
                     NmeaOptions(variation_deg=2.5))
    assert recs[0].heading_deg == 101.5
    assert b.stats.notes["HDG made true with [nmea] variation_deg"] == 1
    assert b.stats.variation == {}  # the configured variation overrides the model


def test_magnetic_heading_without_variation_made_true_with_igrf() -> None:
    """HDG 100.0 magnetic, deviation 1.0 W, no variation anywhere: the heading is used with
    the IGRF-14 variation at the fix (it was dropped: 'HDG without variation: not used').
    Off the Dutch coast on 2026-12-02 the variation is about 2.7°E (the Markermeer log's
    receiver gave 0.9°E in 2016; it grows ~0.2°/year there); its value from the model is
    tested against NOAA in tests/geodesy/test_magvar.py."""
    from engine.geodesy.magvar import declination_deg

    recs, _, b = run([rmc(43200), nmea("HCHDG,100.0,1.0,W,,"), rmc(43201)])
    var = declination_deg(52.8, 4.5, date(2026, 12, 2))  # the 0.1° cell of 52°50'N 4°30'E
    assert var is not None and 2.0 < var < 3.5
    assert recs[0].heading_deg == pytest.approx(round(99.0 + var, 1), abs=1e-9)
    assert "heading" in b.stats.sensors
    (line,) = b.stats.variation_lines()
    assert line.startswith("magnetic headings without variation: 1 made true with the "
                           f"IGRF-14 variation {var:.1f}°E at 52.83°N 4.50°E on 2026-12-02")
    assert line in b.stats.summary_lines()


def test_magnetic_heading_uses_the_logs_own_variation_first() -> None:
    """An RMC's variation (the receiver's) makes a VHW magnetic heading true before the
    model is asked; the source is said."""
    r = nmea("GPRMC,120000.00,A,5250.0000,N,00430.0000,E,6.0,45.0,021226,0.9,E,A")
    recs, _, b = run([r, nmea("VWVHW,,T,80.0,M,4.4,N,,K"), rmc(43201)])
    assert recs[0].heading_deg == pytest.approx(80.9)
    assert list(b.stats.variation) == ["the log's own variation (RMC)"]
    assert b.stats.variation_lines() == [
        "magnetic headings without variation: 1 made true with the log's own variation "
        "(RMC) 0.9°E"]


def test_magnetic_heading_before_any_fix_or_outside_the_model_is_not_used() -> None:
    recs, _, b = run([nmea("GPZDA,120000.00,02,12,2026,00,00"), nmea("HCHDG,100.0,,,,"),
                      nmea("GPZDA,120001.00,02,12,2026,00,00")])
    assert all(r.heading_deg is None for r in recs)
    assert b.stats.notes["HDG magnetic heading without variation before the first fix: not "
                         "used (no position for the IGRF-14 variation)"] == 1
    recs, _, b = run([rmc(43200, "021289"), nmea("HCHDG,100.0,,,,"), rmc(43201, "021289")])
    assert recs[0].heading_deg is not None  # 1989: inside IGRF (since 1900)
    recs, _, b = run([rmc(43200, "020131"), nmea("HCHDG,100.0,,,,"), rmc(43201, "020131")])
    assert recs[0].heading_deg is None  # 2031: after the model's span
    assert b.stats.notes["HDG magnetic heading without variation outside IGRF-14 "
                         "(1900–2029): not used"] == 1


def gga_lost(t_s: int) -> str:
    return nmea(f"GPGGA,{hhmmss(t_s)},,,,,0,00,99.9,,M,,M,,")


def test_fix_outage_keeps_the_clock_and_the_other_sensors() -> None:
    """After a valid fix, quality-0 GGAs still carry GPS time: the epochs of the outage are
    made from the heading alone (no position)."""
    lines = [rmc(43200), gga(43200), nmea("HEHDT,10.0,T")]
    for k in range(1, 6):
        lines += [gga_lost(43200 + k), nmea("HEHDT,10.0,T")]
    lines += [gga(43206)]
    recs, _, b = run(lines)
    assert [r.time.second for r in recs] == [0, 1, 2, 3, 4, 5, 6]
    # the fix of 12:00:00 is used once; the outage epochs have the heading only
    assert [r.gps_lat_deg is not None for r in recs] == [True, False, False, False, False, False,
                                                         True]
    assert all(r.heading_deg == 10.0 for r in recs)
    assert b.stats.skipped["not a fix"] == 5


def test_no_fix_yet_times_are_not_used() -> None:
    """Before the first valid fix a receiver's own clock may be wrong: its times are ignored
    (here a 1980 clock that would otherwise set the date)."""
    lines = [nmea("GPRMC,000010,V,,,,,,,060180,,,N"), nmea("HEHDT,10.0,T"), rmc(43200),
             nmea("HEHDT,11.0,T"), rmc(43201)]
    recs, bad, _ = run(lines)
    assert not bad and [r.time for r in recs] == [
        datetime(2026, 12, 2, 12, 0, 0, tzinfo=UTC), datetime(2026, 12, 2, 12, 0, 1, tzinfo=UTC)]


def test_a_fix_goes_into_one_epoch_only() -> None:
    """A 0.5 Hz receiver with a 1 Hz heading: positions every other record, never repeated
    (a repeated fix would be weighed by the filter as a second, independent one); the GGA and
    RMC of the same second are one fix."""
    lines = []
    for k in range(6):
        if k % 2 == 0:
            lines += [rmc(43200 + k), gga(43200 + k)]
        lines.append(nmea("HEHDT,90.0,T"))
        if k % 2 == 1:
            lines.append(nmea(f"GPZDA,{hhmmss(43200 + k)},02,12,2026,00,00"))
    recs, _, _ = run(lines)
    assert [r.time.second for r in recs] == [0, 1, 2, 3, 4, 5]
    assert [r.gps_quality for r in recs] == [1, None, 1, None, 1, None]
    assert [r.gps_lat_deg is not None for r in recs] == [True, False] * 3
    assert all(r.heading_deg == 90.0 for r in recs)


def test_a_date_in_the_log_wins_over_the_configured_one() -> None:
    # An old log replayed into a live port (configured date = today) or a wrong --date: the
    # GGAs before the first RMC are dated from the RMC, not from the option, so the log's time
    # never "goes back" years and nothing is skipped.
    recs, _, b = run([gga(3600), gga(3601), rmc(3602, "150816"), gga(3603)],
                     NmeaOptions(date=date(2026, 12, 2)))
    assert [r.time for r in recs] == [datetime(2016, 8, 15, 1, 0, s, tzinfo=UTC)
                                      for s in (0, 1, 2, 3)]
    assert not b.stats.skipped


def test_configured_date_used_when_the_hold_fills() -> None:
    recs, _, b = run([gga(3600 + k) for k in range(5)],
                     NmeaOptions(date=date(2025, 1, 2), date_hold_lines=2))
    assert [r.time for r in recs] == [datetime(2025, 1, 2, 1, 0, s, tzinfo=UTC)
                                      for s in range(5)]
    assert any(e.startswith("T.nmea:1: no date (RMC/ZDA) in the first 3 sentences: dated "
                            "2025-01-02") for e in b.stats.events)

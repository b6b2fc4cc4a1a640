"""NMEA 0183 sentences → ``.RUN``-equivalent records at a fixed interval (docs/NMEA.md "Epochs").

Sentences arrive at different rates and out of step. :class:`EpochBuilder` keeps the latest
value of each sensor with the log time it arrived at and, every ``interval_s`` seconds of log
time, makes one :class:`~engine.io.runfile.RunRecord` from the latest values; a value older
than its sensor's staleness limit is absent (None, ``-`` in the .RUN line). Nothing is
extrapolated. A GNSS fix is one measurement, so it goes into one epoch only (the first after
it, within its staleness limit): a receiver at 0.5 Hz gives a position every other record, not
the same position twice, which the filter would weigh as two independent fixes. Heading, water
speed, course/speed over ground and depth are sampled: their latest value is repeated while
fresh.

**Log time.** It comes from the sentences only (GGA/RMC/GLL/ZDA time of day; the date from
RMC/ZDA or :attr:`NmeaOptions.date`). A sentence without a time (HDT, VHW, DBT …) is stamped
with the latest log time. Epoch ``E`` (a multiple of ``interval_s`` of UTC seconds) is
*closed* by the first sentence whose time is after ``E``; the record holds the values as they
were just before that sentence, and its ``line_no`` is that sentence's line (for the last epoch
of a log, the last line). The time of a *not a fix* GGA/RMC/GLL moves the clock too, once the
log has had a valid fix (so a GNSS outage keeps its heading/log/depth epochs). Epochs in which
no sensor has a fresh value are not emitted (a gap in the log gives no empty records; gaps over
:data:`GAP_REPORT_S` are reported).

**Date.** Until the log gives a date (RMC/ZDA) the sentences are held, up to
``options.date_hold_lines`` of them (:data:`DATE_HOLD_LINES` for a file); when a date arrives
they are dated from it and used. When none arrives within the hold (or before the log ends),
``options.date`` (``--date``, ``[nmea] date``; today's UTC date for a live source) dates them,
reported; without it the oldest are dropped and counted. A date in the log always wins over
``options.date``: a wrong ``--date``, or an old log replayed into a live port, would otherwise
put the first epochs years away from the rest and make the log's own time "go backwards".
A time of day is put on the day (date − 1, date, date + 1)
that is nearest the log clock, so a time of day that wraps past midnight without a new date
moves to the next day (a *midnight roll-over*, reported).

**A plausible clock.** A sentence's time is believed at once when it is within
:data:`JUMP_S` ahead of the log clock or :data:`LATE_TOLERANCE_S` behind it (a time of day
alone is put on the day that brings it nearest the clock, so a roll-over past midnight is only
ever seen near midnight). A time further off is a *jump*: it is held, not used, until the next
timed sentences decide, as a GNSS receiver's own plausibility checks do. A sentence that keeps
to the old clock refutes it (the held sentences are skipped as ``implausible time``, counted and
reported with their file:line: one wild sentence, a ZDA dated 2099 or a ``235960`` at noon,
never moves the clock); a sentence that keeps to the jump with a later time confirms it (the
clock goes there, a gap or a reset, and the held sentences are used in order). A jump still
unconfirmed at the end of the log is skipped. A time of day alone (GGA, GLL) that fits both
the clock and a jump by whole days tells nothing about the date: it is used on the log clock
while RMC/ZDA decide. The very first time of a log has nothing to be compared with and is
taken as it is. A leap second ``23:59:60`` is taken as
23:59:59.999 (the parser's rule), so it closes no epoch of the next day.

**Time going backwards.** A time up to :data:`LATE_TOLERANCE_S` behind the log clock is a late
sentence: used, the clock does not move back. A confirmed jump back (a reset of the receiver, a
log looping or concatenated) moves the clock back; if that is at or before the last epoch
emitted, it is reported with its file:line and everything is skipped (counted) until the time
passes that epoch again — a run cannot go back in time. While so, :meth:`EpochBuilder.clock_trouble`
says so (a live run shows it: a stall is never silent).

Every record's ``raw`` is its ``.RUN`` line (:func:`~engine.io.runfile.format_run_record`) and
its values are those of that line, so replaying the log and the converted ``.RUN`` agree.
"""

from __future__ import annotations

import dataclasses
import math
from collections import Counter, deque
from dataclasses import dataclass, field
from datetime import UTC, date, datetime, timedelta

from engine.errors import InputError
from engine.geodesy.magvar import MODEL, MODEL_END, MODEL_FIRST, declination_deg, model_covers
from engine.io.nmea_sentences import NmeaValues, SentenceSkip, SkipKind, parse_nmea_line
from engine.io.runfile import (
    MAX_SOG_KN,
    MAX_SPEED_KN,
    BadRecord,
    RunRecord,
    format_run_record,
    parse_run_line,
)

__all__ = [
    "DATE_HOLD_LINES",
    "EpochBuilder",
    "NmeaOptions",
    "NmeaStats",
    "SENSORS",
]

DATE_HOLD_LINES = 2000
"""Sentences held while no date is known (beyond that the oldest are dropped, counted)."""
LATE_TOLERANCE_S = 2.0
"""A sentence time up to this far behind the log clock is a late sentence, not a reset [s]."""
JUMP_S = 10.0
"""A sentence time more than this ahead of the log clock is a jump to be confirmed [s]: beyond
the longest default staleness limit, where every value of the old clock is stale anyway."""
HELD_JUMP_LINES = 50
"""Sentences kept while a jump waits for its confirmation (more of the same time: the oldest
are skipped)."""
GAP_REPORT_S = 60.0
"""A forward jump of the log time longer than this is reported as a gap [s]."""
MAX_EVENTS = 50
"""Events (roll-overs, resets, gaps …) kept with their file:line; the rest are counted."""
MAX_BAD_PER_KIND = 20
"""Damaged lines returned as :class:`BadRecord` per skip kind (the ``.OUT`` log's ``BAD``
lines); the rest are counted in :class:`NmeaStats` only, so a noisy log keeps the log small."""
VARIATION_CELL_DEG = 0.1
"""The model's variation is computed once per cell of this size [deg of latitude and longitude]
and day, at the cell's centre (within 0.05° of the fix: the variation changes by a few
hundredths of a degree over such a distance outside polar waters)."""
VARIATION_CACHE = 4096
"""Cells kept (a run that crosses more starts the cache afresh)."""
MAX_TYPES_COUNTED = 100
"""Distinct unused sentence types counted by name; further types are counted together as
:data:`OTHER_TYPES` (a log of random junk addresses keeps the counts small)."""
OTHER_TYPES = "other types"
MAX_INTERVAL_S = 3600
MAX_HDOP = 99.99
"""Largest HDOP the ``.RUN`` ``hdop=`` token takes (written with two decimals)."""
MAX_SATS = 999

SENSORS = ("position", "heading", "water speed", "course/speed over ground", "depth")
"""The sensors an NMEA log can carry (keys of :attr:`NmeaStats.sensors`)."""
MISSING_SENSOR_TEXT = {
    "position": "no position fix (GGA/RMC/GLL) in the log",
    "heading": "no heading (HDT/HDG/VHW) in the log",
    "water speed": "no water speed (VHW/VBW) in the log",
    "course/speed over ground": "no course/speed over ground (RMC/VTG) in the log",
    "depth": "no depth (DBT/DPT) in the log",
}
NO_DATE = "no date yet"
TIME_BACK = "time went backwards"
IMPLAUSIBLE = "implausible time"


@dataclass
class _Jump:
    """A time far from the log clock, waiting for the next sentences (module docstring)."""

    first: float
    latest: float
    line: int
    held: list[tuple[int, str, NmeaValues, bool]]  # line, raw, values, clock only


@dataclass(frozen=True)
class NmeaOptions:
    """How an NMEA log becomes epochs (``[nmea]`` in the run configuration, docs/CONFIG.md).

    Staleness limits [s]: a value older than this at an epoch is absent. The defaults allow a
    1 Hz sensor to miss two sentences (position, heading, COG/SOG 3 s), a log speed to miss
    four (5 s: logs often send at 0.5–1 Hz and the speed changes slowly) and an echo sounder,
    often at 0.2–1 Hz, several (10 s).
    """

    interval_s: int = 1
    """Epoch interval [whole seconds ≥ 1: the .RUN time resolution]."""
    position_stale_s: float = 3.0
    heading_stale_s: float = 3.0
    water_speed_stale_s: float = 5.0
    cog_sog_stale_s: float = 3.0
    depth_stale_s: float = 10.0
    date: date | None = None
    """UTC date for sentences when the log gives none: used only when no RMC/ZDA date arrives
    within :attr:`date_hold_lines` sentences (or before the log ends), so a date in the log
    always wins over it (a live stream replayed from an old log, a wrong ``--date``)."""
    date_hold_lines: int = DATE_HOLD_LINES
    """Sentences held while waiting for a date in the log before :attr:`date` is used (a live
    source holds fewer, so a stream without RMC/ZDA starts within seconds)."""
    variation_deg: float | None = None
    """Magnetic variation [deg, east positive] for HDG/VHW magnetic headings without one."""
    accept_no_checksum: bool = False
    """Use sentences without ``*hh`` (skipped as ``no checksum`` by default)."""

    def __post_init__(self) -> None:
        if (isinstance(self.interval_s, bool) or not isinstance(self.interval_s, int)
                or not 1 <= self.interval_s <= MAX_INTERVAL_S):
            raise InputError(f"Interval must be a whole number of seconds, 1 to {MAX_INTERVAL_S} !",
                             field="nmea.interval_s", text=str(self.interval_s))
        for name in ("position_stale_s", "heading_stale_s", "water_speed_stale_s",
                     "cog_sog_stale_s", "depth_stale_s"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and not isinstance(value, bool)
                    and 0.0 <= value <= 86400.0):
                raise InputError("Staleness must be 0 to 86400 s !", field=f"nmea.{name}",
                                 text=str(value))
        if self.variation_deg is not None and not (
                isinstance(self.variation_deg, int | float)
                and -180.0 <= self.variation_deg <= 180.0):
            raise InputError("Variation must be -180 to 180 degrees !",
                             field="nmea.variation_deg", text=str(self.variation_deg))
        if (isinstance(self.date_hold_lines, bool) or not isinstance(self.date_hold_lines, int)
                or self.date_hold_lines < 0):
            raise InputError("Date hold must be a whole number of lines >= 0 !",
                             field="nmea.date_hold_lines", text=str(self.date_hold_lines))
        if self.date is not None and not isinstance(self.date, date):
            raise InputError("Date must be YYYY-MM-DD !", field="nmea.date", text=str(self.date))


def _east_text(deg: float) -> str:
    """A variation as the chart says it: ``1.2°E``, ``3.4°W``."""
    return f"{abs(deg):.1f}°{'W' if deg < -0.05 else 'E'}"


@dataclass
class VariationUse:
    """Magnetic headings made true with one source of variation (the model, or the log's own
    from RMC/HDG): how many, the range of the variation [deg, east positive] and, for the
    model, the first position (WGS84 degrees) and UTC date it was computed for."""

    source: str
    count: int = 0
    min_deg: float = math.inf
    max_deg: float = -math.inf
    first: tuple[float, float, float, date] | None = None
    """(variation deg, latitude deg, longitude deg, date) of the first heading made true."""

    def add(self, var_deg: float, where: tuple[float, float, date] | None = None) -> None:
        """One heading made true with ``var_deg`` (at ``where`` for the model)."""
        self.count += 1
        self.min_deg = min(self.min_deg, var_deg)
        self.max_deg = max(self.max_deg, var_deg)
        if self.first is None and where is not None:
            self.first = (var_deg, *where)

    def line(self) -> str:
        """The report line (``magnetic headings without variation: 11093 made true with …``)."""
        span = (f" ({_east_text(self.min_deg)} to {_east_text(self.max_deg)} over the log)"
                if self.max_deg - self.min_deg >= 0.05 else "")
        text = f"magnetic headings without variation: {self.count} made true with "
        if self.first is not None:
            var, lat, lon, day = self.first
            return (text + f"the {self.source} variation {_east_text(var)} at "
                    f"{abs(lat):.2f}°{'S' if lat < 0 else 'N'} {abs(lon):.2f}°"
                    f"{'W' if lon < 0 else 'E'} on {day.isoformat()}{span}")
        return text + f"{self.source} {_east_text(self.min_deg)}{span}"


@dataclass
class NmeaStats:
    """What an NMEA log gave: counts per sentence type used, per skip kind, events with
    file:line, the sensors seen, and the first fix (for a derived configuration)."""

    source: str = "<string>"
    lines: int = 0
    used: Counter[str] = field(default_factory=Counter)
    """Sentences used, per sentence type (``GGA`` …)."""
    skipped: Counter[str] = field(default_factory=Counter)
    """Lines skipped, per kind (:class:`~engine.io.nmea_sentences.SkipKind`, ``no date yet``,
    ``time went backwards``)."""
    skipped_types: Counter[str] = field(default_factory=Counter)
    """Unknown/unused sentence types, per type (``GSV`` …; at most :data:`MAX_TYPES_COUNTED`
    names, the rest under :data:`OTHER_TYPES`)."""
    bad_unlisted: int = 0
    """Damaged lines beyond the first :data:`MAX_BAD_PER_KIND` of their kind: counted here
    and in :attr:`skipped`, not returned as :class:`~engine.io.runfile.BadRecord` (so not
    ``BAD`` lines of the ``.OUT`` log)."""
    notes: Counter[str] = field(default_factory=Counter)
    """Parts of sentences not used and why (``HDG without variation: not used`` …)."""
    variation: dict[str, VariationUse] = field(default_factory=dict)
    """Magnetic headings without a variation of their own made true, per source of the
    variation (the model :data:`~engine.geodesy.magvar.MODEL`, the log's RMC/HDG)."""
    events: list[str] = field(default_factory=list)
    """The first :data:`MAX_EVENTS` events as ``file:line: message``."""
    events_dropped: int = 0
    sensors: set[str] = field(default_factory=set)
    epochs: int = 0
    undated_fixes: int = 0
    """Valid positions not used for want of a date (dropped while held)."""
    first_fix: tuple[float, float] | None = None
    """First valid GNSS position (WGS84 latitude, longitude degrees)."""
    first_time: datetime | None = None
    last_time: datetime | None = None

    def event(self, line_no: int, message: str) -> None:
        """Record an event at ``line_no`` (bounded)."""
        if len(self.events) < MAX_EVENTS:
            self.events.append(f"{self.source}:{line_no}: {message}")
        else:
            self.events_dropped += 1

    def variation_lines(self) -> list[str]:
        """Where the variation of magnetic headings came from, one line per source (empty
        when the log has no magnetic heading without its own variation)."""
        return [use.line() for use in self.variation.values()]

    def missing_sensors(self) -> list[str]:
        """One sentence per sensor the log never gave (e.g. ``no heading (HDT/HDG/VHW) in the
        log``)."""
        return [MISSING_SENSOR_TEXT[s] for s in SENSORS if s not in self.sensors]

    def summary_lines(self) -> list[str]:
        """The report: sentences used and skipped per kind, notes, events, missing sensors."""
        used = ", ".join(f"{k} {n}" for k, n in sorted(self.used.items())) or "none"
        out = [f"NMEA {self.lines} lines, {self.epochs} epochs; sentences used: {used}"]
        if self.skipped:
            out.append("skipped: " + ", ".join(
                f"{k} {n}" for k, n in sorted(self.skipped.items())))
        if self.bad_unlisted:
            out.append(f"damaged lines: {self.bad_unlisted} more than the first "
                       f"{MAX_BAD_PER_KIND} of each kind listed one by one")
        if self.skipped_types:
            out.append("unused sentence types: " + ", ".join(
                f"{k} {n}" for k, n in sorted(self.skipped_types.items())))
        out += [f"{k} ({n}x)" for k, n in sorted(self.notes.items())]
        out += self.variation_lines()
        out += self.events
        if self.events_dropped:
            out.append(f"… {self.events_dropped} more events")
        out += self.missing_sensors()
        return out


@dataclass
class _Latest:
    """The latest values, each with its log time [UTC POSIX seconds]."""

    pos: tuple[float, float, float] | None = None  # stamp, lat, lon
    gga: tuple[float, int | None, float | None, int | None] | None = None  # stamp, q, hdop, sats
    heading: tuple[float, float] | None = None
    stw: tuple[float, float] | None = None
    cog: tuple[float, float] | None = None
    sog: tuple[float, float] | None = None
    depth: tuple[float, float] | None = None


def _stamp(t: float) -> str:
    """UTC POSIX seconds as ``YYYY-MM-DD HH:MM:SS``."""
    return f"{datetime.fromtimestamp(t, UTC):%Y-%m-%d %H:%M:%S}"


def _day_start(d: date) -> float:
    return datetime(d.year, d.month, d.day, tzinfo=UTC).timestamp()


class EpochBuilder:
    """Feeds NMEA lines, gives ``.RUN``-equivalent records (module docstring).

    ``source`` names the log in messages (``FILE:LINE: …``). :meth:`feed` and :meth:`finish`
    never raise for any text.
    """

    def __init__(self, options: NmeaOptions | None = None, source: str = "<string>") -> None:
        self.options = options if options is not None else NmeaOptions()
        self.source = source
        self.stats = NmeaStats(source=source)
        self._date: date | None = None
        """The log's date once known (from RMC/ZDA, or ``options.date`` after the hold)."""
        self._clock: float | None = None
        self._next_epoch: int | None = None
        self._latest = _Latest()
        self._held: deque[tuple[int, str, NmeaValues]] = deque()
        self._behind_since: int | None = None
        self._behind_count = 0
        self._jump: _Jump | None = None
        self._last_emitted: float | None = None
        """Time of the last epoch emitted [UTC POSIX s]: no epoch may come at or before it."""
        self._bad_kept: Counter[str] = Counter()
        self._last_line = 0
        self._no_date_reported = False
        self._had_fix = False
        self._log_variation: tuple[float, str] | None = None
        """The latest variation the log gave (deg east, sentence type)."""
        self._variation_cells: dict[tuple[int, int, date], float | None] = {}
        """The model's variation per cell and day (:data:`VARIATION_CELL_DEG`)."""
        self._fix_used: float | None = None
        """Time stamp of the last fix put into an epoch (not repeated in the next ones)."""
        o = self.options
        self._max_stale = max(o.position_stale_s, o.heading_stale_s, o.water_speed_stale_s,
                              o.cog_sog_stale_s, o.depth_stale_s)

    # ------------------------------------------------------------------ input
    def feed(self, line: str, line_no: int) -> list[RunRecord | BadRecord]:
        """One log line (its 1-based number); returns the records it closed and bad lines."""
        self._last_line = line_no
        self.stats.lines += 1
        out: list[RunRecord | BadRecord] = []
        parsed = parse_nmea_line(line, self.options.variation_deg, self.options.accept_no_checksum)
        if parsed is None:
            return out
        if isinstance(parsed, SentenceSkip):
            self._skip(parsed, line_no, line, out)
            if parsed.kind == SkipKind.NOT_FIX and self._had_fix:
                self._clock_only(parsed, line_no, line, out)
            return out
        if self._date is None and parsed.date is None:
            self._hold(line_no, line, parsed, out)
            return out
        if self._held:
            self._release(parsed, out)
        self._use(parsed, line_no, line, out)
        return out

    def finish(self) -> list[RunRecord | BadRecord]:
        """The end of the log: the last open epoch (if its time was reached) and a report of
        sentences still held for want of a date."""
        out: list[RunRecord | BadRecord] = []
        if self._held and self.options.date is not None:
            self._date_from_options(out)
        if self._held:
            n = len(self._held)
            self.stats.skipped[NO_DATE] += n
            self.stats.undated_fixes += sum(v.lat_deg is not None for _, _, v in self._held)
            self._held.clear()
            self.stats.event(self._last_line, f"no date in the log (no RMC/ZDA): {n} sentences "
                             "not used; set [nmea] date = YYYY-MM-DD")
        if self._jump is not None:
            self._refute(self._last_line, "not confirmed before the end of the log", out)
        if self._behind_since is not None:
            self.stats.event(self._last_line, f"log ended while its time was behind "
                             f"({self._behind_count} sentences skipped since line "
                             f"{self._behind_since})")
        if (self._clock is not None and self._next_epoch is not None
                and self._next_epoch <= self._clock):
            self._emit(self._next_epoch, self._last_line, out)
            self._next_epoch += self.options.interval_s
        return out

    # ------------------------------------------------------------------ skips
    def damaged(self, line_no: int, raw: str, kind: str, message: str
                ) -> list[RunRecord | BadRecord]:
        """A line the reader found damaged before it could be fed (too long): counted as a
        line and a skip of ``kind``, returned as a bad record while fewer than
        :data:`MAX_BAD_PER_KIND` of its kind were."""
        self._last_line = line_no
        self.stats.lines += 1
        self.stats.skipped[kind] += 1
        out: list[RunRecord | BadRecord] = []
        self._bad(kind, line_no, raw, message, out)
        return out

    def _bad(self, kind: str, line_no: int, raw: str, message: str,
             out: list[RunRecord | BadRecord]) -> None:
        if self._bad_kept[kind] < MAX_BAD_PER_KIND:
            self._bad_kept[kind] += 1
            text = raw.rstrip("\r\n")
            shown = text[:80] + ("…" if len(text) > 80 else "")
            out.append(BadRecord(line_no, shown, InputError(
                message, file=self.source, line=line_no, field=kind)))
        else:
            self.stats.bad_unlisted += 1

    def _skip(self, skip: SentenceSkip, line_no: int, raw: str,
              out: list[RunRecord | BadRecord]) -> None:
        self.stats.skipped[skip.kind] += 1
        if skip.kind == SkipKind.UNKNOWN and skip.sentence_type:
            types = self.stats.skipped_types
            name = skip.sentence_type
            types[name if name in types or len(types) < MAX_TYPES_COUNTED else OTHER_TYPES] += 1
        if skip.kind in SkipKind.REPORTED:
            self._bad(skip.kind, line_no, raw, skip.message, out)

    def _clock_only(self, skip: SentenceSkip, line_no: int, raw: str,
                    out: list[RunRecord | BadRecord]) -> None:
        """The time (and date) of a *not a fix* sentence after the log's first valid fix: a
        receiver keeps GPS time through an outage, so the log clock goes on and the other
        sensors' epochs are not lost. Before the first fix such times are not used (a
        receiver's own clock may be wrong then)."""
        if skip.time_s is None or (self._date is None and skip.date is None):
            return
        v = NmeaValues(skip.sentence_type or "", "", time_s=skip.time_s, date=skip.date)
        t = self._place(v, line_no, raw, out, clock_only=True)  # a date is known: not held
        if t is not None:
            self._apply(v, t, line_no, raw, out, clock_only=True)

    # ------------------------------------------------------------------ date
    def _hold(self, line_no: int, raw: str, v: NmeaValues,
              out: list[RunRecord | BadRecord]) -> None:
        self._held.append((line_no, raw, v))
        limit = self.options.date_hold_lines
        if len(self._held) > limit and self.options.date is not None:
            self._date_from_options(out)
        elif len(self._held) > limit:
            dropped = self._held.popleft()[2]
            self.stats.skipped[NO_DATE] += 1
            self.stats.undated_fixes += dropped.lat_deg is not None
            if not self._no_date_reported:
                self._no_date_reported = True
                self.stats.event(line_no, f"no date (RMC/ZDA) in the first {limit} "
                                 "sentences: the oldest are dropped until one arrives; set "
                                 "[nmea] date = YYYY-MM-DD")

    def _date_from_options(self, out: list[RunRecord | BadRecord]) -> None:
        """No date arrived while sentences were held: date them with ``options.date``."""
        assert self.options.date is not None
        self._date = self.options.date
        self.stats.event(self._held[0][0], f"no date (RMC/ZDA) in the first {len(self._held)} "
                         f"sentences: dated {self._date.isoformat()} (the configured date)")
        held, self._held = self._held, deque()
        for line_no, raw, v in held:
            self._use(v, line_no, raw, out)

    def _release(self, dated: NmeaValues, out: list[RunRecord | BadRecord]) -> None:
        """A date arrived: date the held sentences from it and use them in order."""
        assert dated.date is not None
        anchor = _day_start(dated.date) + (dated.time_s or 0.0)
        first_tod = next((v.time_s for _, _, v in self._held if v.time_s is not None), None)
        day = dated.date
        if first_tod is not None:
            day = min((dated.date + timedelta(days=k) for k in (-1, 0, 1)),
                      key=lambda d: abs(_day_start(d) + first_tod - anchor))
        self._date = day
        held, self._held = self._held, deque()
        for line_no, raw, v in held:
            self._use(v, line_no, raw, out)

    def _resolve(self, v: NmeaValues, ref: float | None) -> tuple[float, date] | None:
        """The UTC POSIX time of a sentence with a time and the day it is on (None for one
        without): a time of day alone on the day that brings it nearest ``ref`` (None: on
        the log's date)."""
        if v.time_s is None:
            return None
        if v.date is not None:
            return _day_start(v.date) + v.time_s, v.date
        if ref is None:
            assert self._date is not None
            return _day_start(self._date) + v.time_s, self._date
        around = datetime.fromtimestamp(ref, UTC).date()
        tod = v.time_s
        best = min((around + timedelta(days=k) for k in (-1, 0, 1)),
                   key=lambda d: abs(_day_start(d) + tod - ref))
        return _day_start(best) + tod, best

    def _set_day(self, v: NmeaValues, day: date, line_no: int) -> None:
        """A believed sentence's day becomes the log's date (a time of day alone that went
        past midnight: a roll-over, reported)."""
        if v.date is not None:
            self._date = v.date
        elif self._date is None or day > self._date:
            if self._date is not None:
                self.stats.event(line_no, f"midnight roll-over: time of day wrapped without a "
                                 f"new date, now {day.isoformat()}")
            self._date = day

    @staticmethod
    def _fits(t: float, ref: float) -> bool:
        return ref - LATE_TOLERANCE_S <= t <= ref + JUMP_S

    def _place(self, v: NmeaValues, line_no: int, raw: str,
               out: list[RunRecord | BadRecord], *, clock_only: bool = False) -> float | None:
        """The time of a sentence with a time if it is believed now; None when it is held
        for a jump (or, with a date only, has no time) (module docstring "A plausible
        clock")."""
        clock = self._clock
        placed = self._resolve(v, clock)
        if placed is None:
            if v.date is not None:
                self._date = v.date
            return None
        t, day = placed
        jump = self._jump
        if clock is None or self._fits(t, clock):
            if jump is not None:
                if v.date is None and self._fits(self._resolve(v, jump.latest)[0], jump.latest):
                    # A time of day alone that fits both (a jump by whole days): it tells
                    # nothing about the date; used on the log clock, the jump still waits.
                    self._set_day(v, day, line_no)
                    return t
                self._refute(line_no, "the next sentences keep to the log clock", out)
            self._set_day(v, day, line_no)
            return t
        if jump is not None:
            t2, _day2 = self._resolve(v, jump.latest) or (t, day)
            if self._fits(t2, jump.latest):
                jump.held.append((line_no, raw, v, clock_only))
                if len(jump.held) > HELD_JUMP_LINES:
                    del jump.held[0]
                    self.stats.skipped[IMPLAUSIBLE] += 1
                if t2 > jump.first:
                    self._confirm(line_no, out)
                else:
                    jump.latest = max(jump.latest, t2)
                return None
            self._refute(line_no, "the next sentence keeps to neither", out)
        self._jump = _Jump(t, t, line_no, [(line_no, raw, v, clock_only)])
        return None

    def _refute(self, line_no: int, why: str, out: list[RunRecord | BadRecord]) -> None:
        """The pending jump is not believed: its sentences are skipped (counted, reported)."""
        jump = self._jump
        assert jump is not None
        self._jump = None
        first_line, raw, _v, _c = jump.held[0]
        n = len(jump.held)
        off = jump.first - self._clock if self._clock is not None else 0.0
        message = (f"{_stamp(jump.first)} is {off:+.0f} s from the log clock: {n} sentence"
                   f"{'s' if n > 1 else ''} not used ({why}, line {line_no})")
        self.stats.skipped[IMPLAUSIBLE] += sum(not c for _l, _r, _v, c in jump.held)
        self.stats.event(first_line, f"{IMPLAUSIBLE} {message}")
        self._bad(IMPLAUSIBLE, first_line, raw, message, out)

    def _confirm(self, line_no: int, out: list[RunRecord | BadRecord]) -> None:
        """The pending jump is believed: the clock goes there and its sentences are used."""
        jump = self._jump
        assert jump is not None
        self._jump = None
        off = jump.first - self._clock if self._clock is not None else 0.0
        self.stats.event(jump.line, f"time jumped {off:+.0f} s to {_stamp(jump.first)} "
                         f"(confirmed by line {line_no})")
        ref = jump.first
        for ln, raw, v, clock_only in jump.held:
            placed = self._resolve(v, ref)
            if placed is None:
                continue
            t, day = placed
            self._set_day(v, day, ln)
            ref = max(ref, t)
            if self._apply(v, t, ln, raw, out, clock_only=clock_only) and not clock_only:
                self._store_used(v, t)

    # ------------------------------------------------------------------ values
    def _use(self, v: NmeaValues, line_no: int, raw: str,
             out: list[RunRecord | BadRecord]) -> None:
        t = self._place(v, line_no, raw, out)
        if t is None:
            if v.time_s is not None:
                return  # held for a jump
            if self._behind_since is not None:  # no time: skipped while the time is behind
                self._behind_count += 1
                self.stats.skipped[TIME_BACK] += 1
                return
        elif not self._apply(v, t, line_no, raw, out):
            return
        self._store_used(v, t)

    def _apply(self, v: NmeaValues, t: float, line_no: int, raw: str,
               out: list[RunRecord | BadRecord], *, clock_only: bool = False) -> bool:
        """Move the clock to a believed time ``t``; False (counted) when it is behind."""
        if self._advance(t, line_no, raw, out):
            return True
        self._behind_count += 1
        if not clock_only:
            self.stats.skipped[TIME_BACK] += 1
        return False

    def _store_used(self, v: NmeaValues, t: float | None) -> None:
        """Keep a used sentence's values at time ``t`` (the clock when None), a magnetic
        heading made true first (:meth:`_true_heading`)."""
        if v.variation_deg is not None:
            self._log_variation = (v.variation_deg, v.sentence_type)
        if v.magnetic_deg is not None:
            v = self._true_heading(v, t if t is not None else self._clock)
        self.stats.used[v.sentence_type] += 1
        for note in v.notes:
            self.stats.notes[note] += 1
        self._store(v, t if t is not None else self._clock)

    def clock_trouble(self) -> str:
        """What is wrong with the log's clock now, in a few words for a state line (""
        when nothing): ``CLOCK BEHIND 3600 s, 56 skipped`` while sentences are skipped
        because the time went back, ``CLOCK JUMP? +43200 s, 1 held`` while a jump waits."""
        if self._behind_since is not None and self._last_emitted is not None:
            back = self._last_emitted - (self._clock or 0.0)
            return f"CLOCK BEHIND {back:.0f} s, {self._behind_count} skipped"
        jump = self._jump
        if jump is not None and self._clock is not None:
            return f"CLOCK JUMP? {jump.first - self._clock:+.0f} s, {len(jump.held)} held"
        return ""

    # ------------------------------------------------------------------ variation
    def _true_heading(self, v: NmeaValues, t: float | None) -> NmeaValues:
        """A magnetic heading without a variation of its own (and none configured) made true
        with the log's latest variation (RMC/HDG), else the model's at the latest fix on the
        log's date (docs/NMEA.md "Magnetic headings"); without either it is not used (noted).
        """
        assert v.magnetic_deg is not None
        what = f"{v.sentence_type} magnetic heading without variation"
        if self._log_variation is not None:
            var, kind = self._log_variation
            key = f"the log's own variation ({kind})"
            self.stats.variation.setdefault(key, VariationUse(key)).add(var)
        else:
            pos = self._latest.pos
            day = (datetime.fromtimestamp(t, UTC).date() if t is not None and math.isfinite(t)
                   else self._date)
            if pos is None or day is None:
                return dataclasses.replace(v, magnetic_deg=None, notes=(
                    *v.notes, f"{what} before the first fix: not used (no position for the "
                    f"{MODEL} variation)"))
            if not model_covers(day):
                return dataclasses.replace(v, magnetic_deg=None, notes=(
                    *v.notes, f"{what} outside {MODEL} ({MODEL_FIRST.year}–"
                    f"{MODEL_END.year - 1}): not used"))
            cell = VARIATION_CELL_DEG
            key_cell = (round(pos[1] / cell), round(pos[2] / cell), day)
            if key_cell not in self._variation_cells:
                if len(self._variation_cells) >= VARIATION_CACHE:
                    self._variation_cells.clear()
                try:
                    self._variation_cells[key_cell] = declination_deg(
                        key_cell[0] * cell, key_cell[1] * cell, day)
                except ImportError:  # the model's package is missing from this install
                    self._variation_cells[key_cell] = None
            var_or_none = self._variation_cells[key_cell]
            if var_or_none is None:
                return dataclasses.replace(v, magnetic_deg=None, notes=(
                    *v.notes, f"{what}: not used ({MODEL} not available: ppigrf missing)"))
            var = var_or_none
            self.stats.variation.setdefault(MODEL, VariationUse(MODEL)).add(
                var, (pos[1], pos[2], day))
        heading = (v.magnetic_deg + var) % 360.0
        return dataclasses.replace(v, heading_deg=heading, magnetic_deg=None)

    def _advance(self, t: float, line_no: int, raw: str,
                 out: list[RunRecord | BadRecord]) -> bool:
        """Move the log clock to a believed time ``t``, closing the epochs before it; False
        when ``t`` is at or before the last epoch emitted after the clock went back (the
        sentence is skipped)."""
        step = self.options.interval_s
        if self._clock is None or self._next_epoch is None:
            self._clock = t
            self._next_epoch = math.ceil(t / step) * step
            self.stats.first_time = datetime.fromtimestamp(t, UTC)
            self._fill_unstamped(t)
            return True
        last = self._last_emitted
        if t < self._clock - LATE_TOLERANCE_S:  # a confirmed jump back: the clock goes back
            back = self._clock - t
            self._clock = t
            self._forget_after(t if last is None else max(t, last))
            self._next_epoch = math.ceil(t / step) * step
            if last is not None and self._next_epoch <= last:
                self._next_epoch = int(last) + step
            if last is not None and t <= last and self._behind_since is None:
                self._behind_since = line_no
                self._behind_count = 0
                message = (f"time went backwards by {back:.1f} s (to "
                           f"{datetime.fromtimestamp(t, UTC):%Y-%m-%d %H:%M:%S}): sentences "
                           "are skipped until it passes the last epoch")
                self.stats.event(line_no, message)
                self._bad(TIME_BACK, line_no, raw, message, out)
        if self._behind_since is not None:
            if last is not None and t <= last:
                self._clock = max(self._clock, t)
                return False
            self.stats.event(line_no, f"time passes the last epoch again: "
                             f"{self._behind_count} sentences skipped since line "
                             f"{self._behind_since}")
            self._behind_since = None
            self._behind_count = 0
        if t > self._clock:
            if t - self._clock > GAP_REPORT_S:
                self.stats.event(line_no, f"gap of {t - self._clock:.0f} s in the log time")
            self._close_before(t, line_no, out)
            self._clock = t
        return True

    def _forget_after(self, t: float) -> None:
        """Values stamped after ``t`` (by a clock that went back): gone."""
        for f in dataclasses.fields(self._latest):
            item = getattr(self._latest, f.name)
            if item is not None and item[0] > t:
                setattr(self._latest, f.name, None)

    def _fill_unstamped(self, t: float) -> None:
        """Values that came before the first time get that time."""
        for f in dataclasses.fields(self._latest):
            item = getattr(self._latest, f.name)
            if item is not None and math.isnan(item[0]):
                setattr(self._latest, f.name, (t, *item[1:]))

    def _store(self, v: NmeaValues, t: float | None) -> None:
        stamp = t if t is not None else math.nan  # NaN: before the first time (filled then)
        lat = self._latest
        s = self.stats.sensors
        if v.lat_deg is not None and v.lon_deg is not None:
            lat.pos = (stamp, v.lat_deg, v.lon_deg)
            s.add("position")
            self._had_fix = True
            if self.stats.first_fix is None:
                self.stats.first_fix = (v.lat_deg, v.lon_deg)
            if v.sentence_type == "GGA":
                hdop, sats = v.hdop, v.sats
                if hdop is not None and not 0.005 <= hdop <= MAX_HDOP:
                    self.stats.notes[f"GGA HDOP outside (0, {MAX_HDOP}]: not used"] += 1
                    hdop = None
                if sats is not None and sats > MAX_SATS:
                    self.stats.notes[f"GGA satellites above {MAX_SATS}: not used"] += 1
                    sats = None
                lat.gga = (stamp, v.quality, hdop, sats)
            elif lat.gga is not None and lat.gga[0] != stamp:
                lat.gga = None  # quality, HDOP, satellites belong to the GGA's own fix
        if v.heading_deg is not None:
            lat.heading = (stamp, v.heading_deg)
            s.add("heading")
        if v.stw_kn is not None:
            if v.stw_kn <= MAX_SPEED_KN:
                lat.stw = (stamp, v.stw_kn)
                s.add("water speed")
            else:
                self.stats.notes[f"water speed above {MAX_SPEED_KN:.0f} kn: not used"] += 1
        if v.cog_deg is not None:
            lat.cog = (stamp, v.cog_deg)
            s.add("course/speed over ground")
        if v.sog_kn is not None:
            if v.sog_kn <= MAX_SOG_KN:
                lat.sog = (stamp, v.sog_kn)
                s.add("course/speed over ground")
            else:
                self.stats.notes[f"speed over ground above {MAX_SOG_KN:.0f} kn: not used"] += 1
        if v.depth_m is not None:
            lat.depth = (stamp, v.depth_m)
            s.add("depth")

    # ------------------------------------------------------------------ epochs
    def _close_before(self, t: float, line_no: int, out: list[RunRecord | BadRecord]) -> None:
        """Emit the epochs before ``t`` (those with a fresh value; a long gap is jumped)."""
        assert self._next_epoch is not None
        step = self.options.interval_s
        while self._next_epoch < t:
            if not self._emit(self._next_epoch, line_no, out) and self._all_stale(
                    self._next_epoch):
                self._next_epoch = max(self._next_epoch + step, math.ceil(t / step) * step)
                continue
            self._next_epoch += step

    def _all_stale(self, epoch: float) -> bool:
        lat = self._latest
        stamps = [item[0] for item in (lat.pos, lat.heading, lat.stw, lat.cog, lat.sog, lat.depth)
                  if item is not None]
        return not stamps or epoch - max(stamps) > self._max_stale

    def _emit(self, epoch: int, line_no: int, out: list[RunRecord | BadRecord]) -> bool:
        """The record of ``epoch`` from the fresh values; False when every value is stale."""
        o = self.options
        lat = self._latest

        def fresh(item: tuple[float, float] | None, limit: float) -> float | None:
            return item[1] if item is not None and epoch - item[0] <= limit else None

        pos = lat.pos if (lat.pos is not None and epoch - lat.pos[0] <= o.position_stale_s
                          and lat.pos[0] != self._fix_used) else None
        gga = lat.gga if pos is not None and lat.gga is not None else None
        heading = fresh(lat.heading, o.heading_stale_s)
        stw = fresh(lat.stw, o.water_speed_stale_s)
        cog = fresh(lat.cog, o.cog_sog_stale_s)
        sog = fresh(lat.sog, o.cog_sog_stale_s)
        depth = fresh(lat.depth, o.depth_stale_s)
        if pos is None and all(x is None for x in (heading, stw, cog, sog, depth)):
            return False
        rec = RunRecord(
            line_no, datetime.fromtimestamp(epoch, UTC),
            None if pos is None else pos[1], None if pos is None else pos[2],
            (None, None, None), heading, stw, None, None, None, depth, "",
            gps_hdop=None if gga is None else gga[2],
            gps_quality=None if gga is None else gga[1],
            gps_sats=None if gga is None else gga[3],
            cog_deg=cog, sog_kn=sog,
        )
        out.append(self._as_run_line(rec))
        self._last_emitted = epoch
        if pos is not None:
            self._fix_used = pos[0]  # a fix is one measurement: it goes into one epoch only
        self.stats.epochs += 1
        self.stats.last_time = rec.time
        return True

    def _as_run_line(self, rec: RunRecord) -> RunRecord | BadRecord:
        """``rec`` as its ``.RUN`` line says it (values rounded as the line writes them)."""
        raw = format_run_record(rec)
        try:
            parsed = parse_run_line(raw, rec.line_no, self.source)
        except InputError as exc:  # pragma: no cover - every value is range-checked before
            return BadRecord(rec.line_no, raw, exc)
        assert parsed is not None
        return parsed

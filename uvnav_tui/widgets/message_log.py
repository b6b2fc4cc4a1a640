"""The console's message log: every message of the engine and the console, with its times.

Plain data, no widgets. The cycle worker thread and the UI thread both add entries, so every
access goes through a lock. The message line shows the newest entry (:meth:`MessageLog.newest`).
The log page (F2) and the Pg 100 panel show the entries *grouped*: each message is sorted into
alarm, warning or information (as bridge alert management does, IEC 62923-1 / IMO MSC.302(87)),
with what to do about it (:data:`CATALOG`), and a message of the same kind within
:data:`GROUP_WINDOW_S` of the first joins its group (``×37 in 10 min``) instead of taking a line
of its own (:meth:`MessageLog.groups_since`). The start and end of each run are marked.
"""

from __future__ import annotations

import math
import re
import threading
import time
from collections import deque
from dataclasses import dataclass
from datetime import UTC, datetime

from engine.api import format_time_z

LOG_LIMIT = 50_000
"""Entries kept in memory (the oldest go first, counted in :attr:`MessageLog.dropped`); the
``.OUT`` log keeps every engine message of a run on disk regardless."""


GROUP_WINDOW_S = 600.0
"""Messages of one kind within this many seconds of the first (record time; wall time for
messages outside a cycle) form one group, shown as one line with ``×N in M min``."""

ALARM, WARNING, INFO = "alarm", "warning", "info"
"""The three priorities of bridge alert management (IEC 62923-1; cautions are shown as
information): an alarm needs the officer now (and is acknowledged), a warning needs a look,
information is for the record."""
LEVEL_TAGS = {ALARM: "ALARM", WARNING: "WARN ", INFO: "     "}
"""The five-column tag before a grouped line (the display is monochrome: alarms are also in
reverse video, warnings in bold)."""
RUN_MARK = "run"
"""The kind of the run start and end marks (never grouped)."""
MARK_SOURCE = "mark"
"""The source of a run mark's entry (not a message: the message line does not show it)."""

CATALOG: tuple[tuple[str, str, str, str], ...] = (
    # (pattern at the start of the text, level, kind, what to do)
    (r"Source lost", ALARM, "source-lost",
     "the MPP is dead-reckoned from the last heading and speed, its ellipse growing; check "
     "the receiver, its cable or the network; F3 acknowledges the alarm"),
    (r"Engine error", ALARM, "engine-error",
     "the run is suspended; Run ▸ Start begins a new one (the .OUT so far is complete)"),
    (r"No MPP", ALARM, "no-mpp", "switch the gyro and the log on (Setup ▸ Sensors)"),
    (r"Decca chain .* not in the chain file", ALARM, "decca-chain",
     "choose a chain of DECCA.CHN in Setup ▸ Systems ▸ Decca"),
    (r"Fix .* σ from the filter: a gross error", WARNING, "gross-error",
     "the fix was not used: compare the LSE and the MPP (Pg 641) and check the systems' "
     "readings (Pg 611, 615); after several in a row the filter restarts from the LSE"),
    (r"Filter position re-initialised", WARNING, "filter-reset",
     "the filter restarted from the LSE: check the DR position, the gyro and the log"),
    (r"Fix fails the innovation test", WARNING, "innovation",
     "the fix was used: compare the LSE and the MPP (Pg 641) and the filter's tests "
     "(Pg 650); if it repeats, the fixes' σ (Demo ▸ LS params) or the filter's process "
     "noise (Demo ▸ Filter params) are too small for this data"),
    (r"unit variance rejected", WARNING, "unit-variance",
     "the LOPs' residuals do not fit their a priori σ: look at v and w per LOP (Pg 633); if "
     "S² stays far from 1 the σ of the systems are wrong for this data"),
    (r"advice: scale the a priori VCV by S²", INFO, "scale-vcv",
     "the fix's VCV is scaled by S² (Pg 633); raise the systems' σ (Demo ▸ LS params) if "
     "S² stays above 1"),
    (r"GPS voted out by the w-test", WARNING, "gps-voted-out",
     "check the Decca zone/lanes (Setup ▸ Systems ▸ Decca; Pg 615)"),
    (r"LOP .* fails the w-test", WARNING, "w-test-ask",
     "answer the question: Yes leaves the LOP out of this fix; compare it on Pg 631/633"),
    (r"LOP .*: w = .* reject \?", WARNING, "w-test-exceeds", "see Pg 633 (w per LOP)"),
    (r"Fix fails its tests", WARNING, "fix-fails-tests",
     "the filter took the fix (its VCV scaled by S² where it says so); look at the LOPs on "
     "Pg 633"),
    (r"LOP .* rejected", WARNING, "lop-rejected",
     "the fix was computed without it (Pg 631); if one system keeps failing, check it"),
    (r"LOP .*: w = .*not rejected", WARNING, "lop-monitored",
     "kept in the fix: watch it on Pg 633"),
    (r"LOP .*: w = .*rejection leaves no fix", WARNING, "lop-monitored",
     "too few LOPs to leave it out: check that system's reading"),
    (r"outlier detected, not identifiable", WARNING, "outlier",
     "one reading is wrong but too few LOPs say which: check each system (Pg 611, 615)"),
    (r"Decca .*lane slip", WARNING, "lane-slip",
     "the lane count was corrected from GPS: check the Decca receiver"),
    (r"Decca .*more than half a zone", WARNING, "half-zone",
     "check the zone/lane entered (Setup ▸ Systems ▸ Decca) or the DR position"),
    (r"Decca .*lane not identified", WARNING, "lane-lost",
     "enter the zone/lane (Setup ▸ Systems ▸ Decca) or wait for GPS"),
    (r"Decca: lane count not resolved", WARNING, "lane-unresolved",
     "check the DR position (Setup ▸ Params ▸ DR Pos)"),
    (r"Bad record skipped", WARNING, "bad-record",
     "the record was skipped and the run goes on (a BAD line in the .OUT); fix the file"),
    (r"No gyro heading or log speed", WARNING, "no-dr",
     "positions come from the fixes alone: switch gyro and log on or give COG/SOG"),
    (r"Pressure .* gives depth", WARNING, "pressure",
     "check the pressure sensor and Demo ▸ Parameters' pressure reference"),
    (r"Warning: ", WARNING, "data-warning", "check the data file named"),
    (r"Hardcopy failed", WARNING, "hardcopy-failed", "check the hardcopy directory"),
    (r"Script stopped", WARNING, "script", ""),
)
"""How each engine and console message is sorted, grouped and what it asks of the officer;
a message not listed is information, grouped with those that differ from it only in numbers."""
_CATALOG = tuple((re.compile(p), level, kind, advice) for p, level, kind, advice in CATALOG)
_NUMBER = re.compile(r"[-+]?\d[\d.,:]*")


def classify(text: str) -> tuple[str, str, str]:
    """(level, kind, what to do) of a message text (:data:`CATALOG`)."""
    for pattern, level, kind, advice in _CATALOG:
        if pattern.match(text):
            return level, kind, advice
    return INFO, _NUMBER.sub("#", text), ""


@dataclass(frozen=True, slots=True)
class LogEntry:
    """One message: wall-clock time (``time.time()``, s), the record time of the cycle it belongs
    to (None when there is no cycle yet), the source (``engine``, ``data`` or ``console``) and the
    literal text."""

    wall_s: float
    record_time: datetime | None
    source: str
    text: str

    @property
    def stamp(self) -> str:
        """``HH:MM:SSZ`` record time, else ``--:--:--Z``."""
        return format_time_z(self.record_time) if self.record_time is not None else "--:--:--Z"

    def line(self) -> str:
        """``HH:MM:SSZ text`` as shown in the log (the text is literal, never markup)."""
        return f"{self.stamp} {self.text}"

    def seconds(self) -> float:
        """The entry's time for grouping: record time (s since the epoch), else wall time."""
        return self.record_time.timestamp() if self.record_time is not None else self.wall_s


@dataclass(slots=True)
class MessageGroup:
    """Messages of one kind (``first`` … ``last``, ``count`` of them), numbered from 0 for
    ever; ``serial`` changes whenever the group does (a view redraws it)."""

    number: int
    level: str
    kind: str
    advice: str
    first: LogEntry
    last: LogEntry
    count: int = 1
    serial: int = 0
    created: int = 0
    """The log's serial when the group was made (rises along the log)."""

    @property
    def is_mark(self) -> bool:
        """A run start or end mark."""
        return self.kind == RUN_MARK

    def repeat_text(self) -> str:
        """``×37 in 10 min, last 10:09:52Z`` (minutes from the first to the last, at least 1),
        or ""."""
        if self.count < 2:
            return ""
        minutes = max(1, math.ceil((self.last.seconds() - self.first.seconds()) / 60.0))
        return f"×{self.count} in {minutes} min, last {self.last.stamp}"

    def line(self, wall_time: bool = False) -> str:
        """``HH:MM:SSZ WARN  text  ×37 in 10 min, last HH:MM:SSZ`` (the first message's time,
        so groups stand in time order, and the last one's text);
        a run mark as ``──── text ────`` (``wall_time``: with the wall-clock UTC time)."""
        if self.is_mark:
            when = (f" ({datetime.fromtimestamp(self.last.wall_s, UTC):%Y-%m-%d %H:%M:%S} UTC)"
                    if wall_time else "")
            return f"──── {self.last.text}{when} ────"
        repeat = self.repeat_text()
        return (f"{self.first.stamp} {LEVEL_TAGS[self.level]} {self.last.text}"
                + (f"  {repeat}" if repeat else ""))


class MessageLog:
    """A bounded, thread-safe list of :class:`LogEntry`; entries are numbered from 0 for ever."""

    def __init__(self, limit: int = LOG_LIMIT) -> None:
        self._lock = threading.Lock()
        self._entries: deque[LogEntry] = deque(maxlen=max(1, limit))
        self.total = 0
        """Entries ever added (the number the next one gets)."""
        self._groups: deque[MessageGroup] = deque(maxlen=max(1, limit))
        self._open: dict[str, MessageGroup] = {}
        self.groups_total = 0
        """Groups ever made (the number the next one gets)."""
        self.serial = 0
        """Changes of the groups so far (each new or grown group takes the next)."""

    @property
    def dropped(self) -> int:
        """Entries no longer kept (beyond :data:`LOG_LIMIT`)."""
        with self._lock:
            return self.total - len(self._entries)

    def add(self, text: str, record_time: datetime | None = None, source: str = "console",
            *, wall_s: float | None = None) -> LogEntry:
        """Append one message (blank texts are ignored but returned)."""
        entry = LogEntry(time.time() if wall_s is None else wall_s, record_time, source, text)
        if not text.strip():
            return entry
        with self._lock:
            self._entries.append(entry)
            self.total += 1
            self._group(entry)
        return entry

    def mark(self, text: str) -> LogEntry:
        """A run start or end mark (``Run started …``): a line of its own that ends every
        group (the next run's messages start new ones)."""
        entry = LogEntry(time.time(), None, MARK_SOURCE, text)
        with self._lock:
            self._entries.append(entry)
            self.total += 1
            self._open.clear()
            self._new_group(entry, INFO, RUN_MARK, "")
            self._open.clear()
        return entry

    def _group(self, entry: LogEntry) -> None:
        level, kind, advice = classify(entry.text)
        group = self._open.get(kind)
        if group is not None and entry.seconds() - group.first.seconds() <= GROUP_WINDOW_S \
                and entry.seconds() >= group.last.seconds():
            group.last = entry
            group.count += 1
            self.serial += 1
            group.serial = self.serial
            return
        self._open[kind] = self._new_group(entry, level, kind, advice)

    def _new_group(self, entry: LogEntry, level: str, kind: str, advice: str) -> MessageGroup:
        self.serial += 1
        group = MessageGroup(self.groups_total, level, kind, advice, entry, entry,
                             serial=self.serial, created=self.serial)
        self._groups.append(group)
        self.groups_total += 1
        return group

    def groups_since(self, serial: int) -> tuple[int, list[MessageGroup]]:
        """(the serial now, copies of the groups changed since ``serial``: new or grown), for
        a view that draws what changed."""
        with self._lock:
            now = self.serial
            if now == serial:
                return now, []
            new: list[MessageGroup] = []
            for g in reversed(self._groups):  # made since: a suffix of the log
                if g.created <= serial:
                    break
                new.append(g)
            grown = [g for g in self._open.values() if g.created <= serial < g.serial]
            changed = sorted(grown, key=lambda g: g.number) + new[::-1]
        return now, [_copy(g) for g in changed]

    def recent_groups(self, n: int) -> list[MessageGroup]:
        """The last ``n`` groups (copies), oldest first."""
        with self._lock:
            items = list(self._groups)[-n:] if n > 0 else []
            return [_copy(g) for g in items]

    @property
    def groups_kept(self) -> int:
        """Groups still kept."""
        with self._lock:
            return len(self._groups)

    def newest(self) -> LogEntry | None:
        """The last entry that is a message (not a run mark), or None."""
        with self._lock:
            for entry in reversed(self._entries):
                if entry.source != MARK_SOURCE:
                    return entry
            return None

    def since(self, index: int) -> tuple[int, list[LogEntry]]:
        """Entries numbered ``index`` and later that are still kept, and the number of the
        first one returned (larger than ``index`` when older ones were dropped)."""
        with self._lock:
            first = self.total - len(self._entries)
            start = max(index, first)
            items = list(self._entries)[start - first:] if start < self.total else []
            return start, items

    def __len__(self) -> int:
        with self._lock:
            return len(self._entries)


def _copy(g: MessageGroup) -> MessageGroup:
    """A snapshot of a group (the log goes on changing the original)."""
    return MessageGroup(g.number, g.level, g.kind, g.advice, g.first, g.last, g.count, g.serial,
                        g.created)

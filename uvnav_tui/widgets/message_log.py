"""The console's message log: every message of the engine and the console, with its times.

Plain data, no widgets. The cycle worker thread and the UI thread both add entries, so every
access goes through a lock. The message line shows the newest entry (:meth:`MessageLog.newest`),
the log page and the Pg 100 panel show them all (:meth:`MessageLog.since`).
"""

from __future__ import annotations

import threading
import time
from collections import deque
from dataclasses import dataclass
from datetime import datetime

from engine.api import format_time_z

LOG_LIMIT = 50_000
"""Entries kept in memory (the oldest go first, counted in :attr:`MessageLog.dropped`); the
``.OUT`` log keeps every engine message of a run on disk regardless."""


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


class MessageLog:
    """A bounded, thread-safe list of :class:`LogEntry`; entries are numbered from 0 for ever."""

    def __init__(self, limit: int = LOG_LIMIT) -> None:
        self._lock = threading.Lock()
        self._entries: deque[LogEntry] = deque(maxlen=max(1, limit))
        self.total = 0
        """Entries ever added (the number the next one gets)."""

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
        return entry

    def newest(self) -> LogEntry | None:
        """The last entry, or None."""
        with self._lock:
            return self._entries[-1] if self._entries else None

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

"""NMEA 0183 log files as run input (docs/NMEA.md): sniffing, streaming, ``.RUN`` or NMEA.

:func:`is_nmea_file` decides by content, not by suffix; :class:`NmeaLog` streams a log through
:class:`~engine.io.nmea_epochs.EpochBuilder` one line at a time (constant memory, lines over
:data:`MAX_LINE_CHARS` characters are damage, not read whole); :func:`open_records` gives the
record iterator of either kind of run file.
"""

from __future__ import annotations

import os
import re
import stat
from collections.abc import Iterator

from engine.errors import InputError
from engine.io.nmea_epochs import EpochBuilder, NmeaOptions, NmeaStats
from engine.io.nmea_sentences import SkipKind
from engine.io.runfile import BadRecord, RunRecord, check_input_file, iter_run_file

__all__ = ["NmeaLog", "is_nmea_file", "open_records", "scan_nmea_log"]

SNIFF_BYTES = 1 << 16
"""Bytes read to decide whether a file is an NMEA log."""
SNIFF_LINES = 10
"""Non-empty lines looked at (at most) to decide."""
MAX_LINE_CHARS = 1024
"""Longest log line read (a sentence is at most 82 characters); longer ones are damage."""
_SENTENCE_RE = re.compile(r"[$!][A-Z0-9]{5},[\x20-\x7e]*\*[0-9A-Fa-f]{2}\Z")


def is_nmea_file(path: str | os.PathLike[str]) -> bool:
    """True when the first non-empty lines of a regular file are mostly NMEA sentences
    (``$``/``!``, five characters, fields, ``*hh``): at least 2 of the first
    :data:`SNIFF_LINES` (or the only one) and more than half of them. False for anything
    unreadable (its reader then reports why)."""
    try:
        name = os.fspath(path)
        if "\0" in name or not stat.S_ISREG(os.stat(name).st_mode):
            return False
        with open(name, "rb") as fh:
            head = fh.read(SNIFF_BYTES)
    except (OSError, ValueError):
        return False
    lines = [ln.strip() for ln in head.decode("ascii", "replace").splitlines() if ln.strip()]
    if len(head) == SNIFF_BYTES and len(lines) > 1:
        lines = lines[:-1]  # the last line may be cut by the read
    lines = lines[:SNIFF_LINES]
    good = sum(1 for ln in lines if _SENTENCE_RE.match(ln))
    return good >= min(2, len(lines)) and good * 2 > len(lines)


CONVERTED_RUN_MARK = "* UVNAV .RUN converted from the NMEA 0183 log"
"""First line of a ``.RUN`` that ``uvnav convert`` wrote from an NMEA log."""


def is_converted_nmea_run(path: str | os.PathLike[str]) -> bool:
    """True when ``path`` is a ``.RUN`` written by ``uvnav convert`` (its first line is
    :data:`CONVERTED_RUN_MARK`): its records come from an NMEA log, so a run treats it as one
    (``filter.vessel = "auto"``), and replaying it gives the cycles of the log. False for
    anything unreadable."""
    try:
        name = os.fspath(path)
        if "\0" in name or not stat.S_ISREG(os.stat(name).st_mode):
            return False
        with open(name, "rb") as fh:
            head = fh.read(len(CONVERTED_RUN_MARK))
    except (OSError, ValueError):
        return False
    return head == CONVERTED_RUN_MARK.encode("ascii")


class NmeaLog:
    """The records of an NMEA log (an iterable of RunRecord | BadRecord, read once).

    The file is checked when this is built (missing, unreadable, not a regular file: an
    ``InputError`` before anything runs); it is opened on the first ``next()``. ``stats`` fills
    as it is read (complete once the iterator is exhausted).
    """

    def __init__(self, path: str | os.PathLike[str], options: NmeaOptions | None = None) -> None:
        self.name = check_input_file(path)
        self.options = options if options is not None else NmeaOptions()
        self._builder = EpochBuilder(self.options, self.name)
        self._iter = self._stream()

    @property
    def stats(self) -> NmeaStats:
        """What the log gave so far (sentences used/skipped, events, sensors)."""
        return self._builder.stats

    def __iter__(self) -> NmeaLog:
        return self

    def __next__(self) -> RunRecord | BadRecord:
        return next(self._iter)

    def close(self) -> None:
        """Stop reading (closes the file)."""
        self._iter.close()

    def _stream(self) -> Iterator[RunRecord | BadRecord]:
        builder = self._builder
        with open(self.name, "rb") as fh:
            line_no = 0
            while data := fh.readline(MAX_LINE_CHARS + 1):
                line_no += 1
                if len(data) > MAX_LINE_CHARS and not data.endswith(b"\n"):
                    while data and not data.endswith(b"\n"):
                        data = fh.readline(1 << 16)
                    builder.stats.lines += 1
                    builder.stats.skipped[SkipKind.MALFORMED] += 1
                    yield BadRecord(line_no, "", InputError(
                        f"Line too long (more than {MAX_LINE_CHARS} characters) !",
                        file=self.name, line=line_no, field=SkipKind.MALFORMED))
                    continue
                yield from builder.feed(data.decode("ascii", "replace"), line_no)
            yield from builder.finish()


def open_records(
    path: str | os.PathLike[str], nmea_options: NmeaOptions | None = None
) -> Iterator[RunRecord | BadRecord]:
    """The records of a run file: an :class:`NmeaLog` when the content is NMEA 0183
    (:func:`is_nmea_file`), else the ``.RUN`` reader (:func:`engine.io.runfile.iter_run_file`)."""
    if is_nmea_file(path):
        return NmeaLog(path, nmea_options)
    return iter_run_file(path)


def scan_nmea_log(path: str | os.PathLike[str], options: NmeaOptions | None = None) -> NmeaStats:
    """Read a whole log once and return what it gave (sentences, sensors, first fix), for a
    derived configuration and the ``.OUT`` header before the run starts."""
    log = NmeaLog(path, options)
    for _ in log:
        pass
    return log.stats

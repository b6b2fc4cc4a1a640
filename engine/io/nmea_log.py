"""NMEA 0183 log files as run input (docs/NMEA.md): sniffing, streaming, ``.RUN`` or NMEA.

:func:`sniff_log` decides by content, not by suffix, and says what a file that is no log is;
:class:`NmeaLog` streams a log through :class:`~engine.io.nmea_epochs.EpochBuilder` one line at
a time (constant memory, lines over :data:`MAX_LINE_CHARS` characters are damage, not read
whole), with any line end (LF, CR LF, CR) and through gzip when the file is compressed
(:func:`open_log_text`); :func:`open_records` gives the record iterator of either kind of run
file.
"""

from __future__ import annotations

import gzip
import io
import os
import re
import stat
import zlib
from collections.abc import Iterator
from dataclasses import dataclass
from typing import BinaryIO, TextIO

from engine.io.nmea_epochs import EpochBuilder, NmeaOptions, NmeaStats
from engine.io.nmea_sentences import SkipKind
from engine.io.runfile import (
    BadRecord,
    QuickParser,
    RunRecord,
    check_input_file,
    iter_run_file,
)

__all__ = ["LogSniff", "NmeaLog", "is_nmea_file", "not_nmea_message", "open_log_text",
           "open_records", "scan_nmea_log", "sniff_log"]

SNIFF_LINES = 10
"""Non-empty lines looked at (at most) to decide."""
SNIFF_MAX_CHARS = 1 << 24
"""Characters read at most to find those lines (an over-long first line is skipped over)."""
MAX_LINE_CHARS = 1024
"""Longest log line read (a sentence is at most 82 characters); longer ones are damage."""
GZIP_MAGIC = b"\x1f\x8b"
"""First bytes of a gzip file (RFC 1952): a log rotated by its logger (``.nmea.gz``)."""
_SENTENCE_RE = re.compile(
    r"[$!](?:[A-Z0-9]{5}|P[A-Z0-9]{3,9}),[\x20-\x7e]*\*[0-9A-Fa-f]{2}\Z")
_NOT_TEXT_RE = re.compile(r"[^\t\x20-\x7e]")
"""A character that is not printable ASCII or a tab (bytes outside ASCII read as U+FFFD)."""
_NOT_TEXT_MAGIC = (
    (b"\xff\xfe\x00\x00", "UTF-32 text, byte-order mark FF FE 00 00, not ASCII"),
    (b"\x00\x00\xfe\xff", "UTF-32 text, byte-order mark 00 00 FE FF, not ASCII"),
    (b"\xff\xfe", "UTF-16 text, byte-order mark FF FE, not ASCII"),
    (b"\xfe\xff", "UTF-16 text, byte-order mark FE FF, not ASCII"),
    (b"PK\x03\x04", "a ZIP archive: unpack it first"),
    (b"BZh", "bzip2-compressed data: only gzip is read, decompress it first"),
    (b"\xfd7zXZ\x00", "xz-compressed data: only gzip is read, decompress it first"),
    (b"\x28\xb5\x2f\xfd", "zstd-compressed data: only gzip is read, decompress it first"),
)
"""Leading bytes of files that are not ASCII text, and what they are (for the message)."""
_GZIP_ERRORS = (EOFError, zlib.error, gzip.BadGzipFile)
"""What a damaged or cut gzip file raises while it is read."""


@dataclass(frozen=True)
class LogSniff:
    """What :func:`sniff_log` found: ``nmea`` (an NMEA 0183 log), ``text`` (plain text lines,
    which a ``.RUN`` file may be), ``gzip`` (read through gzip) and ``what`` the file is, for a
    message (``"an empty file"``, ``"UTF-16 text …"``, ``"text: 0 of 10 lines are NMEA
    sentences"`` …)."""

    nmea: bool
    text: bool
    gzip: bool
    what: str


def open_log_text(name: str) -> TextIO:
    """A log file as text lines: gzip-compressed or not (by its first bytes), any line end
    (LF, CR LF or CR alone: universal newlines, each read as ``\\n``), bytes outside ASCII
    as U+FFFD (so such a line is noise, never a crash). Raises ``OSError`` as ``open`` does."""
    with open(name, "rb") as fh:
        compressed = fh.read(2) == GZIP_MAGIC
    binary: BinaryIO = gzip.open(name, "rb") if compressed else open(name, "rb")  # noqa: SIM115
    try:
        return io.TextIOWrapper(binary, encoding="ascii", errors="replace", newline=None)
    except BaseException:
        binary.close()
        raise


def _head_lines(fh: TextIO) -> tuple[list[str], int]:
    """The first :data:`SNIFF_LINES` non-empty lines (stripped; an over-long line is one
    line ``"\\x1a"``, never a sentence) and how many lines were over-long."""
    lines: list[str] = []
    long = 0
    total = 0
    while len(lines) < SNIFF_LINES and total < SNIFF_MAX_CHARS:
        data = fh.readline(MAX_LINE_CHARS + 1)
        if not data:
            break
        total += len(data)
        if len(data) > MAX_LINE_CHARS and not data.endswith("\n"):
            while data and not data.endswith("\n") and total < SNIFF_MAX_CHARS:
                data = fh.readline(1 << 16)
                total += len(data)
            lines.append("\x1a")
            long += 1
        elif data.strip():
            lines.append(data.strip())
    return lines, long


def sniff_log(path: str | os.PathLike[str]) -> LogSniff:
    """Whether a regular file is an NMEA 0183 log, and if not what it is (:class:`LogSniff`).

    A log: the first non-empty lines are mostly NMEA sentences (``$``/``!``, the address,
    fields, ``*hh``): at least 2 of the first :data:`SNIFF_LINES` (or the only one) and more
    than half of them; lines may end in LF, CR LF or CR; the file may be gzip-compressed; an
    over-long line counts as one line that is not a sentence. Anything unreadable is not a
    log (its reader then reports why)."""
    try:
        name = os.fspath(path)
        if "\0" in name or not stat.S_ISREG(os.stat(name).st_mode):
            return LogSniff(False, False, False, "not a regular file")
        with open(name, "rb") as fh:
            head = fh.read(8)
    except (OSError, ValueError):
        return LogSniff(False, False, False, "not readable")
    if not head:
        return LogSniff(False, False, False, "an empty file")
    for magic, what in _NOT_TEXT_MAGIC:
        if head.startswith(magic):
            return LogSniff(False, False, False, what)
    compressed = head.startswith(GZIP_MAGIC)
    prefix = "gzip-compressed " if compressed else ""
    try:
        with open_log_text(name) as text:
            lines, long = _head_lines(text)
    except _GZIP_ERRORS as exc:
        return LogSniff(False, False, True, f"gzip-compressed data that cannot be read: {exc}")
    except OSError:
        return LogSniff(False, False, compressed, "not readable")
    if not lines:
        what = "an empty file" if compressed else "a file of blank lines only"
        return LogSniff(False, False, compressed, prefix + what)
    good = sum(1 for ln in lines if _SENTENCE_RE.match(ln))
    if good >= min(2, len(lines)) and good * 2 > len(lines):
        return LogSniff(True, True, compressed, prefix + "NMEA 0183 log")
    if any("\x00" in ln for ln in lines):
        return LogSniff(False, False, compressed, prefix + "binary data with NUL bytes: not "
                        "text, or UTF-16 text without a byte-order mark")
    noisy = sum(1 for ln in lines if ln != "\x1a" and _NOT_TEXT_RE.search(ln))
    if noisy * 2 > len(lines):
        return LogSniff(False, False, compressed,
                        prefix + f"binary data: {noisy} of the first {len(lines)} lines are "
                        "not printable ASCII")
    return LogSniff(False, not compressed, compressed,
                    prefix + f"text: {good} of its first {len(lines)} non-empty lines are NMEA "
                    f"0183 sentences $TTSSS,…*hh"
                    + (f", {long} longer than {MAX_LINE_CHARS} characters" if long else ""))


def is_nmea_file(path: str | os.PathLike[str]) -> bool:
    """True when the file is an NMEA 0183 log (:func:`sniff_log`). False for anything
    unreadable (its reader then reports why)."""
    return sniff_log(path).nmea


def not_nmea_message(sniff: LogSniff) -> str:
    """The message for a file that is not a log: ``Not an NMEA 0183 log (what it is) !``."""
    return f"Not an NMEA 0183 log ({sniff.what}) !"


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
        with open_log_text(self.name) as fh:
            line_no = 0
            while True:
                try:
                    data = fh.readline(MAX_LINE_CHARS + 1)
                    too_long = len(data) > MAX_LINE_CHARS and not data.endswith("\n")
                    while data and not data.endswith("\n") and too_long:
                        data = fh.readline(1 << 16)
                except _GZIP_ERRORS as exc:  # a cut or damaged .gz: what came before is used
                    yield from builder.damaged(
                        line_no + 1, "", SkipKind.MALFORMED,
                        f"gzip data damaged ({exc}): the rest of the log cannot be read !")
                    break
                if not data and not too_long:
                    break
                line_no += 1
                if too_long:
                    yield from builder.damaged(
                        line_no, "", SkipKind.MALFORMED,
                        f"Line too long (more than {MAX_LINE_CHARS} characters) !")
                    continue
                yield from builder.feed(data, line_no)
            yield from builder.finish()


def open_records(
    path: str | os.PathLike[str], nmea_options: NmeaOptions | None = None,
    quick: QuickParser | None = None,
) -> Iterator[RunRecord | BadRecord]:
    """The records of a run file: an :class:`NmeaLog` when the content is NMEA 0183
    (:func:`is_nmea_file`), else the ``.RUN`` reader (:func:`engine.io.runfile.iter_run_file`,
    with the run's ``quick`` parser of the usual line, if any)."""
    if is_nmea_file(path):
        return NmeaLog(path, nmea_options)
    return iter_run_file(path, quick)


def scan_nmea_log(path: str | os.PathLike[str], options: NmeaOptions | None = None) -> NmeaStats:
    """Read a whole log once and return what it gave (sentences, sensors, first fix), for a
    derived configuration and the ``.OUT`` header before the run starts."""
    log = NmeaLog(path, options)
    for _ in log:
        pass
    return log.stats

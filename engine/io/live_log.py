"""The raw log of a live source: every received line, exactly as received, beside the ``.OUT``.

Two files with one stem, ``NAME`` being the ``.OUT`` log's name without its suffix
(docs/LIVE.md):

* ``NAME.raw.nmea`` — the lines in arrival order, each ended by CR LF (NMEA 0183's own line
  end, whatever the source used), byte for byte otherwise (written as Latin-1: one byte per
  received byte, binary noise included). Nothing else is in it, so it is an ordinary NMEA log:
  ``uvnav replay NAME.raw.nmea``, OpenCPN's VDR player or gpsd's ``gpsfake`` replay it.
* ``NAME.raw.times.csv`` — the receive times, compactly: a first line
  ``# UVNAV live receive times …`` naming the source, a header ``line,lines,utc,mono_s``, then
  one row per :data:`TIMES_ROW_S` of reception at most: ``lines`` consecutive raw lines from
  line number ``line`` (1-based, counted through all parts) were received from the UTC time
  ``utc`` (ISO 8601, microseconds, ``Z``; the row's first line) on, within
  :data:`TIMES_ROW_S`; ``mono_s`` is the same moment in seconds since the log was opened
  (monotonic clock: immune to clock steps, the figure latency is measured with). So the file
  grows by at most 10 rows a second whatever the stream's rate. Comment lines in between:
  each change of the source's state ``# state UTC mono_s STATUS: detail``, and each gap of
  lines not kept ``# dropped UTC mono_s N lines (…), M datagrams (…) before line L``, so
  ``pandas.read_csv(path, comment="#")`` reads the rows alone.

**Parts.** When ``NAME.raw.nmea`` reaches ``part_bytes`` (:data:`RAW_PART_BYTES`) the
recording goes on in ``NAME.2.raw.nmea`` + ``NAME.2.raw.times.csv``, then ``NAME.3…``: each
file stays below the size, each part is an NMEA log of its own, and line numbers count on
through the parts (``cat`` the parts to replay the whole recording). Nothing is deleted.

Why a side file and not an NMEA 4.10 TAG block (``\\c:1764679398*hh\\$GPGGA…``) per line: a TAG
block changes every line, and neither pynmea2 (which the NMEA reader uses) nor most chart
plotters or ``gpsfake`` accept it, so the raw log would no longer replay as an NMEA log; the
line number joins the two files exactly.

Both files follow the ``.OUT`` rule (engine/io/outputs.py) with one difference: a raw
recording is evidence and is never replaced, not even with ``--force``; the first stem
``NAME``, ``NAME_1``, ``NAME_2`` … for which neither file exists is used (exclusive create).
"""

from __future__ import annotations

import os
import time
from datetime import UTC, datetime
from pathlib import Path

from engine.errors import InputError
from engine.io.live_sources import ReceivedLine, SourceState
from engine.io.outputs import OutputFile, OutputGuard

RAW_SUFFIX = ".raw.nmea"
TIMES_SUFFIX = ".raw.times.csv"
TIMES_SIGNATURE = "# UVNAV live receive times"
TIMES_COLUMNS = "line,lines,utc,mono_s"
TIMES_ROW_S = 0.1
"""Longest span of receive times one row of the times file covers [s] (a row per datagram or
read when they are further apart)."""
RAW_PART_BYTES = 64 * 1024 * 1024
"""Size at which the raw log goes on in a new part (about two days of a 4800-baud stream)."""


def raw_log_stem(out_path: str | os.PathLike[str]) -> Path:
    """The stem of the raw log beside an ``.OUT`` log: ``DIR/NAME.OUT`` → ``DIR/NAME``."""
    path = Path(out_path)
    return path.with_name(path.name[: -len(path.suffix)] if path.suffix else path.name)


def utc_text(utc_s: float) -> str:
    """POSIX seconds as ISO 8601 UTC with microseconds: ``2026-12-02T12:43:18.123456Z``."""
    return datetime.fromtimestamp(utc_s, UTC).strftime("%Y-%m-%dT%H:%M:%S.%fZ")


class RawLog:
    """An open raw log (module docstring): :meth:`write_line` per received line,
    :meth:`write_state` per change of state, :meth:`flush` after each batch."""

    def __init__(self, raw: OutputFile, times: OutputFile, origin_mono_s: float, *,
                 source_url: str = "", guard: OutputGuard | None = None,
                 part_bytes: int = RAW_PART_BYTES) -> None:
        self._raw = raw
        self._times = times
        self.origin_mono_s = origin_mono_s
        """Monotonic time [s] the ``mono_s`` column counts from."""
        self.lines = 0
        self.paths: list[Path] = [raw.path]
        """Every part's ``.raw.nmea``, the first one first."""
        self.part_bytes = part_bytes
        self._source_url = source_url
        self._guard = guard if guard is not None else OutputGuard()
        self._stem = raw.path.with_name(raw.path.name[: -len(RAW_SUFFIX)])
        self._bytes = 0
        self._row: list[float | int] | None = None  # first line, count, utc, mono
        self.rows = 0
        """Rows written to the times files."""

    @property
    def path(self) -> Path:
        """``NAME.raw.nmea`` (the first part)."""
        return self.paths[0]

    @property
    def times_path(self) -> Path:
        """``NAME.raw.times.csv`` (the first part's)."""
        return self.paths[0].with_name(self.paths[0].name[: -len(RAW_SUFFIX)] + TIMES_SUFFIX)

    @classmethod
    def create(
        cls,
        stem: str | os.PathLike[str],
        *,
        source_url: str,
        origin_mono_s: float,
        guard: OutputGuard | None = None,
        part_bytes: int = RAW_PART_BYTES,
    ) -> RawLog:
        """Create ``STEM.raw.nmea`` and ``STEM.raw.times.csv`` under the first stem ``STEM``,
        ``STEM_1``, … for which neither exists (never replaced). ``origin_mono_s`` is the
        monotonic time the ``mono_s`` column counts from; ``part_bytes`` the size of a part.
        Raises :class:`InputError` (field ``raw log``) for a name that can never be an output,
        :class:`OSError` naming the file when one cannot be created."""
        guard = guard if guard is not None else OutputGuard()
        base = Path(stem)
        n = 0
        while True:
            name = base.name if n == 0 else f"{base.name}_{n}"
            n += 1
            pair = _open_pair(base.with_name(name), source_url, guard, note="")
            if pair is None:
                continue
            return cls(*pair, origin_mono_s, source_url=source_url, guard=guard,
                       part_bytes=part_bytes)

    def write_line(self, line: ReceivedLine) -> int:
        """Append one received line; returns its line number (counted through the parts).
        Lines dropped before it (:attr:`ReceivedLine.dropped_before`) are noted first."""
        if self._bytes >= self.part_bytes:
            self._next_part()
        if line.dropped_before or line.sys_dropped_before:
            self.write_drops(line.dropped_before, line.sys_dropped_before, line.utc_s,
                             line.mono_s, f"before line {self.lines + 1}")
        self.lines += 1
        text = line.text + "\r\n"
        self._raw.write(text)
        self._bytes += len(text)
        row = self._row
        if row is not None and line.mono_s - row[3] < TIMES_ROW_S:
            row[1] += 1
        else:
            self._end_row()
            self._row = [self.lines, 1, line.utc_s, line.mono_s]
        return self.lines

    def write_drops(self, lines: int, datagrams: int, utc_s: float, mono_s: float,
                    where: str) -> None:
        """Note a gap: ``lines`` received but dropped (the waiting lines full), ``datagrams``
        dropped by the system (socket buffer full), ``where`` (``before line 12``)."""
        self._end_row()
        self._times.write(f"# dropped {utc_text(utc_s)} {mono_s - self.origin_mono_s:.6f} "
                          f"{lines} lines (UVNAV: waiting lines full), {datagrams} datagrams "
                          f"(system: socket buffer full) {where}\n")

    def write_state(self, state: SourceState, utc_s: float) -> None:
        """Note a change of the source's state (a comment line of the times file)."""
        self._end_row()
        detail = f": {state.detail}" if state.detail else ""
        text = f"{state.status}{detail}".replace("\n", " ").replace("\r", " ")
        self._times.write(f"# state {utc_text(utc_s)} "
                          f"{state.since_mono_s - self.origin_mono_s:.6f} {text}\n")

    def _end_row(self) -> None:
        row = self._row
        if row is not None:
            self._row = None
            self.rows += 1
            self._times.write(f"{row[0]},{row[1]},{utc_text(row[2])},"
                              f"{row[3] - self.origin_mono_s:.6f}\n")

    def _next_part(self) -> None:
        """Go on in the next part (module docstring "Parts")."""
        self._end_row()
        k = len(self.paths) + 1
        while True:
            pair = _open_pair(self._stem.with_name(f"{self._stem.name}.{k}"), self._source_url,
                              self._guard, note=f", part {k} of {self.paths[0].name}, "
                              f"first line {self.lines + 1}")
            if pair is not None:
                break
            k += 1
        self.close()
        self._raw, self._times = pair
        self.paths.append(self._raw.path)
        self._bytes = 0

    def flush(self, now_mono_s: float | None = None) -> None:
        """Hand both files to the operating system (after each batch of lines); the open row
        of receive times is written once its :data:`TIMES_ROW_S` are over at ``now_mono_s``
        (None: now)."""
        row = self._row
        now = time.monotonic() if now_mono_s is None else now_mono_s
        if row is not None and now - row[3] >= TIMES_ROW_S:
            self._end_row()
        self._raw.flush()
        self._times.flush()

    def close(self) -> None:
        """Write the open row, flush and close both files (both are closed even if one
        fails)."""
        try:
            self._end_row()
        finally:
            try:
                self._raw.close()
            finally:
                self._times.close()


def _open_pair(stem: Path, source_url: str, guard: OutputGuard,
               note: str) -> tuple[OutputFile, OutputFile] | None:
    """``STEM.raw.nmea`` and ``STEM.raw.times.csv``, both new (exclusive create), the times
    file's first lines written; None when either exists (or was taken meanwhile)."""
    raw_path = stem.with_name(stem.name + RAW_SUFFIX)
    times_path = stem.with_name(stem.name + TIMES_SUFFIX)
    if os.path.lexists(raw_path) or os.path.lexists(times_path):
        return None
    try:
        raw = guard.open(raw_path, label="raw log", kind="nmea_raw", existing="refuse",
                         encoding="latin-1")
    except InputError as exc:
        if os.path.lexists(raw_path):
            return None  # taken meanwhile
        raise exc from None
    try:
        times = guard.open(times_path, label="raw log times", kind="raw_times",
                           existing="refuse")
    except BaseException as exc:
        raw.close()
        raw.path.unlink(missing_ok=True)
        if isinstance(exc, InputError) and os.path.lexists(times_path):
            return None
        raise
    times.write(f"{TIMES_SIGNATURE}: source {source_url}, raw log {raw.path.name}{note}, "
                "mono_s = seconds since the log was opened (monotonic clock), a row per "
                f"{TIMES_ROW_S:g} s at most\n{TIMES_COLUMNS}\n")
    times.flush()
    return raw, times


__all__ = ["RAW_PART_BYTES", "RAW_SUFFIX", "TIMES_ROW_S", "TIMES_SUFFIX", "RawLog",
           "raw_log_stem", "utc_text"]

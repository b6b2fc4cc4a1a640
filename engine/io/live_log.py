"""The raw log of a live source: every received line, exactly as received, beside the ``.OUT``.

Two files with one stem, ``NAME`` being the ``.OUT`` log's name without its suffix
(docs/LIVE.md):

* ``NAME.raw.nmea`` — the lines in arrival order, each ended by CR LF (NMEA 0183's own line
  end, whatever the source used), byte for byte otherwise (written as Latin-1: one byte per
  received byte, binary noise included). Nothing else is in it, so it is an ordinary NMEA log:
  ``uvnav replay NAME.raw.nmea``, OpenCPN's VDR player or gpsd's ``gpsfake`` replay it.
* ``NAME.raw.times.csv`` — the receive time of each line: a first line
  ``# UVNAV live receive times …`` naming the source, a header ``line,utc,mono_s``, then one
  row per raw line: its 1-based line number in ``NAME.raw.nmea``, the UTC receive time
  (ISO 8601, microseconds, ``Z``) and the seconds since the log was opened (monotonic clock:
  immune to clock steps, the figure latency is measured with). Each change of the source's
  state is a comment line ``# state UTC mono_s STATUS: detail`` in between, so
  ``pandas.read_csv(path, comment="#")`` reads the rows alone.

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
from datetime import UTC, datetime
from pathlib import Path

from engine.errors import InputError
from engine.io.live_sources import ReceivedLine, SourceState
from engine.io.outputs import OutputFile, OutputGuard

RAW_SUFFIX = ".raw.nmea"
TIMES_SUFFIX = ".raw.times.csv"
TIMES_SIGNATURE = "# UVNAV live receive times"
TIMES_COLUMNS = "line,utc,mono_s"


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

    def __init__(self, raw: OutputFile, times: OutputFile, origin_mono_s: float) -> None:
        self._raw = raw
        self._times = times
        self.origin_mono_s = origin_mono_s
        """Monotonic time [s] the ``mono_s`` column counts from."""
        self.lines = 0

    @property
    def path(self) -> Path:
        """``NAME.raw.nmea``."""
        return self._raw.path

    @property
    def times_path(self) -> Path:
        """``NAME.raw.times.csv``."""
        return self._times.path

    @classmethod
    def create(
        cls,
        stem: str | os.PathLike[str],
        *,
        source_url: str,
        origin_mono_s: float,
        guard: OutputGuard | None = None,
    ) -> RawLog:
        """Create ``STEM.raw.nmea`` and ``STEM.raw.times.csv`` under the first stem ``STEM``,
        ``STEM_1``, … for which neither exists (never replaced). ``origin_mono_s`` is the
        monotonic time the ``mono_s`` column counts from. Raises :class:`InputError` (field
        ``raw log``) for a name that can never be an output, :class:`OSError` naming the file
        when one cannot be created."""
        guard = guard if guard is not None else OutputGuard()
        base = Path(stem)
        n = 0
        while True:
            name = base.name if n == 0 else f"{base.name}_{n}"
            raw_path = base.with_name(name + RAW_SUFFIX)
            times_path = base.with_name(name + TIMES_SUFFIX)
            n += 1
            if os.path.lexists(raw_path) or os.path.lexists(times_path):
                continue
            try:
                raw = guard.open(raw_path, label="raw log", kind="nmea_raw", existing="refuse",
                                 encoding="latin-1")
            except InputError as exc:
                if os.path.lexists(raw_path):
                    continue  # taken meanwhile
                raise exc from None
            try:
                times = guard.open(times_path, label="raw log times", kind="raw_times",
                                   existing="refuse")
            except BaseException as exc:
                raw.close()
                raw.path.unlink(missing_ok=True)
                if isinstance(exc, InputError) and os.path.lexists(times_path):
                    continue
                raise
            log = cls(raw, times, origin_mono_s)
            times.write(f"{TIMES_SIGNATURE}: source {source_url}, raw log {raw.path.name}, "
                        "mono_s = seconds since the log was opened (monotonic clock)\n"
                        f"{TIMES_COLUMNS}\n")
            times.flush()
            return log

    def write_line(self, line: ReceivedLine) -> int:
        """Append one received line; returns its line number in ``NAME.raw.nmea``."""
        self.lines += 1
        self._raw.write(line.text + "\r\n")
        self._times.write(f"{self.lines},{utc_text(line.utc_s)},"
                          f"{line.mono_s - self.origin_mono_s:.6f}\n")
        return self.lines

    def write_state(self, state: SourceState, utc_s: float) -> None:
        """Note a change of the source's state (a comment line of the times file)."""
        detail = f": {state.detail}" if state.detail else ""
        text = f"{state.status}{detail}".replace("\n", " ").replace("\r", " ")
        self._times.write(f"# state {utc_text(utc_s)} "
                          f"{state.since_mono_s - self.origin_mono_s:.6f} {text}\n")

    def flush(self) -> None:
        """Hand both files to the operating system (after each batch of lines)."""
        self._raw.flush()
        self._times.flush()

    def close(self) -> None:
        """Flush and close both files (both are closed even if one fails)."""
        try:
            self._raw.close()
        finally:
            self._times.close()


__all__ = ["RAW_SUFFIX", "TIMES_SUFFIX", "RawLog", "raw_log_stem", "utc_text"]

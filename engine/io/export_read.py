"""Reading a replay's logs for ``uvnav export``: the ``.OUT`` log or the JSON lines of a run, and
the smoothed positions that ``uvnav replay --smooth`` writes (docs/EXPORT.md).

The ``.OUT`` log is read by :func:`engine.io.outlog.iter_out_log` (the one ``.OUT`` parser):
``BAD`` and ``ACT`` lines are counted, a log cut short (the last line without its newline, a
last block without ``END``) is reported as a problem naming file and line, and a damaged
complete line is an :class:`~engine.errors.InputError` naming file and line. JSON lines follow
the same rule: a cut-off last line is a problem, a damaged complete line an error.

Positions stay as the log has them: geodetic degrees on the cycle's working datum (``datum``),
TM grid metres on the cycle's central meridian (``cm_deg``), depth in metres (positive down),
the 95 % ellipse semi-axes in metres and the major-axis azimuth in degrees from **grid** north.
:mod:`engine.io.export_geo` turns them into WGS84.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from engine.errors import InputError
from engine.io.outlog import (
    OutCycle,
    PositionChecks,
    check_log_head,
    iter_json_objects,
    iter_out_log,
)

__all__ = [
    "MAX_SEMI_AXIS_M",
    "W_FLAG_BOUND",
    "ExportEpoch",
    "ExportLog",
    "SmoothedPoint",
    "TrackPoint",
    "align_smoothed",
    "logged_datum_file",
    "read_export_log",
    "read_smoothed",
]

W_FLAG_BOUND = 2.576
"""|w| above which an LOP counts as flagged: the thesis' fixed rejection bound
(``engine.lsq.statistics.REJECT_BOUND``, docs/DECISIONS.md "Least squares" Q16; a test keeps
them equal)."""


MAX_SEMI_AXIS_M = 1_000_000.0
"""Largest 95 % semi-axis drawn as a polygon (m): a day of dead reckoning at the demo's Pool
of Errors rate (1.8 km/h) is 43 km; beyond 1000 km an outline in a TM grid means nothing."""


@dataclass(frozen=True, slots=True)
class TrackPoint:
    """One position estimate as logged: geodetic degrees on the working datum, TM grid metres
    (``x_m`` east, ``y_m`` north) on the grid of ``cm_deg``, depth in metres (positive down,
    None if unknown) and the 95 % ellipse (semi-axes m, major-axis azimuth degrees from grid
    north; None without a precision)."""

    lat_deg: float
    lon_deg: float
    x_m: float | None
    y_m: float | None
    depth_m: float | None
    a95_m: float | None
    b95_m: float | None
    az_grid_deg: float | None

    @property
    def has_ellipse(self) -> bool:
        """True when semi-axes and azimuth are all finite, the semi-axes positive and at most
        :data:`MAX_SEMI_AXIS_M`."""
        a, b, az = self.a95_m, self.b95_m, self.az_grid_deg
        return (a is not None and b is not None and az is not None and math.isfinite(az)
                and 0.0 < a <= MAX_SEMI_AXIS_M and 0.0 < b <= MAX_SEMI_AXIS_M)


@dataclass(frozen=True, slots=True)
class ExportEpoch:
    """One cycle of the log: its number, time (UTC), ``.RUN`` line, working datum, CM, the MPP
    source and filter status, the estimates (``mpp``, ``lse``, ``gps`` = the GPS input converted
    to the working datum, ``.OUT`` only) and the fix's test figures (unit variance ``s2``,
    ``rms_m``, LOPs used, largest |w| of a used LOP, LOPs with |w| > :data:`W_FLAG_BOUND`, whether
    the fix failed its tests; None without a fix)."""

    n: int
    time: datetime
    record: int | None
    datum: str
    cm_deg: float | None
    source: str
    filter: str
    mpp: TrackPoint | None
    lse: TrackPoint | None
    gps: TrackPoint | None
    has_filter: bool
    s2: float | None = None
    rms_m: float | None = None
    lops_used: int = 0
    w_max: float | None = None
    lops_flagged: int = 0
    fix_failed: bool | None = None
    messages: int = 0


@dataclass(frozen=True)
class ExportLog:
    """A replay log read for export: ``kind`` ``"out"`` or ``"jsonl"``, the cycles in order
    (a cycle logged again after an operator's LOP rejection replaces the first one), the
    embedded configuration (``.OUT`` only), ``BAD`` records counted, and problems (file:line
    texts: a log cut short)."""

    path: str
    kind: str
    epochs: tuple[ExportEpoch, ...]
    config_text: str = ""
    bad_records: int = 0
    truncated: bool = False
    problems: tuple[str, ...] = field(default=())


@dataclass(frozen=True, slots=True)
class SmoothedPoint:
    """One line of a smoothed-positions file: the point (grid metres on the run's final CM) and
    its time when the line carries one (``time``; the files ``uvnav replay --smooth`` writes
    today do not)."""

    point: TrackPoint
    time: datetime | None
    line: int


def _num(v: Any) -> float | None:
    """A logged number as a finite float (None for ``-``/null, text, bool, NaN or inf)."""
    if isinstance(v, bool) or not isinstance(v, int | float):
        return None
    x = float(v)
    return x if math.isfinite(x) else None


def _time(text: Any, name: str, line: int | None, fieldname: str) -> datetime:
    """An ISO 8601 UTC time ``YYYY-MM-DDTHH:MM:SSZ`` (fractions allowed) as an aware datetime."""
    s = str(text)
    try:
        t = datetime.fromisoformat(s[:-1] + "+00:00" if s.endswith("Z") else s)
    except ValueError:
        raise InputError("Not an ISO 8601 time !", file=name, line=line, field=fieldname,
                         text=s[:80]) from None
    if t.tzinfo is None:
        t = t.replace(tzinfo=UTC)
    return t.astimezone(UTC)


def _point(d: Mapping[str, Any] | None, az_key: str) -> TrackPoint | None:
    """A :class:`TrackPoint` from a position's fields (``.OUT`` line or JSON object), None when
    it has no finite latitude and longitude."""
    if d is None:
        return None
    lat, lon = _num(d.get("lat")), _num(d.get("lon"))
    if lat is None or lon is None or not -90.0 <= lat <= 90.0 or not -540.0 <= lon <= 540.0:
        return None
    return TrackPoint(lat, lon, _num(d.get("x")), _num(d.get("y")), _num(d.get("depth")),
                      _num(d.get("a95")), _num(d.get("b95")), _num(d.get(az_key)))


def _lop_figures(lops: list[Mapping[str, Any]]) -> tuple[int, float | None, int]:
    """(LOPs used, largest |w| of a used LOP, used LOPs with |w| > W_FLAG_BOUND)."""
    used = [lop for lop in lops if lop.get("used") in (1, True)]
    ws = [abs(w) for w in (_num(lop.get("w")) for lop in used) if w is not None]
    return len(used), (max(ws) if ws else None), sum(w > W_FLAG_BOUND for w in ws)


def _out_epoch(c: OutCycle, name: str) -> ExportEpoch:
    f = c.fields
    where = f"CYCLE n={f.get('n')} t"
    lse_line = c.first("LSE")
    lse = _point(lse_line, "az") if lse_line is not None and lse_line.get("kind") == "lse" \
        else None
    gps_line = c.first("GPS")
    gps = _point(gps_line, "az") if gps_line is not None else None
    used, w_max, flagged = _lop_figures(c.all("LOP"))
    fix_failed = None
    if lse_line is not None:
        fix_failed = lse_line.get("tests") == "fail"
    n = f.get("n")
    record = f.get("record")
    return ExportEpoch(
        n=n if isinstance(n, int) else 0,
        time=_time(f.get("t"), name, c.line or None, where),
        record=record if isinstance(record, int) else None,
        datum=str(f.get("datum") or ""),
        cm_deg=_num(f.get("cm")),
        source=str(f.get("source") or ""),
        filter=str(f.get("filter") or ""),
        mpp=_point(c.first("MPP"), "az"),
        lse=lse,
        gps=gps,
        has_filter=c.first("KF") is not None,
        s2=_num(lse_line.get("s2")) if lse_line is not None else None,
        rms_m=_num(lse_line.get("rms")) if lse_line is not None else None,
        lops_used=used, w_max=w_max, lops_flagged=flagged, fix_failed=fix_failed,
        messages=len(c.all("MSG")),
    )


def _json_epoch(obj: Mapping[str, Any], name: str, ln: int) -> ExportEpoch:
    lops = obj.get("lops")
    lops = [x for x in lops if isinstance(x, dict)] if isinstance(lops, list) else []
    used, w_max, flagged = _lop_figures(lops)
    ft = obj.get("fix_tests")
    n, record, msgs = obj.get("n"), obj.get("record"), obj.get("messages")
    mpp, lse = obj.get("mpp"), obj.get("lse")
    return ExportEpoch(
        n=n if isinstance(n, int) and not isinstance(n, bool) else 0,
        time=_time(obj.get("time"), name, ln, "time"),
        record=record if isinstance(record, int) and not isinstance(record, bool) else None,
        datum=str(obj.get("datum") or ""),
        cm_deg=_num(obj.get("cm_deg")),
        source=str(obj.get("source") or ""),
        filter=str(obj.get("filter") or ""),
        mpp=_point(mpp if isinstance(mpp, dict) else None, "az_deg"),
        lse=_point(lse if isinstance(lse, dict) else None, "az_deg"),
        gps=None,
        has_filter=obj.get("state") is not None,
        s2=_num(obj.get("s2")),
        rms_m=_num(obj.get("rms")),
        lops_used=used, w_max=w_max, lops_flagged=flagged,
        fix_failed=bool(ft.get("failed")) if isinstance(ft, dict) else None,
        messages=len(msgs) if isinstance(msgs, list) else 0,
    )


def _check_file(path: str | os.PathLike[str], label: str) -> str:
    name = str(path)
    p = Path(path)
    if "\0" in name:
        raise InputError("A path cannot contain a NUL character !", field=label, text=name)
    if p.is_dir():
        raise InputError("Is a directory, not a file !", file=name, field=label)
    if not p.exists():
        raise InputError("File not found !", file=name, field=label)
    if not p.is_file():
        raise InputError("Not a regular file (a device or pipe) !", file=name, field=label)
    return name


def _add(epochs: list[ExportEpoch], e: ExportEpoch) -> None:
    """Append, or replace the last cycle when the log wrote the same cycle again (the
    console's LOP rejection redoes the last cycle: ``ACT`` then the same ``n``)."""
    if epochs and epochs[-1].n == e.n and e.n > 0:
        epochs[-1] = e
    else:
        epochs.append(e)


def read_export_log(path: str | os.PathLike[str]) -> ExportLog:
    """Read a ``.OUT`` log or a JSON-lines cycle log (told apart by the first non-blank byte:
    ``{`` = JSON lines). Raises :class:`InputError` (file, line) for a missing, unreadable,
    empty or damaged file, or one without any cycle; a log cut short is read up to its last
    complete cycle and reported in ``problems``."""
    name = _check_file(path, "log")
    try:
        with open(path, "rb") as fh:
            head = fh.read(4096).lstrip()
    except OSError as exc:
        raise InputError(f"Cannot read: {exc.strerror or exc} !", file=name) from None
    if not head:
        raise InputError("Empty log file !", file=name)
    epochs: list[ExportEpoch] = []
    problems: list[str] = []
    checks = PositionChecks(name)
    kind, config_text, bad, truncated = "jsonl", "", 0, False
    try:
        if head.startswith(b"{"):
            for ln, obj in iter_json_objects(path, "a cycle of a --jsonl log", problems):
                if "time" not in obj or "mpp" not in obj:
                    raise InputError("JSON line without 'time' and 'mpp': not a --jsonl cycle "
                                     "log !", file=name, line=ln, field="time")
                _add(epochs, _json_epoch(obj, name, ln))
        else:
            check_log_head(head, name)
            state, events = iter_out_log(path)
            for what, item in events:
                if what == "cycle" and isinstance(item, OutCycle):
                    _add(epochs, _out_epoch(item, name))
                    for tag in ("LSE", "MPP", "GPS"):
                        checks.check(tag, item.first(tag), item.line)
                elif what == "bad":
                    bad += 1
            problems.extend(state.problems)
            kind, config_text, truncated = "out", "\n".join(state.config) + "\n", state.truncated
    except OSError as exc:
        raise InputError(f"Cannot read: {exc.strerror or exc} !", file=name) from None
    if not epochs:
        raise InputError("No complete cycle in the log !", file=name)
    return ExportLog(name, kind, tuple(epochs), config_text, bad, truncated or bool(problems),
                     (*problems, *checks.notes()))


def read_smoothed(path: str | os.PathLike[str]) -> tuple[list[SmoothedPoint], list[str]]:
    """Read a smoothed-positions file (``uvnav replay --smooth``: one JSON object per line with
    ``lat``, ``lon``, ``x``, ``y``, ``depth``, ``a95``, ``b95``, ``az_deg``; an optional ``time``
    is used when present). Returns (points, problems); InputError for a damaged line."""
    name = _check_file(path, "--smoothed")
    problems: list[str] = []
    out: list[SmoothedPoint] = []
    try:
        for ln, obj in iter_json_objects(path, "a smoothed position", problems):
            p = _point(obj, "az_deg")
            if p is None or not {"x", "y"} <= obj.keys():
                raise InputError("Not a smoothed position (needs lat, lon, x, y) !", file=name,
                                 line=ln, field="lat")
            t = obj.get("time")
            out.append(SmoothedPoint(p, None if t is None else _time(t, name, ln, "time"), ln))
    except OSError as exc:
        raise InputError(f"Cannot read: {exc.strerror or exc} !", file=name) from None
    if not out:
        raise InputError("No smoothed position in the file !", file=name)
    return out, problems


def align_smoothed(epochs: tuple[ExportEpoch, ...], smoothed: list[SmoothedPoint],
                   name: str) -> list[TrackPoint | None]:
    """The smoothed point of each cycle (None where there is none).

    Lines with a ``time`` are matched by time. Lines without (what ``uvnav replay --smooth``
    writes) are the smoothed span oldest first, one per cycle that had a filter state, ending
    at the run's last cycle (engine.run.session.Session.iter_smoothed): they are matched to the
    last ``len(smoothed)`` cycles with a filter state. InputError when they cannot belong to
    this log.
    """
    out: list[TrackPoint | None] = [None] * len(epochs)
    if all(s.time is not None for s in smoothed):
        index = {e.time: i for i, e in enumerate(epochs)}
        missing = [s for s in smoothed if s.time not in index]
        if missing:
            raise InputError("Smoothed position at a time the log has no cycle for: not the "
                             "smoothed file of this run !", file=name, line=missing[0].line,
                             field="time", text=str(missing[0].time))
        for s in smoothed:
            out[index[s.time]] = s.point  # type: ignore[index]
        return out
    filtered = [i for i, e in enumerate(epochs) if e.has_filter]
    if len(smoothed) > len(filtered):
        raise InputError(f"{len(smoothed)} smoothed positions but only {len(filtered)} cycles "
                         "with a filter state in the log: not the smoothed file of this run "
                         "(or the log is cut short) !", file=name, field="--smoothed")
    for i, s in zip(filtered[len(filtered) - len(smoothed):], smoothed, strict=True):
        out[i] = s.point
    return out


def logged_datum_file(log: ExportLog) -> Path | None:
    """``TO_WGS84.DAT`` in the ``data_dir`` of the configuration a ``.OUT`` log embeds (absolute
    in every log ``uvnav replay`` writes; a relative one is taken from the log's directory), or
    None (JSON lines, no configuration, or no such file)."""
    if not log.config_text.strip():
        return None
    import tomllib

    try:
        cfg = tomllib.loads(log.config_text)
    except tomllib.TOMLDecodeError:
        return None
    data_dir = cfg.get("data_dir")
    if not isinstance(data_dir, str) or "\0" in data_dir:
        return None
    path = Path(log.path).parent / data_dir / "TO_WGS84.DAT"
    return path if path.is_file() else None

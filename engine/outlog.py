"""The ``.OUT`` log: a plain-text, human-readable and machine-parseable record of a run.

Layout (program.md §5.4, A1)::

    # UVNAV output log, format 1            header lines start with '#'
    # engine 0.1.0
    # config-begin                          the start-up configuration, verbatim TOML
    # datum = "ED50"
    # config-end
    ACT t=1992-09-17T08:35:40Z cycle=3 text="Setup > Systems > GPS on"      operator action
    BAD record=7 field=heading message="..." raw="..."                      rejected input record
    CYCLE n=1 t=1992-09-17T08:35:38Z record=2                               one block per cycle
      IN raw="920917 083538 ..."
      LSE lat=52.842 ...
    END n=1

Every line after the header is ``TAG key=value ...``; a value with blanks, quotes or ``=`` is
written as a JSON string.  Each cycle block is written with one ``write`` and flushed, so a killed
process leaves every completed cycle readable; the reader reports a trailing block without its
``END`` line as truncated instead of failing.  An existing log is never overwritten unless the
caller asks for it explicitly (``force=True``): otherwise a new name is chosen.
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from numbers import Integral
from pathlib import Path
from typing import Any

from engine.errors import InputError
from engine.outputs import OutputFile, OutputGuard, free_name

FORMAT_VERSION = 1
Value = str | int | float | bool | None


def format_value(value: Value) -> str:
    """Encode one value for a ``key=value`` pair (floats keep full precision, None is ``-``)."""
    fmt = _BY_TYPE.get(type(value))
    if fmt is not None:  # the exact built-in types: float, str, int, bool, None
        return fmt(value)
    if isinstance(value, float):  # subclasses, e.g. numpy.float64
        return float.__repr__(value)  # shortest round-trip text; "nan", "inf", "-inf"
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, Integral):
        return str(int(value))
    return _format_text(str(value))


_NEEDS_QUOTES = re.compile(r'[\s"=\\]').search
"""A blank (``str.isspace``), a quote, ``=`` or a backslash: the word must be JSON-quoted."""


@lru_cache(maxsize=1024)
def _format_text(text: str) -> str:
    """A string value: bare if it reads back as itself, else JSON-quoted (cached: the same
    short words (verdicts, systems, sources) recur in every cycle)."""
    if text in ("", "-") or _NEEDS_QUOTES(text) or _looks_numeric(text):
        return json.dumps(text, ensure_ascii=False)
    return text


def _format_none(_value: None) -> str:
    return "-"


def _format_bool(value: bool) -> str:
    return "1" if value else "0"


_BY_TYPE: dict[type, Callable[[Any], str]] = {
    float: repr,  # an exact float: its shortest round-trip text ("nan", "inf", "-inf" too)
    str: _format_text,
    int: int.__repr__,
    bool: _format_bool,
    type(None): _format_none,
}
"""Formatter per exact type (a dict look-up instead of an isinstance chain on the hot path)."""


def _looks_numeric(text: str) -> bool:
    """True if a bare word would be read back as a number (so it must be quoted)."""
    try:
        float(text)
    except ValueError:
        return False
    return True


def _append_fields(parts: list[str], fields: Mapping[str, Value]) -> None:
    """Append ``" k=v"`` for each field to ``parts`` (a float's text is its ``repr``)."""
    fv = format_value
    for k, v in fields.items():
        if type(v) is float:  # most values: skip the look-up
            parts.append(f" {k}={v!r}")
        else:
            parts.append(f" {k}={fv(v)}")


def format_fields(fields: Mapping[str, Value]) -> str:
    """The ``" k=v k=v"`` part of a log line (each pair with its leading blank)."""
    parts: list[str] = []
    _append_fields(parts, fields)
    return "".join(parts)


def format_line(tag: str, fields: Mapping[str, Value], indent: str = "") -> str:
    """One log line: ``TAG k=v k=v`` (no newline)."""
    return indent + tag + format_fields(fields)


def _split_tokens(text: str) -> list[str]:
    tokens: list[str] = []
    i, n = 0, len(text)
    while i < n:
        while i < n and text[i] == " ":
            i += 1
        if i >= n:
            break
        start = i
        in_quote = False
        while i < n and (in_quote or text[i] != " "):
            if text[i] == '"':
                in_quote = not in_quote
            elif text[i] == "\\" and in_quote:
                i += 1
            i += 1
        if in_quote:
            raise ValueError("unterminated quoted value")
        tokens.append(text[start:i])
    return tokens


def parse_value(text: str) -> Value:
    """Decode a value written by :func:`format_value` (numbers come back as int or float)."""
    if text == "-":
        return None
    if text.startswith('"'):
        return str(json.loads(text))
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        return text


def parse_line(line: str) -> tuple[str, dict[str, Value]]:
    """Split a log line into its tag and fields; raises ValueError on a malformed line."""
    tokens = _split_tokens(line.strip())
    if not tokens:
        raise ValueError("empty line")
    tag, fields = tokens[0], {}
    for tok in tokens[1:]:
        key, sep, raw = tok.partition("=")
        if not sep or not key:
            raise ValueError(f"token without key=value: {tok!r}")
        fields[key] = parse_value(raw)
    return tag, fields


@dataclass(frozen=True)
class OutCycle:
    """One cycle block read back: the CYCLE line's fields and the tagged lines inside it.

    ``lines`` keeps every inner line in order as (tag, fields); :meth:`first` and :meth:`all`
    look lines up by tag.
    """

    fields: dict[str, Value]
    lines: tuple[tuple[str, dict[str, Value]], ...]

    def first(self, tag: str) -> dict[str, Value] | None:
        """The fields of the first inner line with ``tag``, or None."""
        for t, f in self.lines:
            if t == tag:
                return f
        return None

    def all(self, tag: str) -> list[dict[str, Value]]:
        """The fields of every inner line with ``tag``, in order."""
        return [f for t, f in self.lines if t == tag]


@dataclass(frozen=True)
class OutLogContents:
    """A whole ``.OUT`` file read back."""

    header: tuple[str, ...]
    config_text: str
    cycles: tuple[OutCycle, ...]
    actions: tuple[dict[str, Value], ...]
    bad_records: tuple[dict[str, Value], ...]
    truncated: bool = False
    problems: tuple[str, ...] = field(default=())


def free_log_path(path: Path) -> Path:
    """``path`` if nothing is there, else the first free ``stem_N.suffix`` (N = 1, 2, …); any
    directory entry, a dangling symbolic link too, counts as taken
    (:func:`engine.outputs.free_name`)."""
    return free_name(path)


class OutLogWriter:
    """Append-only writer of a ``.OUT`` log.  Use :meth:`create`; close with :meth:`close`.

    Every block is flushed to the operating system when written (survives a killed process);
    ``fsync_every`` cycles it is also forced to the disk (survives a power cut), and at close.
    """

    def __init__(self, handle: OutputFile, path: Path, fsync_every: int = 600) -> None:
        self._fh = handle
        self.path = path
        self._fsync_every = max(1, fsync_every)
        self._since_sync = 0

    @classmethod
    def create(
        cls,
        path: str | os.PathLike[str],
        *,
        header: Sequence[str] = (),
        config_text: str = "",
        force: bool = False,
        fsync_every: int = 600,
        guard: OutputGuard | None = None,
        label: str = "--out",
    ) -> OutLogWriter:
        """Create a new log at ``path``; if it exists, pick ``NAME_1.OUT`` … unless ``force``.

        Opened by :meth:`engine.outputs.OutputGuard.open` (exclusive create, so two runs can
        never share one log; never an input of ``guard``; ``force`` replaces only an earlier
        ``.OUT`` log).
        """
        fh = (guard if guard is not None else OutputGuard()).open(
            path, label=label, kind="out", force=force)
        target = fh.path
        writer = cls(fh, target, fsync_every)
        lines = [f"# UVNAV output log, format {FORMAT_VERSION}"]
        lines.extend(f"# {h}" for h in header)
        lines.append("# config-begin")
        lines.extend(f"# {ln}" if ln else "#" for ln in config_text.splitlines())
        lines.append("# config-end")
        writer._write("\n".join(lines) + "\n", sync=True)
        return writer

    def _write(self, text: str, sync: bool = False) -> None:
        self._fh.write(text)
        self._fh.flush()
        self._since_sync += 1
        if sync or self._since_sync >= self._fsync_every:
            self._fh.fsync()
            self._since_sync = 0

    def write_cycle(
        self, fields: Mapping[str, Value], lines: Sequence[tuple[str, Mapping[str, Value]]]
    ) -> None:
        """Write one complete cycle block (``CYCLE`` … ``END``) in a single flushed write."""
        parts = ["CYCLE"]
        _append_fields(parts, fields)
        for tag, f in lines:
            parts.append("\n  " + tag)
            _append_fields(parts, f)
        parts.append("\nEND")
        _append_fields(parts, {"n": fields.get("n")})
        parts.append("\n")
        self._write("".join(parts))

    def write_action(self, fields: Mapping[str, Value]) -> None:
        """Write an operator action line (``ACT``)."""
        self._write(format_line("ACT", fields) + "\n")

    def write_bad_record(self, fields: Mapping[str, Value]) -> None:
        """Write a rejected input record line (``BAD``)."""
        self._write(format_line("BAD", fields) + "\n")

    def close(self) -> None:
        """Flush, force to disk and close (an error names the file)."""
        self._fh.close(sync=True)

    def __enter__(self) -> OutLogWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def iter_out_lines(path: str | os.PathLike[str]) -> Iterator[tuple[int, str]]:
    """Yield (line number, line without newline) of a log file."""
    with open(path, encoding="utf-8") as fh:
        for i, line in enumerate(fh, start=1):
            yield i, line.rstrip("\n")


def read_out_log(path: str | os.PathLike[str]) -> OutLogContents:
    """Read a ``.OUT`` log back.  A final block cut off by a crash sets ``truncated``; a line that
    cannot be parsed raises :class:`InputError` naming file and line (a log is machine-written,
    so anything else is corruption)."""
    name = str(path)
    header: list[str] = []
    config: list[str] = []
    cycles: list[OutCycle] = []
    actions: list[dict[str, Value]] = []
    bad: list[dict[str, Value]] = []
    in_config = False
    current: tuple[dict[str, Value], list[tuple[str, dict[str, Value]]]] | None = None
    problems: list[str] = []
    last_line = 0
    pending: tuple[int, str, str] | None = None
    for ln, text in iter_out_lines(path):
        last_line = ln
        if text.startswith("#"):
            body = text[2:] if text.startswith("# ") else text[1:]
            if body == "config-begin":
                in_config = True
            elif body == "config-end":
                in_config = False
            elif in_config:
                config.append(body)
            else:
                header.append(body)
            continue
        if not text.strip():
            continue
        if pending is not None:
            # An unreadable line followed by more lines is corruption, not a crash cut-off.
            p_ln, p_text, p_msg = pending
            raise InputError(p_msg, file=name, line=p_ln, field="line", text=p_text[:80])
        try:
            tag, fields = parse_line(text)
        except ValueError as exc:
            pending = (ln, text, str(exc))
            continue
        if tag == "CYCLE":
            if current is not None:
                problems.append(f"{name}:{ln}: cycle block without END before this line")
            current = (fields, [])
        elif tag == "END":
            if current is None:
                raise InputError("END without CYCLE", file=name, line=ln, field="END", text=text)
            cycles.append(OutCycle(current[0], tuple(current[1])))
            current = None
        elif current is not None:
            current[1].append((tag, fields))
        elif tag == "ACT":
            actions.append(fields)
        elif tag == "BAD":
            bad.append(fields)
        else:
            raise InputError("unknown line tag", file=name, line=ln, field="tag", text=tag)
    truncated = current is not None or pending is not None
    if truncated:
        problems.append(f"{name}:{last_line}: last cycle block is incomplete (run interrupted)")
    return OutLogContents(
        header=tuple(header),
        config_text="\n".join(config) + ("\n" if config else ""),
        cycles=tuple(cycles),
        actions=tuple(actions),
        bad_records=tuple(bad),
        truncated=truncated,
        problems=tuple(problems),
    )

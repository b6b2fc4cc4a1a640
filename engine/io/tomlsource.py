"""Reading TOML files (run configurations, scenarios) with errors located at their source line.

``tomllib`` reports syntax errors with a position but knows nothing about values that parse
and are then refused; :class:`SourceIndex` keeps, best effort, the line and the value text of
every ``table.key`` of the text (``leg[i].key`` for the i-th ``[[leg]]`` table), so that an
:class:`~engine.errors.InputError` raised with ``field="table.key"`` can be given its file and
line. :func:`parse_located` ties it together for a loader.
"""

from __future__ import annotations

import os
import re
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from engine.errors import InputError, read_error

T = TypeVar("T")

FILE_NOT_FOUND_MESSAGE = "File not found !"
NOT_UTF8_MESSAGE = "File is not UTF-8 text !"
TOO_DEEP_MESSAGE = "Arrays or inline tables nested too deep !"
TOO_LONG_NUMBER_MESSAGE = "Number too long (more than 4300 digits) !"
NUL_IN_PATH_MESSAGE = "A path cannot contain a NUL character !"
UNKNOWN_KEY_MESSAGE = "Unknown key !"
UNKNOWN_TABLE_MESSAGE = "Unknown table !"

_KEY_PART = r"""(?:[A-Za-z0-9_-]+|"[^"\n]*"|'[^'\n]*')"""
_KEY_LINE_RE = re.compile(rf"\s*({_KEY_PART}(?:\s*\.\s*{_KEY_PART})*)\s*=(.*)")
_HEADER_RE = re.compile(
    rf"\s*(\[\[?)\s*({_KEY_PART}(?:\s*\.\s*{_KEY_PART})*)\s*\]\]?\s*(?:#.*)?")
_TOML_POS_RE = re.compile(r"\s*\(at (?:line (\d+), column \d+|end of document)\)\s*$")


def dotted(raw: str) -> str:
    """A TOML key as written (``a . "b c"``) in dotted form (``a.b c``)."""
    parts = re.findall(_KEY_PART, raw)
    return ".".join(p[1:-1] if p[:1] in "\"'" else p for p in parts)


def strip_comment(value: str, *, unquote: bool = False) -> str:
    """The value text before an end-of-line ``#`` comment (quotes respected); with ``unquote``
    a quoted string loses its quotes."""
    quote = ""
    out = value
    i = 0
    while i < len(value):
        ch = value[i]
        if quote:
            if ch == "\\" and quote == '"':
                i += 1
            elif ch == quote:
                quote = ""
        elif ch in "\"'":
            quote = ch
        elif ch == "#":
            out = value[:i]
            break
        i += 1
    out = out.strip()
    if unquote and len(out) >= 2 and out[0] == out[-1] and out[0] in "\"'":
        out = out[1:-1]
    return out


class SourceIndex:
    """Line numbers (1-based) and value texts of every key of a TOML text (best effort).

    ``where["table.key"] = (line, value text)``; a table header maps to ``(line, None)``; the
    i-th (1-based) ``[[name]]`` table's keys are ``name[i].key``. ``unquote`` drops the quotes
    of string values in the recorded text.
    """

    def __init__(self, text: str, *, unquote: bool = False) -> None:
        self.lines = text.splitlines()
        self.where: dict[str, tuple[int, str | None]] = {}
        table = ""
        counts: dict[str, int] = {}
        in_string = ""
        for number, line in enumerate(self.lines, start=1):
            if in_string:
                if in_string in line:
                    in_string = ""
                continue
            header = _HEADER_RE.fullmatch(line)
            if header is not None:
                table = dotted(header.group(2))
                if header.group(1) == "[[":
                    counts[table] = counts.get(table, 0) + 1
                    self.where.setdefault(table, (number, None))
                    table = f"{table}[{counts[table]}]"
                self.where.setdefault(table, (number, None))
                continue
            match = _KEY_LINE_RE.match(line)
            if match is None or line.lstrip().startswith("#"):
                continue
            key = dotted(match.group(1))
            name = f"{table}.{key}" if table else key
            self.where.setdefault(name, (number, strip_comment(match.group(2), unquote=unquote)))
            for delimiter in ('"""', "'''"):
                if match.group(2).count(delimiter) % 2 == 1:
                    in_string = delimiter

    def locate(self, err: InputError, filename: str) -> InputError:
        """``err`` with the file, the line of its field (or of the nearest enclosing table) and
        the value text as written."""
        name = err.field or ""
        parts = name.split(".")
        for n in range(len(parts), 0, -1):
            found = self.where.get(".".join(parts[:n]))
            if found is not None:
                line, value_text = found
                exact = n == len(parts)
                keep = err.message in (UNKNOWN_KEY_MESSAGE, UNKNOWN_TABLE_MESSAGE)
                text = value_text if exact and value_text is not None and not keep else err.text
                return InputError(err.message, file=filename, line=line, field=err.field, text=text)
        return err.located(file=filename)

    def at_line(self, message: str, filename: str, line: int) -> InputError:
        """An InputError at ``line`` with the key of that line as the field, if one is known
        (the value text is not echoed: it is what is too long or too deep)."""
        names = [name for name, (at, val) in self.where.items() if at == line and val is not None]
        return InputError(message, file=filename, line=line, field=names[0] if names else None)

    def syntax_error(self, err: tomllib.TOMLDecodeError, filename: str) -> InputError:
        """An InputError for a TOML syntax error, at the line tomllib reports (with the key of
        that line as the field, if one is known)."""
        message = str(err)
        match = _TOML_POS_RE.search(message)
        line = max(len(self.lines), 1)
        if match is not None:
            message = message[: match.start()]
            if match.group(1) is not None:
                line = int(match.group(1))
        text = self.lines[line - 1] if 0 < line <= len(self.lines) else ""
        names = [name for name, (at, val) in self.where.items() if at == line and val is not None]
        return InputError(f"TOML syntax error: {message} !", file=filename, line=line,
                          field=names[0] if names else None, text=text)


def parse_located(text: str, filename: str, build: Callable[[dict[str, Any]], T], *,
                  unquote: bool = False) -> T:
    """``build(tomllib.loads(text))`` with every InputError located in ``text`` as
    ``filename:line: field``."""
    index = SourceIndex(text, unquote=unquote)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise index.syntax_error(err, filename) from None
    except RecursionError:  # tomllib recurses once per level of [ or {
        raise index.at_line(TOO_DEEP_MESSAGE, filename, _deepest_line(text)) from None
    except ValueError:  # an integer of more than 4300 digits (sys.get_int_max_str_digits)
        raise index.at_line(TOO_LONG_NUMBER_MESSAGE, filename, _long_number_line(text)) from None
    try:
        return build(data)
    except InputError as err:
        raise index.locate(err, filename) from None
    except RecursionError:
        raise index.at_line(TOO_DEEP_MESSAGE, filename, _deepest_line(text)) from None


def _deepest_line(text: str) -> int:
    """The first line (1-based) reaching the deepest ``[``/``{`` nesting of ``text`` (best
    effort: quoted strings and comments skipped, table headers count as one level)."""
    depth = best = 0
    best_line = line = 1
    quote = ""
    comment = False
    for ch in text:
        if ch == "\n":
            line += 1
            comment = False
            continue
        if comment:
            continue
        if quote:
            if ch == quote:
                quote = ""
        elif ch in "\"'":
            quote = ch
        elif ch == "#":
            comment = True
        elif ch in "[{":
            depth += 1
            if depth > best:
                best, best_line = depth, line
        elif ch in "]}":
            depth = max(0, depth - 1)
    return best_line


def _long_number_line(text: str) -> int:
    """The line of the first run of more than 4300 digits (1 if none is found)."""
    match = re.search(r"[0-9_]{4301,}", text)
    return 1 if match is None else text.count("\n", 0, match.start()) + 1


def read_text(path: str | os.PathLike[str]) -> str:
    """A UTF-8 text file (InputError ``File not found !``, ``Is a directory, not a file !``,
    ``Cannot read: …`` (:func:`~engine.errors.read_error`) or ``File is not UTF-8 text !``
    with the line of the first bad byte). A byte-order mark at its start (what Windows editors
    write) is dropped: TOML allows none, and a configuration saved by Notepad was refused."""
    file = Path(path)
    if "\0" in str(file):
        raise InputError(NUL_IN_PATH_MESSAGE, file=str(file))
    try:
        raw = file.read_bytes()
    except OSError as exc:
        raise read_error(exc, str(file), FILE_NOT_FOUND_MESSAGE) from None
    try:
        return raw.decode("utf-8").removeprefix("\ufeff")
    except UnicodeDecodeError as err:
        line = raw[: err.start].count(b"\n") + 1
        raise InputError(NOT_UTF8_MESSAGE, file=str(file), line=line) from None

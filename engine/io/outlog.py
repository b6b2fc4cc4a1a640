"""The ``.OUT`` log: a plain-text, human-readable and machine-parseable record of a run.

Layout (THEORY §13.4, D35)::

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

Writing is the per-cycle hot path: a block handed over as :class:`KeyedLines` rows is rendered
by one cached ``%`` template per block shape (:func:`render_rows`), its floats written by one
compiled call where orjson is installed (:func:`float_texts`, checked against ``repr``), the
rest by ``repr``; :func:`format_line` / :func:`format_fields` stay the general API and the
reference the template is tested against (tests/io/test_outlog_fast.py). A run may write its
blocks by the compiled writer of ``engine.fast.outlog`` instead, which writes the same text.
"""

from __future__ import annotations

import json
import math
import os
import re
from array import array
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from itertools import chain, starmap
from numbers import Integral
from operator import itemgetter
from pathlib import Path
from typing import Any, overload

from engine.errors import InputError
from engine.io.outputs import OutputFile, OutputGuard, free_name

FORMAT_VERSION = 1
Value = str | int | float | bool | None


def format_value(value: Value) -> str:
    """Encode one value for a ``key=value`` pair (floats keep full precision, None is ``-``)."""
    fmt = _BY_TYPE.get(type(value))
    if fmt is not None:  # the exact built-in types: float, str, int, bool, None
        return fmt(value)
    if isinstance(value, float):  # subclasses, e.g. numpy.float64
        return float.__repr__(value)  # shortest round-trip text; "nan", "inf", "-inf"
    if isinstance(value, Integral):  # None and bool (not subclassable) are in _BY_TYPE
        return str(int(value))
    return _format_text(str(value))


_NEEDS_QUOTES = re.compile(r'[\s"=\\]').search
"""A blank (``str.isspace``), a quote, ``=`` or a backslash: the word must be JSON-quoted."""


@lru_cache(maxsize=1024)
def _format_text(text: str) -> str:
    """A string value: bare if it reads back as itself, else JSON-quoted (cached: the same
    short words (verdicts, systems, sources) recur in every cycle)."""
    if text in ("", "-") or _NEEDS_QUOTES(text) or _looks_numeric(text):
        return _json_string(text)
    return text


_json_string: Callable[[str], str] = json.encoder.encode_basestring  # type: ignore[attr-defined]
"""``json.dumps(text, ensure_ascii=False)`` for a str: the very function ``JSONEncoder.encode``
calls for one (the C encoder), without building an encoder per call."""


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


_NEVER_IN_A_NUMBER = re.compile(
    r"[:,;/()<>|!?@#$%&*'^~`\[\]{}bcdghj-mo-su-xzBCDGHJ-MO-SU-XZ]").search
"""ASCII characters that ``float()`` rejects wherever they stand: it takes only blanks, a sign,
digits (any script), ``_``, ``.``, an exponent ``e``/``E`` and the words inf, infinity, nan (any
case: the letters a e f i n t y). A word with one of these cannot be a number (a time stamp's
``:``, a list's ``,``), which spares the exception of a failed ``float()``."""


def _looks_numeric(text: str) -> bool:
    """True if a bare word would be read back as a number (so it must be quoted)."""
    if _NEVER_IN_A_NUMBER(text):
        return False
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


_NoneType = type(None)
_Template = tuple[str, tuple[tuple[int, Callable[[Any], str]], ...]]
_TEMPLATES: dict[tuple[str, tuple[str, ...], tuple[type, ...]], _Template] = {}
_TEMPLATES_MAX = 4096
"""Compiled line templates (bounded: a run has a few dozen line shapes; a caller with ever new
keys only costs a recompile after the cache is cleared)."""


def _compile_line(prefix: str, keys: tuple[str, ...], types: tuple[type, ...],
                  batched: bool = False) -> _Template:
    """A ``%`` template giving exactly ``prefix + format_fields(dict(zip(keys, values)))`` for
    values of exactly these ``types``, and the (index, converter) of the values to convert first.

    A float or int slot is ``%r`` (``repr``, as :func:`format_value`), a bool ``%d`` (``1``/``0``),
    None ``%.0s-`` (nothing of ``str(None)``, then ``-``); a str goes through
    :func:`_format_text` and anything else (numpy scalars, ...) through :func:`format_value`
    into a ``%s`` slot. Keys are put in with the same ``f"{k}"`` as :func:`_append_fields`.
    ``batched``: an exact float's slot is ``%s`` too, for its text from :func:`float_texts`.
    """
    parts = [prefix.replace("%", "%%")]
    conv: list[tuple[int, Callable[[Any], str]]] = []
    for i, (k, t) in enumerate(zip(keys, types, strict=True)):
        head = f" {k}=".replace("%", "%%")
        if t is float and batched:
            parts.append(head + "%s")
        elif t is float or t is int:
            parts.append(head + "%r")
        elif t is bool:
            parts.append(head + "%d")
        elif t is _NoneType:
            parts.append(head + "%.0s-")
        else:
            parts.append(head + "%s")
            conv.append((i, _format_text if t is str else format_value))
    return "".join(parts), tuple(conv)


def render_line(prefix: str, keys: tuple[str, ...], values: tuple[Value, ...]) -> str:
    """``prefix + format_fields(dict(zip(keys, values)))`` from a cached template (the ``.OUT``
    hot path: one ``%`` per line, each float's ``repr`` done in C). ``keys`` must be exact
    ``str`` (as every caller's are); the result is the same text as :func:`format_line`."""
    types = tuple(map(type, values))
    key = (prefix, keys, types)
    tpl = _TEMPLATES.get(key)
    if tpl is None:
        if len(_TEMPLATES) >= _TEMPLATES_MAX:
            _TEMPLATES.clear()
        tpl = _TEMPLATES[key] = _compile_line(prefix, keys, types)
    fmt, conv = tpl
    if conv:
        vals = list(values)
        for i, fn in conv:
            vals[i] = fn(vals[i])
        return fmt % tuple(vals)
    return fmt % values


def _render_fields(prefix: str, fields: Mapping[str, Value]) -> str:
    """``prefix + format_fields(fields)``: a plain dict with str keys by :func:`render_line`,
    any other mapping by the general :func:`_append_fields`."""
    if type(fields) is dict:
        keys = tuple(fields)
        if all(type(k) is str for k in keys):
            return render_line(prefix, keys, tuple(fields.values()))
    parts = [prefix]
    _append_fields(parts, fields)
    return "".join(parts)


def _probe_float_writer() -> Callable[[list[float]], bytes] | None:
    """``orjson.dumps`` (compiled shortest round-trip float text, ~20× faster than ``repr`` per
    float) if it is installed and writes every probe that it writes in plain positional form
    exactly as ``repr`` does (the nearest of the shortest digits, ties to even: the ``.125``
    ties; ``1.0``, ``-0.0``), and the values that ``repr`` writes with an exponent (≥ 1e16,
    < 1e-4) in a form :func:`float_texts` sends back to ``repr``; else None (``repr`` only)."""
    try:
        import orjson
    except ImportError:
        return None
    return _checked_float_writer(orjson.dumps)


def _checked_float_writer(
    dumps: Callable[[list[float]], bytes],
) -> Callable[[list[float]], bytes] | None:
    """``dumps`` if it passes the probes of :func:`_probe_float_writer`, else None."""
    probes = [0.0, -0.0, 1.0, -1.0, 2.5, 100.0, 0.1, 0.2, 0.3, 1 / 3, 2 / 3, 0.0001, 0.00012345,
              0.00099999999999999, 52.84232512345678, 4.531599494383838, -31615.4,
              5857300.165, -101065508335255.125, 101065508335255.375, 123456789.123, 1e15,
              9999999999999998.0, 1e16, 1.5e16, 1e17, 1e22, 1e300, 1.7976931348623157e308,
              9.999999999999999e-05, 1e-5, 1.5e-5, 1e-7, 5e-324, 2.2250738585072014e-308]
    try:
        texts = dumps(probes)[1:-1].decode("ascii").split(",")
    except Exception:  # noqa: BLE001 - any surprise: keep to repr
        return None
    for v, t in zip(probes, texts, strict=True):
        if _plain_float_text(t) and (t != repr(v) or "e" in repr(v)):
            return None
    return dumps


_JSON_NUMBER_BYTES = b"0123456789.,-[]"
"""What a JSON array of floats in positional form consists of (no exponent letter or sign)."""


def _plain_float_text(text: str) -> bool:
    """A float's text in the positional form that ``repr`` uses too, by the test that
    :func:`float_texts` makes of a whole array: only digits, a minus sign and one point (no
    exponent, null, nan, inf) and no ``0.0000`` (< 1e-4 in positional form)."""
    return (not text.encode().translate(None, _JSON_NUMBER_BYTES) and "0.0000" not in text
            and text.count(".") == 1)


@lru_cache(maxsize=1)
def _float_writer() -> Callable[[list[float]], bytes] | None:
    """The batched float writer (None: every float through ``repr``), probed once at its first
    use (:func:`_probe_float_writer`; importing this module does not import orjson)."""
    return _probe_float_writer()


def float_texts(values: list[float], compiled: bool = True) -> list[str]:
    """``[repr(v) for v in values]`` for exact floats, in one compiled call where possible.

    The compiled writer's text is kept only in the positional form (:func:`_plain_float_text`)
    that it was checked to share with ``repr``; any other value (exponent, < 1e-4, ≥ 1e16, nan,
    inf) is written by ``repr`` itself. ``compiled=False``: ``repr`` only (the reference).
    The writer writes JSON (numbers ``-?d+(.d+)?([eE][+-]?d+)?`` and ``null``), so the fast
    check of the whole array is: no ``e``/``E`` (no exponent: ≥ 1e16 has one, as the probe of
    :func:`_probe_float_writer` at 1e16 made sure), no ``n`` (null: nan, inf), no ``0.0000``
    (< 1e-4 in positional form) and one point per number.
    Else the texts with a ``null``, an exponent or a ``0.0000`` are checked one by one (found
    by their markers: any other text is digits, a minus sign and at most one point), and if the
    rest do not have one point each, every text is.
    """
    dumps = _float_writer() if compiled else None
    if not values:
        return []
    if dumps is None:
        return list(map(repr, values))
    text = dumps(values).decode("ascii")[1:-1]
    texts = text.split(",")
    n = len(values)
    if ("e" not in text and "n" not in text and "E" not in text and "0.0000" not in text
            and text.count(".") == n):
        return texts  # the common case: every number positional, none < 1e-4
    suspect = set()  # nan/inf (null), an exponent (e), < 1e-4 in positional form (0.0000)
    for marker in ("null", "e", "E", "0.0000"):
        at = text.find(marker)
        while at >= 0:
            suspect.add(text.count(",", 0, at))
            at = text.find(marker, at + 1)
    dots = text.count(".")
    for i in suspect:
        t = texts[i]
        dots -= t.count(".")
        texts[i] = t if _plain_float_text(t) else repr(values[i])
    if dots != n - len(suspect):  # a number without its point (JSON has ≤ 1): each on its own
        return [t if _plain_float_text(t) else repr(v) for t, v in zip(texts, values,
                                                                        strict=True)]
    return texts


def _getter(indices: list[int]) -> Callable[[Sequence[Any]], tuple[Any, ...]]:
    """``lambda seq: tuple(seq[i] for i in indices)`` as a C-level ``itemgetter`` (which gives
    a bare item, not a 1-tuple, for one index)."""
    if len(indices) >= 2:
        return itemgetter(*indices)
    if len(indices) == 1:
        i = indices[0]
        return lambda seq: (seq[i],)
    return lambda seq: ()


_Getter = Callable[[Sequence[Any]], tuple[Any, ...]]
_N = ("n",)
_BlockTemplate = tuple[str, _Getter, _Getter, _Getter, _Getter, _Getter]
_BLOCK_TEMPLATES: dict[tuple[tuple[tuple[str, tuple[str, ...]], ...], tuple[type, ...]],
                       _BlockTemplate] = {}
_BLOCK_TEMPLATES_MAX = 512
"""Whole-block templates by (line shapes, value types): a run has a few dozen (LOP count,
TEST lines, messages, which values are None)."""


def _compile_block(shape: tuple[tuple[str, tuple[str, ...]], ...],
                   types: tuple[type, ...]) -> _BlockTemplate:
    """The ``%`` template of a whole block of lines (:func:`_compile_line` per line, exact-float
    slots as ``%s``), and getters that pick from the flat values: the exact floats, the str
    values, the other-typed values (through :func:`format_value`), the int/bool/None values
    (formatted by the template), and the permutation that puts [float texts, str texts, other
    texts, int/bool/None values] back in line order."""
    fmts = []
    groups: tuple[list[int], list[int], list[int], list[int]] = ([], [], [], [])
    at = 0
    for prefix, keys in shape:
        line_types = types[at:at + len(keys)]
        fmt, _conv = _compile_line(prefix, keys, line_types, batched=True)
        fmts.append(fmt)
        for i, t in enumerate(line_types, start=at):
            if t is float:
                groups[0].append(i)
            elif t is str:
                groups[1].append(i)
            elif t is int or t is bool or t is _NoneType:
                groups[3].append(i)
            else:
                groups[2].append(i)
        at += len(keys)
    where = {}
    for pos, i in enumerate(i for g in groups for i in g):
        where[i] = pos
    perm = _getter([where[i] for i in range(at)])
    return ("".join(fmts), _getter(groups[0]), _getter(groups[1]), _getter(groups[2]),
            _getter(groups[3]), perm)


_ROW_SHAPE = itemgetter(0, 1)
_ROW_VALUES = itemgetter(2)


_Row = tuple[str, tuple[str, ...], tuple[Value, ...]]


def render_rows(rows: Sequence[_Row], compiled: bool = True) -> str:
    """``"".join(render_line(*row) for row in rows)`` by one ``%`` with a cached whole-block
    template, all exact floats written by one :func:`float_texts` call and all str values by
    one ``map`` (the ``.OUT`` hot path: one cycle, ~17 lines, ~160 values, no per-value
    Python code). ``compiled=False``: the floats through ``repr`` only."""
    flat = list(chain.from_iterable(map(_ROW_VALUES, rows)))
    key = (tuple(map(_ROW_SHAPE, rows)), tuple(map(type, flat)))
    tpl = _BLOCK_TEMPLATES.get(key)
    if tpl is None:
        if len(_BLOCK_TEMPLATES) >= _BLOCK_TEMPLATES_MAX:
            _BLOCK_TEMPLATES.clear()
        tpl = _BLOCK_TEMPLATES[key] = _compile_block(*key)
    fmt, floats, strs, others, plain, perm = tpl
    texts = float_texts(list(floats(flat)), compiled)
    texts.extend(map(_format_text, strs(flat)))
    texts.extend(map(format_value, others(flat)))
    texts.extend(plain(flat))
    return fmt % perm(texts)


class KeyedLines(Sequence[tuple[str, dict[str, Value]]]):
    """The inner lines of a cycle block as rows (``"\\n  " + tag``, keys, values), the keys a
    tuple of exact ``str``: what :meth:`OutLogWriter.write_cycle` renders without building a
    dict per line. Read as a sequence it gives the same (tag, fields dict) pairs as a plain
    list of lines (the dicts are built on demand)."""

    __slots__ = ("rows",)

    def __init__(self) -> None:
        self.rows: list[tuple[str, tuple[str, ...], tuple[Value, ...]]] = []

    def __len__(self) -> int:
        return len(self.rows)

    @overload
    def __getitem__(self, index: int) -> tuple[str, dict[str, Value]]: ...
    @overload
    def __getitem__(self, index: slice) -> list[tuple[str, dict[str, Value]]]: ...

    def __getitem__(
        self, index: int | slice,
    ) -> tuple[str, dict[str, Value]] | list[tuple[str, dict[str, Value]]]:
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(len(self)))]
        prefix, keys, values = self.rows[index]
        return prefix[3:], dict(zip(keys, values, strict=True))

    def __iter__(self) -> Iterator[tuple[str, dict[str, Value]]]:
        for prefix, keys, values in self.rows:
            yield prefix[3:], dict(zip(keys, values, strict=True))

    def __repr__(self) -> str:
        return f"KeyedLines({list(self)!r})"


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
    line: int = field(default=0, compare=False)
    """The CYCLE line's number in the file (1-based), for messages about its fields; 0 where
    unknown."""

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
    cycles: Sequence[OutCycle]
    actions: tuple[dict[str, Value], ...]
    bad_records: tuple[dict[str, Value], ...]
    truncated: bool = False
    problems: tuple[str, ...] = field(default=())


def free_log_path(path: Path) -> Path:
    """``path`` if nothing is there, else the first free ``stem_N.suffix`` (N = 1, 2, …); any
    directory entry, a dangling symbolic link too, counts as taken
    (:func:`engine.io.outputs.free_name`)."""
    return free_name(path)


def block_rows(fields: Mapping[str, Value], lines: KeyedLines) -> list[_Row]:
    """The rows of a whole cycle block (``CYCLE`` … ``END n=…`` and its newline) for
    :func:`render_rows`: the CYCLE line of ``fields``, the inner ``lines``, the END line."""
    return [("CYCLE", tuple(fields), tuple(fields.values())), *lines.rows,
            ("\nEND", _N, (fields.get("n"),)), ("\n", (), ())]


def block_text(fields: Mapping[str, Value],
               lines: Sequence[tuple[str, Mapping[str, Value]]]) -> str:
    """The text of one cycle block: ``CYCLE`` and its fields, each inner (tag, fields) line
    indented by two blanks, ``END n=…``, each line ending in a newline."""
    if (type(lines) is KeyedLines and type(fields) is dict
            and all(type(k) is str for k in fields)):
        return render_rows(block_rows(fields, lines))
    parts = [_render_fields("CYCLE", fields)]
    if type(lines) is KeyedLines:
        parts.extend(starmap(render_line, lines.rows))
    else:
        render = _render_fields
        for tag, f in lines:
            parts.append(render("\n  " + tag, f))
    parts.append(f"\nEND n={format_value(fields.get('n'))}\n")
    return "".join(parts)


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
        self._fd: int | None = handle.utf8_fd
        """The log's descriptor for :meth:`write_direct` (None: the handle encodes otherwise)."""
        self._direct: int | None = self._fd
        """:attr:`_fd` while nothing is left in the text buffer (None during a write through
        it, after one that failed and after :meth:`close`): where :meth:`write_direct` may
        write."""

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

        Opened by :meth:`engine.io.outputs.OutputGuard.open` (exclusive create, so two runs can
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
        """Write and flush ``text``; every ``fsync_every`` writes (or with ``sync``) force the
        file to the disk."""
        self._direct = None
        self._fh.write_flushed(text)
        self._direct = self._fd
        self._since_sync += 1
        if sync or self._since_sync >= self._fsync_every:
            self._fh.fsync()
            self._since_sync = 0

    def write_block(self, text: str) -> None:
        """Write one complete cycle block's text (``CYCLE`` … ``END n=…`` and its newline, as
        :meth:`write_cycle` renders it: :func:`block_text`) in a single
        flushed write (:meth:`_write`, written out: once per cycle)."""
        self._direct = None
        self._fh.write_flushed(text)
        self._direct = self._fd
        self._since_sync += 1
        if self._since_sync >= self._fsync_every:
            self._fh.fsync()
            self._since_sync = 0

    def write_direct(self, write: Callable[[Any, int], int | None], item: object) -> bool:
        """Write one complete cycle block by ``write(item, fd)``, a compiled writer
        (``engine.fast.outlog``) that builds the block of ``item`` and writes
        its UTF-8 bytes to the log's descriptor itself (write(2) until all are written): the
        bytes :meth:`write_block` hands to the operating system for the same text, past the
        text layers, nothing being buffered before them. Counted for ``fsync_every`` as
        :meth:`write_block`. False, with nothing written, where ``write`` declines (returns
        None) or the log has no such descriptor (then write the block by :meth:`write_block`
        or :meth:`write_cycle`); an OSError names the file."""
        fd = self._direct
        if fd is None:
            return False
        try:
            done = write(item, fd)
        except OSError as exc:
            raise self._fh.os_error(exc) from exc
        if done is None:
            return False
        self._since_sync += 1
        if self._since_sync >= self._fsync_every:
            self._fh.fsync()
            self._since_sync = 0
        return True

    def write_cycle(
        self, fields: Mapping[str, Value], lines: Sequence[tuple[str, Mapping[str, Value]]]
    ) -> None:
        """Write one complete cycle block (``CYCLE`` … ``END``) in a single flushed write."""
        self._write(block_text(fields, lines))

    def write_action(self, fields: Mapping[str, Value]) -> None:
        """Write an operator action line (``ACT``)."""
        self._write(format_line("ACT", fields) + "\n")

    def write_bad_record(self, fields: Mapping[str, Value]) -> None:
        """Write a rejected input record line (``BAD``)."""
        self._write(format_line("BAD", fields) + "\n")

    def close(self) -> None:
        """Flush, force to disk and close (an error names the file)."""
        self._direct = self._fd = None
        self._fh.close(sync=True)

    def __enter__(self) -> OutLogWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _raw_lines(path: str | os.PathLike[str], name: str,
               start: int = 0) -> Iterator[tuple[int, int, str | None, bool]]:
    """Yield (byte offset, line number, text without newline, complete) of a log file.

    Read in binary, one line at a time (memory bounded by the longest line). ``complete`` is
    False only for a last line without its newline: every write ends in one, so such a line is
    a write cut short, and its text is None when the cut split a UTF-8 character. A complete
    line that is not UTF-8 is corruption (InputError naming file and line). ``start``: byte
    offset to begin at (line numbers then count from 1 there).
    """
    with open(path, "rb") as fh:
        fh.seek(start)
        offset = start
        for i, raw in enumerate(fh, start=1):
            complete = raw.endswith(b"\n")
            try:
                text: str | None = raw.decode("utf-8")
            except UnicodeDecodeError:
                if complete:
                    raise InputError("Not UTF-8 text !", file=name, line=i, field="line",
                                     text=raw[:80].decode("utf-8", "replace")) from None
                text = None
            if text is not None and complete:
                text = text[:-1]
            yield offset, i, text, complete
            offset += len(raw)


def iter_out_lines(path: str | os.PathLike[str]) -> Iterator[tuple[int, str]]:
    """Yield (line number, line without newline) of a log file (a cut UTF-8 character at the
    very end is replaced by U+FFFD; a bad one elsewhere raises InputError)."""
    for _off, i, text, _complete in _raw_lines(path, str(path)):
        yield i, "\ufffd" if text is None else text


class OutCycles(Sequence[OutCycle]):
    """The cycles of a ``.OUT`` log, read from the file on demand (nothing is kept in memory
    but one byte offset and one line number per cycle, 16 bytes): iterate, index or take
    ``len``. The file was checked whole by :func:`read_out_log`; only the cycles found then are
    served."""

    def __init__(self, path: str, offsets: array[int],
                 line_numbers: array[int] | None = None) -> None:
        self._path = path
        self._offsets = offsets
        self._lines = line_numbers
        """The CYCLE line's number of each cycle (8 more bytes per cycle), or None."""

    def __len__(self) -> int:
        return len(self._offsets)

    @overload
    def __getitem__(self, index: int) -> OutCycle: ...
    @overload
    def __getitem__(self, index: slice) -> list[OutCycle]: ...

    def __getitem__(self, index: int | slice) -> OutCycle | list[OutCycle]:
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(len(self)))]
        n = len(self._offsets)
        if index < 0:
            index += n
        if not 0 <= index < n:
            raise IndexError("cycle index out of range")
        return next(self._read(index, index + 1))

    def __iter__(self) -> Iterator[OutCycle]:
        return self._read(0, len(self._offsets))

    def _read(self, first: int, stop: int) -> Iterator[OutCycle]:
        if first >= stop:
            return
        left = stop - first
        index = first
        current: tuple[dict[str, Value], list[tuple[str, dict[str, Value]]]] | None = None
        for _off, _i, text, _complete in _raw_lines(self._path, self._path,
                                                     self._offsets[first]):
            if text is None or not text.strip() or text.startswith("#"):
                continue
            tag, fields = parse_line(text)
            if tag == "CYCLE":
                current = (fields, [])
            elif tag == "END" and current is not None:
                line = self._lines[index] if self._lines is not None else 0
                yield OutCycle(current[0], tuple(current[1]), line)
                current = None
                index += 1
                left -= 1
                if left == 0:
                    return
            elif current is not None:
                current[1].append((tag, fields))


def iter_json_objects(path: str | os.PathLike[str], what: str,
                      problems: list[str]) -> Iterator[tuple[int, dict[str, Any]]]:
    """(line number, object) of a JSON-lines file (``--jsonl``, ``--smooth``: read by
    ``uvnav assess`` and ``uvnav export``). A last line without its newline that does not
    parse is a write cut short: a note in ``problems``, not an error; any other bad line (not
    JSON, not UTF-8, not an object: ``what`` says what it should be) is an InputError naming
    file and line."""
    name = str(path)
    with open(path, "rb") as fh:
        for ln, raw in enumerate(fh, start=1):
            if not raw.strip():
                continue
            complete = raw.endswith(b"\n")
            try:
                obj = json.loads(raw)
            except ValueError as exc:  # JSONDecodeError and UnicodeDecodeError
                if not complete:
                    problems.append(f"{name}:{ln}: last line is incomplete (run interrupted)")
                    return
                raise InputError(f"Not a JSON object ({exc}) !", file=name, line=ln,
                                 field="line", text=raw[:80].decode("utf-8", "replace")) from None
            if not isinstance(obj, dict):
                raise InputError(f"Not a JSON object: not {what} !", file=name, line=ln,
                                 field="line", text=raw[:80].decode("utf-8", "replace"))
            yield ln, obj


def check_log_head(head: bytes, name: str) -> None:
    """InputError unless ``head`` (a log's first bytes, leading blanks removed) starts a
    ``.OUT`` log (``# UVNAV output log``) or a JSON-lines log (``{``): a file that is neither
    is named as such, not by the first parse error deep inside it."""
    if not (head.startswith(b"{") or head.startswith(b"# UVNAV output log")):
        raise InputError("Not a UVNAV .OUT log or JSON-lines log (the first line is neither "
                         "'# UVNAV output log' nor a JSON object) !", file=name, line=1,
                         field="log", text=head[:40].decode("utf-8", "replace"))


class PositionChecks:
    """Logged positions whose ``lat`` or ``lon`` is no number this program writes (infinite,
    or text; NaN is the engine's "no value"), per line tag: the reader leaves such a position
    out of its track, and :meth:`notes` says where (the first one's line) and how often."""

    def __init__(self, name: str) -> None:
        self.name = name
        self._first: dict[str, tuple[int, Value]] = {}
        self._count: dict[str, int] = {}

    def check(self, tag: str, fields: Mapping[str, Value] | None, line: int) -> None:
        """Look at the position ``fields`` of a ``tag`` line (the cycle's line ``line``)."""
        if fields is None:
            return
        for key in ("lat", "lon"):
            v = fields.get(key)
            if isinstance(v, str) or (isinstance(v, float) and math.isinf(v)):
                self._count[tag] = self._count.get(tag, 0) + 1
                self._first.setdefault(tag, (line, v))
                return

    def notes(self) -> list[str]:
        """``NAME:LINE: the cycle's MPP lat/lon is not a number (got inf): …`` per tag (LINE:
        the cycle's CYCLE line)."""
        out = []
        for tag, (line, v) in self._first.items():
            more = self._count[tag] - 1
            out.append(f"{self.name}:{line}: the cycle's {tag} lat/lon is not a number (got "
                       f"{v!r}): that position is left out"
                       + (f", and {more} more such" if more else ""))
        return out


@dataclass
class _ScanState:
    """What a scan of a log has found besides the cycles (filled while iterating)."""

    header: list[str] = field(default_factory=list)
    config: list[str] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)
    truncated: bool = False
    in_config: bool = False

    def comment(self, text: str) -> None:
        """A ``#`` line: the configuration between ``config-begin`` and ``config-end``, the
        header otherwise (the ``#`` and one blank after it removed)."""
        body = text[2:] if text.startswith("# ") else text[1:]
        if body == "config-begin":
            self.in_config = True
        elif body == "config-end":
            self.in_config = False
        elif self.in_config:
            self.config.append(body)
        else:
            self.header.append(body)


def _scan(
    path: str | os.PathLike[str], state: _ScanState,
) -> Iterator[tuple[str, int, dict[str, Value] | OutCycle]]:
    """Yield ("cycle", offset, OutCycle), ("action", offset, fields), ("bad", offset, fields) in
    file order; header, configuration, problems and ``truncated`` go to ``state``.

    A last line without its newline is a write cut short (a crash, a full disk, a copy cut):
    it is not parsed and the log is ``truncated``, whatever the cut left (``B``, ``CYCL``, half
    a UTF-8 character). A complete line that cannot be parsed is corruption: InputError naming
    file and line, unless only a cut-short line follows it.
    """
    name = str(path)
    current: tuple[dict[str, Value], list[tuple[str, dict[str, Value]]], int, int] | None = None
    last_line = 0
    pending: tuple[int, str, str, str, str] | None = None  # line, text, message, field, got
    cut = False
    for off, ln, text, complete in _raw_lines(path, name):
        last_line = ln
        if not complete:
            cut = True
            break
        assert text is not None
        if text.startswith("#"):
            state.comment(text)
            continue
        if not text.strip():
            continue
        if pending is not None:
            raise InputError(pending[2], file=name, line=pending[0], field=pending[3],
                             text=pending[4])
        try:
            tag, fields = parse_line(text)
        except ValueError as exc:
            pending = (ln, text, str(exc), "line", text[:80])
            continue
        if tag == "CYCLE":
            if current is not None:
                state.problems.append(f"{name}:{ln}: cycle block without END before this line")
            current = (fields, [], off, ln)
        elif tag == "END":
            if current is None:
                raise InputError("END without CYCLE", file=name, line=ln, field="END", text=text)
            yield "cycle", current[2], OutCycle(current[0], tuple(current[1]), current[3])
            current = None
        elif current is not None:
            current[1].append((tag, fields))
        elif tag == "ACT":
            yield "action", off, fields
        elif tag == "BAD":
            yield "bad", off, fields
        else:
            pending = (ln, text, "unknown line tag", "tag", tag)
    if pending is not None and not cut:
        raise InputError(pending[2], file=name, line=pending[0], field=pending[3],
                         text=pending[4])
    if current is not None or cut or state.in_config:
        state.truncated = True
        what = "last cycle block" if current is not None else "last line"
        state.problems.append(f"{name}:{last_line}: {what} is incomplete (run interrupted)")


def iter_out_log(
    path: str | os.PathLike[str],
) -> tuple[_ScanState, Iterator[tuple[str, dict[str, Value] | OutCycle]]]:
    """Stream a ``.OUT`` log: (state, events). ``events`` yields ("cycle", OutCycle),
    ("action", fields) and ("bad", fields) in file order, one at a time (memory flat in the
    length of the run); ``state.header``, ``state.config``, ``state.problems`` and
    ``state.truncated`` are complete once ``events`` is exhausted (the header already after the
    first event). Errors as :func:`read_out_log`."""
    state = _ScanState()
    return state, ((kind, item) for kind, _off, item in _scan(path, state))


def read_out_log(path: str | os.PathLike[str]) -> OutLogContents:
    """Read a ``.OUT`` log back.  A final block cut off by a crash (or any last line without its
    newline: ``B``, ``CYCL``, half a UTF-8 character) sets ``truncated``; a complete line that
    cannot be parsed raises :class:`InputError` naming file and line (a log is machine-written,
    so anything else is corruption).

    The whole file is checked, but the cycles are not kept: ``cycles`` is an :class:`OutCycles`
    that reads them from the file on demand (16 bytes per cycle in memory: the offset and the
    CYCLE line's number). Actions and bad
    records are kept (they are few; a run's bad records are capped by the writer).
    """
    name = str(path)
    state = _ScanState()
    offsets: array[int] = array("q")
    line_numbers: array[int] = array("q")
    actions: list[dict[str, Value]] = []
    bad: list[dict[str, Value]] = []
    for kind, off, item in _scan(path, state):
        if kind == "cycle":
            offsets.append(off)
            line_numbers.append(item.line)  # type: ignore[union-attr]
        elif kind == "action":
            actions.append(item)  # type: ignore[arg-type]
        else:
            bad.append(item)  # type: ignore[arg-type]
    return OutLogContents(
        header=tuple(state.header),
        config_text="\n".join(state.config) + ("\n" if state.config else ""),
        cycles=OutCycles(name, offsets, line_numbers),
        actions=tuple(actions),
        bad_records=tuple(bad),
        truncated=state.truncated,
        problems=tuple(state.problems),
    )

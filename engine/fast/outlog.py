"""The ``.OUT`` writer on the compiled ``engine.native.outfmt``: a cycle's block in one call.

The reference builds a cycle's block as rows (:func:`engine.run.records.cycle_block`) and
renders them by template (:func:`engine.io.outlog.render_rows`). The kernel does both from the
:class:`~engine.run.cycle.CycleResult` itself: ``cycle_writer`` builds the block's UTF-8 bytes
and writes them to the log's descriptor (:meth:`~engine.io.outlog.OutLogWriter.write_direct`),
``cycle_text`` gives the block's str, ``render_rows`` renders rows. Each gives the reference's
characters or declines (None) a cycle it leaves to the reference.

A run takes :class:`BlockWriter` as its block writer (``engine.run.parts.CycleParts.
out_writer``) when :func:`probe` passes; the writer also checks its first block of the run
against the reference's text and keeps to the reference for the rest of the run if they
differ (:attr:`BlockWriter.declined` says why).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from engine import native
from engine.io import outlog
from engine.io.outlog import KeyedLines, OutLogWriter, Value, block_text

CycleResult = Any
"""A cycle's result (engine.run.cycle.CycleResult: this room sits below engine.run and is
handed what it needs of it)."""
Shapes = tuple[Any, ...]
"""The block's shapes (engine.run.records.BLOCK_SHAPES): the key tuples of every line shape,
the 95 % factor, the number of navigation states, the time-stamp function; the kernel's
``cycle_rows`` takes them in this order (its ``enum`` of ``C_*``)."""
BlockOf = Callable[[Any], tuple[dict[str, Value], KeyedLines]]
"""The reference's block of a cycle (engine.run.records.cycle_block)."""


def kernel() -> Any:
    """``engine.native.outfmt`` in use, or None (not built, stale, ``UVNAV_PURE=1``)."""
    return native.kernel("outfmt")


_Row = tuple[str, tuple[str, ...], tuple[Value, ...]]


def render_rows(rows: Sequence[_Row], compiled: bool = True) -> str:
    """:func:`engine.io.outlog.render_rows` of ``rows`` by the kernel (the same characters),
    or by the reference for rows it leaves to it. ``compiled=False``: floats by ``repr``."""
    k = kernel()
    if k is not None:
        text = k.render_rows(rows, outlog._float_writer() if compiled else None,
                             outlog._format_text, outlog.format_value)
        if text is not None:
            return text  # type: ignore[no-any-return]
    return outlog.render_rows(rows, compiled)


def cycle_text(r: CycleResult, shapes: Shapes) -> str | None:
    """The whole ``.OUT`` block of ``r`` (``CYCLE`` … ``END n=…`` and its newline), the text
    :func:`engine.run.records.write_block` writes, built and rendered by one compiled call;
    None without the kernel or for a cycle it leaves to the reference."""
    k = kernel()
    if k is None:
        return None
    return k.cycle_text(r, shapes, outlog._float_writer(),  # type: ignore[no-any-return]
                        outlog._format_text, outlog.format_value)


def cycle_writer(shapes: Shapes) -> Callable[[CycleResult, int], int | None] | None:
    """``write(r, fd)``: :func:`cycle_text`'s block of ``r`` written as UTF-8 bytes to the
    descriptor ``fd`` by the kernel itself (no str made, no Python frame per cycle); it
    returns the number of bytes, or None with nothing written for a cycle it leaves to the
    reference. None without the kernel."""
    k = kernel()
    make = getattr(k, "cycle_writer", None)
    if make is None:
        return None
    return make(shapes, outlog._float_writer(),  # type: ignore[no-any-return]
                outlog._format_text, outlog.format_value)


class BlockWriter:
    """A run's block writer on the kernel: ``writer(out, r)`` writes the block of ``r`` to
    the log ``out`` by :func:`cycle_writer` (straight to its descriptor), else by
    :func:`cycle_text`, else as the reference does (``out.write_cycle(*block_of(r))``).

    ``shapes`` and ``block_of`` are the reference's (engine.run.records.BLOCK_SHAPES and
    cycle_block). The first block the kernel writes in the run is checked against the
    reference's text of the same cycle; if they differ, the run writes every block as the
    reference does and :attr:`declined` says why."""

    def __init__(self, shapes: Shapes, block_of: BlockOf) -> None:
        self._shapes = shapes
        self._block_of = block_of
        self._direct = cycle_writer(shapes)
        self.checked = False
        """True once a block of the kernel was compared with the reference's."""
        self.declined: str | None = None
        """Why this run writes its blocks by the reference (None: it does not)."""

    def __call__(self, out: OutLogWriter, r: CycleResult) -> None:
        if not self.checked:
            self._first(out, r)
            return
        if self.declined is None and not r.adapt_logged:  # an ADAPT line: the reference's
            direct = self._direct
            if direct is not None and out.write_direct(direct, r):
                return
            text = cycle_text(r, self._shapes)
            if text is not None:
                out.write_block(text)
                return
        out.write_cycle(*self._block_of(r))

    def _first(self, out: OutLogWriter, r: CycleResult) -> None:
        """The first-use check: the kernel's text of ``r`` against the reference's."""
        text = None if r.adapt_logged else cycle_text(r, self._shapes)
        if text is None:  # left to the reference: check the next one
            out.write_cycle(*self._block_of(r))
            return
        self.checked = True
        want = block_text(*self._block_of(r))
        if text != want:
            self.declined = f"first-use check: cycle {r.n}'s block differs from the reference"
            out.write_block(want)
            return
        out.write_block(text)


def _probe_rows() -> list[_Row]:
    """Rows of every value kind the writer formats (floats of each form, ints, bools, None,
    words bare and quoted, non-ASCII text)."""
    floats = (0.0, -0.0, 1.0, 0.1, 1 / 3, 52.84232512345678, -31615.4, 5857300.165, 1e16,
              1.5e-5, 9.999999999999999e-05, 1e300, 5e-324, float("nan"), float("inf"))
    words = ("lse", "", "-", "12", "1e5", "a b", 'say "x"', "k=v", "Dünkirchen", "2026-12-07T21",
             "nan", "inf", "back\\slash")
    return [
        ("CYCLE", ("n", "t", "ok"), (7, "1992-09-17T08:35:38Z", True)),
        ("\n  F", tuple(f"f{i}" for i in range(len(floats))), floats),
        ("\n  W", tuple(f"w{i}" for i in range(len(words))), words),
        ("\n  X", ("none", "no", "big"), (None, False, 10 ** 20)),
        ("\nEND", ("n",), (7,)), ("\n", (), ()),
    ]


def probe() -> str | None:
    """Why the compiled writer is not used (None: it is): not built, or its text of the probe
    rows not the reference's (with the fast float writer and with ``repr`` only)."""
    k = kernel()
    if k is None:
        return native.status("outfmt")
    rows = _probe_rows()
    for compiled in (True, False):
        text = k.render_rows(rows, outlog._float_writer() if compiled else None,
                             outlog._format_text, outlog.format_value)
        if text != outlog.render_rows(rows, compiled):
            return "first-use probe failed (render_rows)"
    if getattr(k, "cycle_writer", None) is None:
        return "first-use probe failed (no cycle_writer)"
    return None

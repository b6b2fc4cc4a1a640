"""Standard output of a headless command, guarded: a write that fails (the reader went away,
``uvnav replay … | head -1``; a full disk, ``> /dev/full``) ends the command the way a signal
would, past the command's own ``OSError`` handlers, which are about the files it names.

:func:`guarded_stdout` puts :class:`GuardedStdout` in place of ``sys.stdout`` for the command's
run; its failure is :class:`StdoutFailed`, a ``BaseException`` like ``KeyboardInterrupt`` so
that neither ``except OSError`` (which would report it as a file it is not) nor ``except
Exception`` (an internal error with a traceback) takes it. ``uvnav_tui.cli.main`` turns it into
exit 141 (a reader that went away, as SIGPIPE would) or exit 1 with one line naming standard
output.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from typing import Any, TextIO


class StdoutFailed(BaseException):
    """Standard output could not be written; ``error`` is the ``OSError`` of the write."""

    def __init__(self, error: OSError) -> None:
        super().__init__(error)
        self.error = error


class GuardedStdout:
    """``stream`` whose ``write``, ``writelines`` and ``flush`` raise :class:`StdoutFailed`
    instead of an ``OSError``; everything else (``isatty``, ``fileno``, ``encoding``…) is the
    stream's own."""

    def __init__(self, stream: TextIO) -> None:
        self._stream = stream

    def write(self, text: str) -> int:
        try:
            return self._stream.write(text)
        except OSError as exc:
            raise StdoutFailed(exc) from exc

    def writelines(self, lines: Iterable[str]) -> None:
        for line in lines:
            self.write(line)

    def flush(self) -> None:
        try:
            self._stream.flush()
        except OSError as exc:
            raise StdoutFailed(exc) from exc

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


@contextmanager
def guarded_stdout() -> Iterator[GuardedStdout]:
    """``sys.stdout`` guarded for the block, flushed at its end (so that an error of the last
    buffered lines is the command's, not the interpreter's at exit), then put back."""
    stream = sys.stdout
    guard = GuardedStdout(stream)
    sys.stdout = guard  # type: ignore[assignment]
    try:
        yield guard
        guard.flush()
    finally:
        sys.stdout = stream


def silence_stdout() -> None:
    """Point the standard output descriptor at /dev/null, so that the interpreter's own flush
    at exit (of what is still buffered) does not fail and print a second error."""
    try:
        fd = sys.stdout.fileno()
    except (OSError, ValueError, AttributeError):  # no descriptor (a capture in tests)
        return
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, fd)
    finally:
        os.close(devnull)

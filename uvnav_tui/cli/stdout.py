"""Standard output of a headless command, guarded: a write that fails (the reader went away,
``uvnav replay … | head -1``; a full disk, ``> /dev/full``) ends the command the way a signal
would, past the command's own ``OSError`` handlers, which are about the files it names.

:func:`guarded_stdout` puts :class:`GuardedStdout` in place of ``sys.stdout`` for the command's
run; its failure is :class:`StdoutFailed`, a ``BaseException`` like ``KeyboardInterrupt`` so
that neither ``except OSError`` (which would report it as a file it is not) nor ``except
Exception`` (an internal error with a traceback) takes it. ``uvnav_tui.cli.main`` turns it into
exit 141 (a reader that went away, as SIGPIPE would) or exit 1 with one line naming standard
output. Standard error is made literal the same way (:func:`literal_stderr`): control
characters in a message are written as escapes.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterable, Iterator
from contextlib import AbstractContextManager, contextmanager
from typing import Any, TextIO


class StdoutFailed(BaseException):
    """Standard output could not be written; ``error`` is the ``OSError`` of the write."""

    def __init__(self, error: OSError) -> None:
        super().__init__(error)
        self.error = error


class _InPlaceOf:
    """A text stream put in the place of ``sys.stdout`` or ``sys.stderr``: ``writelines``
    goes through the subclass's ``write``; everything else (``isatty``, ``fileno``,
    ``encoding``, ``flush``…) is the wrapped ``stream``'s own."""

    def __init__(self, stream: TextIO) -> None:
        self.stream = stream

    def write(self, text: str) -> int:
        return self.stream.write(text)

    def writelines(self, lines: Iterable[str]) -> None:
        for line in lines:
            self.write(line)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.stream, name)


class GuardedStdout(_InPlaceOf):
    """Standard output whose ``write`` and ``flush`` raise :class:`StdoutFailed` instead of
    an ``OSError``."""

    def write(self, text: str) -> int:
        try:
            return self.stream.write(text)
        except OSError as exc:
            raise StdoutFailed(exc) from exc

    def flush(self) -> None:
        try:
            self.stream.flush()
        except OSError as exc:
            raise StdoutFailed(exc) from exc


CONTROL_ESCAPES = {c: f"\\x{c:02x}" for c in (*range(0x00, 0x20), 0x7F, *range(0x80, 0xA0))
                   if c not in (0x09, 0x0A)}
"""Every C0 and C1 control character but tab and newline, as its ``\\xNN`` escape."""


class LiteralStderr(_InPlaceOf):
    """Standard error that writes control characters as ``\\xNN``: a file name or record
    quoted in a message (``x\\x1b[31m.RUN: File not found !``) is shown literally, never
    obeyed by the terminal. Rich output meant for the terminal (the replay's progress bar)
    goes to :func:`unfiltered_stderr`."""

    def write(self, text: str) -> int:
        return self.stream.write(text.translate(CONTROL_ESCAPES))


def unfiltered_stderr() -> TextIO:
    """Standard error as the terminal gets it (for Rich's own control codes)."""
    err = sys.stderr
    return err.stream if isinstance(err, LiteralStderr) else err


@contextmanager
def _in_place_of(name: str, wrapper: _InPlaceOf) -> Iterator[_InPlaceOf]:
    """``sys.<name>`` is ``wrapper`` for the block, then the stream it wraps again."""
    setattr(sys, name, wrapper)
    try:
        yield wrapper
    finally:
        setattr(sys, name, wrapper.stream)


@contextmanager
def guarded_stdout() -> Iterator[_InPlaceOf]:
    """``sys.stdout`` guarded for the block, flushed at its end (so that an error of the last
    buffered lines is the command's, not the interpreter's at exit)."""
    with _in_place_of("stdout", GuardedStdout(sys.stdout)) as guard:
        yield guard
        guard.flush()


def literal_stderr() -> AbstractContextManager[_InPlaceOf]:
    """``sys.stderr`` as :class:`LiteralStderr` for the block."""
    return _in_place_of("stderr", LiteralStderr(sys.stderr))


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

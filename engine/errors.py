"""The one error type every UVNAV parser raises for bad input."""

from __future__ import annotations

MAX_ECHO_CHARS = 200
"""Longest offending text quoted in a message (the rest is cut and marked with …)."""


class InputError(ValueError):
    """Bad input, located as precisely as the source allows.

    ``message`` is the operator-facing text (for dialogs, e.g. ``Wrong position input format !``);
    ``file``, ``line`` (1-based), ``field`` and ``text`` (the offending characters) locate it.
    ``str(err)`` gives ``file:line: field: message (got 'text')`` with absent parts left out.
    """

    def __init__(
        self,
        message: str,
        *,
        file: str | None = None,
        line: int | None = None,
        field: str | None = None,
        text: str | None = None,
    ) -> None:
        self.message = message
        self.file = file
        self.line = line
        self.field = field
        self.text = text
        super().__init__(str(self))

    def __str__(self) -> str:
        where = ""
        if self.file is not None:
            where = f"{self.file}:"
            if self.line is not None:
                where += f"{self.line}:"
            where += " "
        elif self.line is not None:
            where = f"line {self.line}: "
        field = f"{self.field}: " if self.field else ""
        text = self.text
        if text is not None and len(text) > MAX_ECHO_CHARS:  # a huge value is not echoed whole
            text = text[: MAX_ECHO_CHARS - 1] + "…"
        got = f" (got {text!r})" if text is not None else ""
        return f"{where}{field}{self.message}{got}"

    def located(self, *, file: str | None = None, line: int | None = None) -> InputError:
        """A copy with the file and/or line filled in (for errors raised by field parsers)."""
        return InputError(
            self.message,
            file=file if file is not None else self.file,
            line=line if line is not None else self.line,
            field=self.field,
            text=self.text,
        )


def read_error(exc: OSError, file: str, missing: str = "File not found !") -> InputError:
    """The InputError for a file that cannot be opened for reading, by the reason: ``missing``
    (``File not found !``), ``Is a directory, not a file !``, ``Cannot read: permission
    denied !`` or ``Cannot read: <the system's reason> !``."""
    if isinstance(exc, FileNotFoundError):
        message = missing
    elif isinstance(exc, IsADirectoryError):
        message = "Is a directory, not a file !"
    elif isinstance(exc, PermissionError):
        message = "Cannot read: permission denied !"
    else:
        message = f"Cannot read: {exc.strerror or exc} !"
    return InputError(message, file=file)

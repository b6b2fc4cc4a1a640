"""Bounded reading of the data files (``TO_WGS84.DAT``, ``DECCA.CHN``) and their checksums.

A data file is small (the bundled ones are under 2 kB), so it is read whole, but never more than
:data:`MAX_DATA_FILE_BYTES`: a file symlinked to ``/dev/zero`` or a multi-gigabyte file given by
mistake is refused with a located message instead of reading until memory runs out. Only regular
files are read (a device, a FIFO or a directory is refused before any byte is read).

The SHA-256 of the bundled files is recorded in :data:`BUNDLED_SHA256`; :func:`modified_bundled`
tells a run that it uses a file that differs from the one shipped with UVNAV (docs/DATAFILES.md).
A change that keeps every value inside its physical range (e.g. one digit of a station's seconds)
cannot be caught by any parser check; this warning is what makes such a change visible.

Both parsers walk their lines with :class:`DataLines` (comments, blank lines and the required
``* End of Data`` marker) and read numbers with :func:`plain_number`.
"""

from __future__ import annotations

import hashlib
import os
import stat
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

from engine.errors import InputError
from engine.io.operator_input import SIGNED_DECIMAL_RE

__all__ = [
    "BUNDLED_SHA256",
    "MAX_DATA_FILE_BYTES",
    "DataLine",
    "DataLines",
    "DataText",
    "is_plain_number",
    "modified_bundled",
    "plain_number",
    "read_data_text",
]

MAX_DATA_FILE_BYTES = 1 << 20
"""Largest data file read (1 MiB: some 20 000 datum rows or 1 000 chains)."""

BUNDLED_SHA256: dict[str, str] = {
    "TO_WGS84.DAT": "df8c52f7e0a952bfd8be6933664d4d9a35f7d1f304682d35a81a3bbe7210f31b",
    "DECCA.CHN": "4dbcacef1dc6e807a0739a8c6c6242e49d0d12d5e32b62e727f5b1e293681797",
}
"""SHA-256 (hex) of the data files in ``data/`` as shipped (thesis A8.4 transcriptions)."""


@dataclass(frozen=True, slots=True)
class DataText:
    """A data file's text (UTF-8, a BOM removed, undecodable bytes replaced) and the SHA-256
    (hex) of its bytes."""

    text: str
    sha256: str


def read_data_text(path: str | os.PathLike[str], limit: int = MAX_DATA_FILE_BYTES) -> DataText:
    """Read a regular file of at most ``limit`` bytes.

    Raises ``InputError`` naming the file: ``File not found !``, ``Not a regular file !`` (a
    device such as ``/dev/zero``, a FIFO, a directory), ``File too large (more than N bytes) !``
    or ``Cannot read file !`` with the system's reason.
    """
    name = os.fspath(path)
    try:
        fd = os.open(name, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except FileNotFoundError:
        raise InputError("File not found !", file=name) from None
    except OSError as exc:
        raise InputError("Cannot read file !", file=name, text=exc.strerror) from None
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise InputError("Not a regular file !", file=name)
        with os.fdopen(fd, "rb", closefd=False) as fh:
            data = fh.read(limit + 1)
    except OSError as exc:
        raise InputError("Cannot read file !", file=name, text=exc.strerror) from None
    finally:
        os.close(fd)
    if len(data) > limit:
        raise InputError(f"File too large (more than {limit} bytes) !", file=name)
    digest = hashlib.sha256(data).hexdigest()
    return DataText(data.decode("utf-8-sig", errors="replace"), digest)


def modified_bundled(path: str | os.PathLike[str]) -> str | None:
    """A warning when ``path`` is named like a bundled data file but its bytes differ from the
    shipped file's (None when it is identical, unknown by name, or unreadable: reading it
    properly is the parser's job)."""
    p = Path(path)
    expected = BUNDLED_SHA256.get(p.name)
    if expected is None:
        return None
    try:
        got = read_data_text(p).sha256
    except InputError:
        return None
    if got == expected:
        return None
    return (f"{p}: differs from the bundled {p.name} (sha256 {got[:12]}…, shipped "
            f"{expected[:12]}…): a modified data file; check it is the one you mean")


@dataclass(frozen=True, slots=True)
class DataLine:
    """One non-blank line of a data file: its 1-based number, its stripped text and, for a
    comment (first character ``*``), the text after the ``*`` (stripped; None on a data line)."""

    line_no: int
    text: str
    comment: str | None


class DataLines:
    """The non-blank lines of a data file up to its required ``* End of Data`` marker.

    Iterating yields :class:`DataLine` items, the marker included (test :attr:`is_end`); a data
    line after the marker raises ``Data after 'End of Data' (line N) !``. After the loop,
    :attr:`last_line` is the file's last line number (blank lines counted) and
    :meth:`require_end` refuses a file cut short. Shared by the datum and chain file parsers.
    """

    def __init__(self, lines: Iterable[str], file: str) -> None:
        self._lines = lines
        self.file = file
        self.ended_at: int | None = None
        self.last_line = 0

    @staticmethod
    def is_end(line: DataLine) -> bool:
        """True on the ``* End of Data`` comment (any case and spacing)."""
        return line.comment is not None and " ".join(line.comment.lower().split()) == "end of data"

    def __iter__(self) -> Iterator[DataLine]:
        for line_no, raw in enumerate(self._lines, 1):
            self.last_line = line_no
            stripped = raw.strip()
            if not stripped:
                continue
            if stripped.startswith("*"):
                line = DataLine(line_no, stripped, stripped[1:].strip())
                if self.is_end(line):
                    self.ended_at = line_no
                yield line
                continue
            if self.ended_at is not None:
                raise InputError(
                    f"Data after 'End of Data' (line {self.ended_at}) !",
                    file=self.file, line=line_no, field="section", text=stripped,
                )
            yield DataLine(line_no, stripped, None)

    def require_end(self) -> None:
        """Raise ``No '* End of Data' line`` unless the marker was read."""
        if self.ended_at is None:
            raise InputError(
                "No '* End of Data' line: the file is cut short !",
                file=self.file, line=self.last_line or None, field="section",
            )


def is_plain_number(token: str) -> bool:
    """True for a plain decimal: optional ``-``, ASCII digits (:data:`SIGNED_DECIMAL_RE`)."""
    return SIGNED_DECIMAL_RE.fullmatch(token) is not None


def plain_number(token: str, field: str) -> float:
    """A plain decimal (:func:`is_plain_number`) as a float, else ``Not a number !`` at
    ``field`` (the caller adds the file and line)."""
    if not is_plain_number(token):
        raise InputError("Not a number !", field=field, text=token)
    return float(token)

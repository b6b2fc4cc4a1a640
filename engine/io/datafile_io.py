"""Bounded reading of the data files (``TO_WGS84.DAT``, ``DECCA.CHN``) and their checksums.

A data file is small (the bundled ones are under 2 kB), so it is read whole, but never more than
:data:`MAX_DATA_FILE_BYTES`: a file symlinked to ``/dev/zero`` or a multi-gigabyte file given by
mistake is refused with a located message instead of reading until memory runs out. Only regular
files are read (a device, a FIFO or a directory is refused before any byte is read).

The SHA-256 of the bundled files is recorded in :data:`BUNDLED_SHA256`; :func:`modified_bundled`
tells a run that it uses a file that differs from the one shipped with UVNAV (docs/DATAFILES.md).
A change that keeps every value inside its physical range (e.g. one digit of a station's seconds)
cannot be caught by any parser check; this warning is what makes such a change visible.
"""

from __future__ import annotations

import hashlib
import os
import stat
from dataclasses import dataclass
from pathlib import Path

from engine.errors import InputError

__all__ = [
    "BUNDLED_SHA256",
    "MAX_DATA_FILE_BYTES",
    "DataText",
    "modified_bundled",
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

"""Opening output files: the ``.OUT`` rule, identity checks against the inputs, ``--force``.

Every file UVNAV writes (``.OUT`` log, JSON lines, smoothed positions, simulated ``.RUN`` and
truth CSV, assessment SVG) is opened here, by :meth:`OutputGuard.open`. The rule (docs/CLI.md,
"Output files"):

* **Identity, not names.** Two paths are the same file when ``os.stat`` gives the same
  ``(st_dev, st_ino)``, so hard links and symbolic links cannot disguise an input. An output
  that is the same file as an input of the run (``.RUN``, configuration, scenario, data files,
  the log being assessed, …) or as another output of the run is refused, with or without
  ``--force``.
* **Never overwritten.** An existing name (any directory entry: a file, a directory, a dangling
  symbolic link) is kept; the first free ``stem_N.suffix`` is used instead (exclusive create, so
  two runs never share a file). ``uvnav simulate`` refuses instead of renaming
  (``existing="refuse"``).
* **``--force`` replaces an earlier output, never anything else.** It truncates an existing file
  only if it is a regular file, not an input of this run, and either empty or recognisably a
  UVNAV output of the same kind by its first line (:data:`SIGNATURES`). A dangling symbolic link
  is refused (writing through it would create a file wherever it points).
* **Only regular files.** A device, pipe, socket or directory as an output is refused with a
  clear message (``--no-out`` writes no log); no sibling name is ever made up next to it.

Errors: :class:`~engine.errors.InputError` (field = the option, e.g. ``--out``) for a refused
name; :class:`OSError` with ``filename`` set when the operating system refuses to create or
write a file. :class:`OutputFile` keeps naming the file in every later write, flush, fsync and
close error.
"""

from __future__ import annotations

import codecs
import json
import os
import stat
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

from engine.errors import InputError

FileId = tuple[int, int]
"""``(st_dev, st_ino)``: what makes two paths the same file."""

NUL_MESSAGE = "A path cannot contain a NUL character !"
DIRECTORY_MESSAGE = "Is a directory, not a file name !"
NO_DIRECTORY_MESSAGE = "Directory not found !"
NOT_REGULAR_MESSAGE = ("Not a regular file (a device, pipe or socket): UVNAV writes only "
                       "regular files !")
DANGLING_MESSAGE = "Dangling symbolic link: refusing to write where it points !"
EXISTS_MESSAGE = "File exists (use --force to replace an earlier output) !"
SIGNATURE_BYTES = 4096
"""How much of an existing file is read to recognise it (its first line)."""


def _first_json(line: bytes) -> dict[str, object] | None:
    try:
        value = json.loads(line)
    except ValueError:
        return None
    return value if isinstance(value, dict) else None


def _is_out(line: bytes) -> bool:
    return line.startswith(b"# UVNAV output log")


def _is_jsonl(line: bytes) -> bool:
    obj = _first_json(line)
    return obj is not None and {"n", "time", "mpp"} <= obj.keys()


def _is_positions(line: bytes) -> bool:
    obj = _first_json(line)
    return obj is not None and {"lat", "lon", "x", "y"} <= obj.keys()


def _is_run(line: bytes) -> bool:
    from engine.io.runfile import parse_run_line

    try:
        text = line.decode("utf-8")
        parse_run_line(text, 1, "<output>")  # a record, a caption or a '*' comment
    except (ValueError, InputError):
        return False
    return bool(text.strip())


def _is_truth(line: bytes) -> bool:
    return line.startswith(b"# UVNAV simulator truth")


def _is_raw_times(line: bytes) -> bool:
    return line.startswith(b"# UVNAV live receive times")


def _is_nmea(line: bytes) -> bool:
    """An NMEA 0183 sentence with a correct checksum (``$TTKKK,…*HH``, CR LF or LF)."""
    from engine.io.nmea_write import checksum

    text = line.rstrip(b"\r")
    if len(text) < 10 or text[:1] != b"$" or text[-3:-2] != b"*" or not text.isascii():
        return False
    body = text[1:-3].decode("ascii")
    return body[:5].isalnum() and body[5:6] == "," and checksum(body) == text[-2:].decode()


def _is_svg(head: bytes) -> bool:
    return b"<svg" in head and b"UVNAV assess plot" in head


def _is_gpx(head: bytes) -> bool:
    return b"<gpx" in head and b'creator="UVNAV export"' in head


def _is_geojson(line: bytes) -> bool:
    return line.startswith(b'{"type":"FeatureCollection","uvnav_export":')


def _is_export_csv(line: bytes) -> bool:
    return line.startswith(b"time_utc,cycle,record,source,filter,datum,")


def _is_kml(head: bytes) -> bool:
    return b"<kml" in head and b"<name>UVNAV export" in head


@dataclass(frozen=True)
class Signature:
    """How to recognise an earlier UVNAV output of one kind from its first bytes."""

    description: str
    matches: Callable[[bytes], bool]
    whole_head: bool = False
    """Test the first :data:`SIGNATURE_BYTES` bytes instead of the first line only."""


SIGNATURES: dict[str, Signature] = {
    "out": Signature(".OUT log (first line '# UVNAV output log')", _is_out),
    "jsonl": Signature("JSON-lines cycle log (an object with n, time, mpp)", _is_jsonl),
    "positions": Signature("JSON-lines position file (an object with lat, lon, x, y)",
                           _is_positions),
    "run": Signature(".RUN file (a record, caption or * comment on the first line)", _is_run),
    "truth": Signature("truth CSV (first line '# UVNAV simulator truth')", _is_truth),
    "svg": Signature("assessment plot (an SVG marked 'UVNAV assess plot')", _is_svg,
                     whole_head=True),
    "nmea": Signature("NMEA 0183 log (a sentence with a correct checksum on the first line)",
                      _is_nmea),
    "gpx": Signature("GPX export (creator 'UVNAV export')", _is_gpx, whole_head=True),
    "geojson": Signature("GeoJSON export (a FeatureCollection with 'uvnav_export')",
                         _is_geojson),
    "csv": Signature("CSV export (header 'time_utc,cycle,record,…')", _is_export_csv),
    "kml": Signature("KML export (named 'UVNAV export')", _is_kml, whole_head=True),
    "raw_times": Signature("live receive-time log (first line '# UVNAV live receive times')",
                           _is_raw_times),
    "nmea_raw": Signature("(nothing: a raw NMEA recording is never replaced)",
                          lambda _line: False),
}


def file_id(path: str | os.PathLike[str]) -> FileId | None:
    """``(st_dev, st_ino)`` of the file ``path`` names (symbolic links followed), or None if
    there is none (missing, dangling link, unreadable directory on the way)."""
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return None
    return (st.st_dev, st.st_ino)


def free_name(path: Path) -> Path:
    """``path`` if no directory entry has that name, else the first free ``stem_N.suffix``.

    A dangling symbolic link or a directory counts as taken (``os.path.lexists``), so the
    exclusive create that follows cannot keep failing on the same name.
    """
    if not os.path.lexists(path):
        return path
    n = 1
    while True:
        candidate = path.with_name(f"{path.stem}_{n}{path.suffix}")
        if not os.path.lexists(candidate):
            return candidate
        n += 1


class OutputFile:
    """A text output (UTF-8, ``\\n`` line ends) whose every error names its file."""

    def __init__(self, handle: IO[str], path: Path, *, utf8_fd: int | None = None) -> None:
        """``utf8_fd``: the descriptor of ``handle`` when it writes each str as its UTF-8
        bytes, unchanged (``newline="\\n"``): then a caller may write such bytes straight to
        it while nothing is buffered (:attr:`utf8_fd`)."""
        self._fh = handle
        self.path = path
        self.utf8_fd = utf8_fd
        """The descriptor that takes the handle's UTF-8 bytes directly, or None (another
        encoding, or not known). Write to it only when every earlier write was flushed."""

    def _error(self, exc: OSError) -> OSError:
        return OSError(exc.errno, exc.strerror or str(exc), str(self.path))

    def os_error(self, exc: OSError) -> OSError:
        """``exc`` (from a write to :attr:`utf8_fd`) as an OSError naming this file."""
        return self._error(exc)

    def write(self, text: str) -> None:
        """Write ``text`` (buffered)."""
        try:
            self._fh.write(text)
        except OSError as exc:
            raise self._error(exc) from exc

    def write_flushed(self, text: str) -> None:
        """Write ``text`` and hand the buffer to the operating system (:meth:`write` then
        :meth:`flush` in one call: the ``.OUT`` writes every cycle so)."""
        fh = self._fh
        try:
            fh.write(text)
            fh.flush()
        except OSError as exc:
            raise self._error(exc) from exc

    def flush(self) -> None:
        """Hand the buffer to the operating system."""
        try:
            self._fh.flush()
        except OSError as exc:
            raise self._error(exc) from exc

    def fsync(self) -> None:
        """Flush and force to the disk."""
        self.flush()
        try:
            os.fsync(self._fh.fileno())
        except OSError as exc:
            raise self._error(exc) from exc

    def fileno(self) -> int:
        """The file descriptor."""
        return self._fh.fileno()

    @property
    def closed(self) -> bool:
        """True once closed."""
        return self._fh.closed

    def close(self, sync: bool = False) -> None:
        """Flush (and with ``sync`` force to disk) and close; the file is closed even when
        that fails, and the error names the file."""
        if self._fh.closed:
            return
        try:
            if sync:
                self.fsync()
            else:
                self.flush()
        finally:
            try:
                self._fh.close()
            except OSError as exc:
                raise self._error(exc) from exc

    def __enter__(self) -> OutputFile:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _refuse(message: str, path: Path, label: str) -> InputError:
    return InputError(message, file=str(path), field=label)


@dataclass
class OutputGuard:
    """The files of one run that an output must never be: its inputs and its outputs so far.

    :meth:`protect` registers an input; :meth:`check` refuses a name before anything is
    written (so a refused run leaves nothing behind); :meth:`open` opens an output by the rule
    of the module docstring and registers it.
    """

    ids: dict[FileId, str] = field(default_factory=dict)
    """Identity → label (``the run file``, ``--out`` …) of every protected file."""
    names: dict[str, str] = field(default_factory=dict)
    """Absolute real path → label of every output checked but not opened yet."""
    planned: dict[FileId, str] = field(default_factory=dict)
    """Identity → label of every existing file an output name checked so far points at."""

    def protect(self, label: str, path: str | os.PathLike[str] | None) -> None:
        """Register an input of the run (ignored when None or missing)."""
        if path is None:
            return
        fid = file_id(path)
        if fid is not None:
            self.ids.setdefault(fid, label)

    def protect_all(self, items: Iterable[tuple[str, str | os.PathLike[str] | None]]) -> None:
        """:meth:`protect` each ``(label, path)``."""
        for label, path in items:
            self.protect(label, path)

    def _clash(self, path: Path, label: str) -> str | None:
        """The label of an input or another output that ``path`` is (None if none)."""
        fid = file_id(path)
        if fid is not None and fid in self.ids:
            return self.ids[fid]
        for other in (None if fid is None else self.planned.get(fid),
                      self.names.get(os.path.realpath(path))):
            if other is not None and other != label:
                return other
        return None

    def check(self, path: str | os.PathLike[str], label: str, *, kind: str | None = None,
              force: bool = False) -> Path:
        """Refuse a name that can never be an output (InputError, field ``label``): a NUL in
        it, a missing directory, a directory, a device/pipe/socket, the same file as an input
        or as another output named so far; with ``force`` and a ``kind`` also an existing
        file that is not an earlier output of that kind (read only: nothing is changed, so
        every output of a run can be checked before any is opened). Returns the path;
        remembers the name."""
        target = Path(path)
        if "\0" in os.fspath(target):
            raise InputError(NUL_MESSAGE, field=label, text=os.fspath(target))
        if target.name in ("", ".", "..") or os.fspath(path).endswith(os.sep):
            raise _refuse(DIRECTORY_MESSAGE, target, label)
        if not target.parent.is_dir():
            raise _refuse(NO_DIRECTORY_MESSAGE, target, label)
        other = self._clash(target, label)
        if other is not None:
            raise _refuse(f"Same file as {other} !", target, label)
        try:
            st = os.stat(target)
        except OSError:
            st = None
        if st is not None:
            if stat.S_ISDIR(st.st_mode):
                raise _refuse(DIRECTORY_MESSAGE, target, label)
            if not stat.S_ISREG(st.st_mode):
                raise _refuse(NOT_REGULAR_MESSAGE, target, label)
            if force and kind is not None:
                try:
                    with open(target, "rb") as fh:
                        self._check_signature(fh.read(SIGNATURE_BYTES), target, label,
                                              SIGNATURES[kind])
                except OSError as exc:
                    raise OSError(exc.errno, exc.strerror, str(target)) from None
            self.planned.setdefault((st.st_dev, st.st_ino), label)
        elif force and os.path.islink(target):
            raise _refuse(DANGLING_MESSAGE, target, label)
        self.names.setdefault(os.path.realpath(target), label)
        return target

    def open(
        self,
        path: str | os.PathLike[str],
        *,
        label: str,
        kind: str,
        force: bool = False,
        existing: str = "free",
        encoding: str = "utf-8",
    ) -> OutputFile:
        """Open a new output by the module's rule and register it; returns the open file (its
        ``path`` is the name actually used).

        ``kind`` is a key of :data:`SIGNATURES` (what ``force`` may replace); ``existing`` is
        ``"free"`` (an existing name gets a free ``stem_N`` sibling) or ``"refuse"``;
        ``encoding`` of the text (``latin-1`` writes one byte per character: the live raw log).
        """
        signature = SIGNATURES[kind]
        target = self.check(path, label)
        while True:
            if os.path.lexists(target):
                if force:
                    fd = self._open_existing(target, label, signature)
                    break
                if existing == "refuse":
                    raise _refuse(EXISTS_MESSAGE, target, label)
                target = free_name(target)
            try:
                fd = os.open(target, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
                break
            except FileExistsError:
                continue  # taken meanwhile (another run): look again
            except OSError as exc:
                raise OSError(exc.errno, exc.strerror, str(target)) from None
        st = os.fstat(fd)
        self.ids[(st.st_dev, st.st_ino)] = label
        handle = os.fdopen(fd, "w", encoding=encoding, newline="\n")
        return OutputFile(handle, target,
                          utf8_fd=fd if codecs.lookup(encoding).name == "utf-8" else None)

    @staticmethod
    def _check_signature(head: bytes, target: Path, label: str, signature: Signature) -> None:
        first = head if signature.whole_head else head.split(b"\n", 1)[0]
        if head and not signature.matches(first):
            raise _refuse(f"Not an earlier UVNAV output: --force replaces only a "
                          f"{signature.description} or an empty file !", target, label)

    def _open_existing(self, target: Path, label: str, signature: Signature) -> int:
        """Open an existing file for ``--force``: only an earlier output of this kind, checked
        on the open descriptor (no race between the check and the truncation)."""
        if file_id(target) is None:
            raise _refuse(DANGLING_MESSAGE, target, label)
        try:
            fd = os.open(target, os.O_RDWR | os.O_NONBLOCK)
        except OSError as exc:
            raise OSError(exc.errno, exc.strerror, str(target)) from None
        try:
            st = os.fstat(fd)
            if not stat.S_ISREG(st.st_mode):
                raise _refuse(NOT_REGULAR_MESSAGE, target, label)
            other = self.ids.get((st.st_dev, st.st_ino))
            if other is not None:
                raise _refuse(f"Same file as {other} !", target, label)
            self._check_signature(os.read(fd, SIGNATURE_BYTES), target, label, signature)
            os.ftruncate(fd, 0)
            os.lseek(fd, 0, os.SEEK_SET)
            os.set_blocking(fd, True)
        except BaseException:
            os.close(fd)
            raise
        return fd


def remove_created(files: Iterable[OutputFile | None], force: bool) -> None:
    """Close outputs opened for a run that then could not start, and remove them again when
    they were new (without ``force`` every output is a new file)."""
    for f in files:
        if f is None:
            continue
        try:
            f.close()
        except OSError:
            pass
        if not force:
            f.path.unlink(missing_ok=True)


__all__ = [
    "SIGNATURES",
    "FileId",
    "OutputFile",
    "OutputGuard",
    "file_id",
    "free_name",
    "remove_created",
]

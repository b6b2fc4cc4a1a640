"""Reader and writer for the geodetic datum file ``TO_WGS84.DAT`` (thesis A8.4, L8800–8871).

Layout (THEORY §13.1; role of the file: thesis L5552–5554):

* Lines whose first non-blank character is ``*`` are comments; blank lines are ignored.
* Section 1, "Parameters of reference spheroids": ``NAME  a[m]  1/f``.
* Section 2, "Transformation parameters of Datums / Datum ==> WGS84":
  ``NAME  a[m]  1/f  dX[m]  dY[m]  dZ[m]  Rx["]  Ry["]  Rz["]  scale[ppm]``, with
  X_WGS84 = X_datum + (dX, dY, dZ) extended to Bursa–Wolf (THEORY D1).
* Names may contain spaces, so the numbers are the *last* 2 (section 1) or 9 (section 2) tokens
  and the name is everything before them (re-joined with single spaces).

Decisions (documented behaviour):

* A section starts at a header comment: a comment mentioning ``datum`` starts section 2;
  otherwise one mentioning ``spheroid`` or ``ellipsoid`` starts section 1. A data line before
  any header is an error (field ``section``).
* ``* End of Data`` ends the file and is required: a file without it was cut short (a copy
  interrupted, a disk full), and a cut inside the last number would otherwise read as a
  different number. Data after it is an error (a datum appended after the end marker would
  otherwise be silently ignored).
* A file without any datum row is an error (most likely the wrong file).
* Physical ranges (docs/DATAFILES.md gives the sources): semi-major axis
  6 376 000 ≤ a ≤ 6 379 000 m and inverse flattening 290 ≤ 1/f ≤ 310 (every reference
  ellipsoid in use lies inside: Everest 1830 a = 6 377 276.345 m, 1/f = 300.8017 to
  International 1924 a = 6 378 388 m, Clarke 1880 1/f = 293.465); shifts |dX|, |dY|, |dZ| ≤
  1000 m; rotations |Rx|, |Ry|, |Rz| ≤ 30″ (≈ 930 m at the Earth's surface); scale |ds| ≤ 50 ppm
  (≈ 320 m; OSGB 1936's −20.5 ppm is among the largest in use). A mistyped or cut digit in any
  of the leading figures falls outside and is an error at its line and field. Every number is a
  plain decimal in ASCII digits with an optional ``-`` (no ``+``, exponent, ``_``,
  ``inf``/``nan``). Names are unique (case and spacing insensitive).
* At most :data:`engine.io.datafile_io.MAX_DATA_FILE_BYTES` are read, from a regular file only.
* A datum's ``Ellipsoid`` is built from the datum row's own a and 1/f. It is named after the
  first spheroid of section 1 with exactly the same a and 1/f (e.g. ED50 → ``HAYFORD 1909``,
  which equals INTERNATIONAL), otherwise after the datum itself (e.g. ``WGS84``, ``OSGB 1936``,
  whose 1/f = 299.3249647 differs from AIRY 1830's 299.3249646 in the thesis file).
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass

from engine.errors import InputError
from engine.geodesy.ellipsoid import (
    A_RANGE_M,
    INV_F_RANGE,
    ROTATION_MAX_ARCSEC,
    SCALE_MAX_PPM,
    SHIFT_MAX_M,
    Datum,
    Ellipsoid,
)
from engine.io.datafile_io import DataLines, is_plain_number, plain_number, read_data_text
from engine.io.operator_input import format_decimal

__all__ = [
    "DatumFile",
    "format_datum_file",
    "parse_datum_text",
    "read_datum_file",
]

_SPHEROID_FIELDS = ("a", "1/f")
_DATUM_FIELDS = ("a", "1/f", "dX", "dY", "dZ", "Rx", "Ry", "Rz", "scale")
_DATUM_LIMITS = (
    ("dX", SHIFT_MAX_M, "m"), ("dY", SHIFT_MAX_M, "m"), ("dZ", SHIFT_MAX_M, "m"),
    ("Rx", ROTATION_MAX_ARCSEC, '"'), ("Ry", ROTATION_MAX_ARCSEC, '"'),
    ("Rz", ROTATION_MAX_ARCSEC, '"'), ("scale", SCALE_MAX_PPM, "ppm"),
)


def _key(name: str) -> str:
    """Lookup key of a name: upper case, runs of whitespace collapsed to one space."""
    return " ".join(name.split()).upper()


@dataclass(frozen=True)
class DatumFile:
    """Contents of ``TO_WGS84.DAT``: spheroids (section 1) and datums (section 2), in file order.

    Keys are the names as written in the file (single-spaced), e.g. ``"ED50 [DMA]"``.
    """

    spheroids: dict[str, Ellipsoid]
    datums: dict[str, Datum]

    def datum(self, name: str) -> Datum:
        """The datum called ``name`` (exact, else case- and spacing-insensitive match).

        Raises ``InputError("Unknown datum !", field="datum", text=name)`` (THEORY §13.7).
        """
        found = self.datums.get(name)
        if found is not None:
            return found
        wanted = _key(name)
        for key, datum in self.datums.items():
            if _key(key) == wanted:
                return datum
        raise InputError("Unknown datum !", field="datum", text=name)


def _check_shape(a: float, inv_f: float, tokens: list[str]) -> None:
    """Semi-major axis and inverse flattening within their physical ranges (module doc)."""
    if not A_RANGE_M[0] <= a <= A_RANGE_M[1]:
        raise InputError(
            f"Semi-major axis must be between {A_RANGE_M[0]:.0f} and {A_RANGE_M[1]:.0f} m !",
            field="a", text=tokens[0],
        )
    if not INV_F_RANGE[0] <= inv_f <= INV_F_RANGE[1]:
        raise InputError(
            f"Inverse flattening must be between {INV_F_RANGE[0]:.0f} and "
            f"{INV_F_RANGE[1]:.0f} !",
            field="1/f", text=tokens[1],
        )


def _check_transformation(values: list[float], tokens: list[str]) -> None:
    """Shifts, rotations and scale of a datum row within their physical ranges (module doc)."""
    for (fld, limit, unit), value, token in zip(_DATUM_LIMITS, values[2:], tokens[2:],
                                                strict=True):
        if abs(value) > limit:
            raise InputError(
                f"{fld} must be between -{limit:g} and {limit:g} {unit} !",
                field=fld, text=token,
            )


def parse_datum_text(text: str, filename: str = "<string>") -> DatumFile:
    """Parse the text of a datum file (see the module docstring for the grammar and checks).

    Raises ``InputError`` naming ``filename``, the 1-based line, the field (``a``, ``1/f``,
    ``dX`` … ``scale``, ``name``, ``record``, ``section``) and the offending text.
    """
    return _parse_lines(text.splitlines(), filename)


def read_datum_file(path: str | os.PathLike[str]) -> DatumFile:
    """Read and parse a datum file from disk (UTF-8, undecodable bytes replaced).

    A missing file gives ``InputError("File not found !")`` (THEORY §13.7); a device, FIFO
    or directory, or a file over 1 MiB, is refused (:func:`engine.io.datafile_io.read_data_text`).
    """
    name = os.fspath(path)
    return _parse_lines(read_data_text(name).text.splitlines(), name)


class _Sections:
    """Rows of a datum file collected per section while parsing (local to one parse call)."""

    def __init__(self) -> None:
        self.section = 0
        self.spheroids: dict[str, Ellipsoid] = {}
        self.spheroid_keys: set[str] = set()
        self.datum_rows: list[tuple[str, list[float]]] = []
        self.datum_keys: set[str] = set()

    def header(self, body: str) -> None:
        """A comment: one mentioning ``datum`` starts section 2, ``spheroid``/``ellipsoid`` 1."""
        body = body.lower()
        if "datum" in body:
            self.section = 2
        elif "spheroid" in body or "ellipsoid" in body:
            self.section = 1

    def row(self, stripped: str) -> None:
        """One data line of the current section, checked and stored."""
        if self.section == 0:
            raise InputError("Data line before any section header !", field="section",
                             text=stripped)
        name, numbers, values = _split_row(stripped, self.section)
        _check_shape(values[0], values[1], numbers)
        key = _key(name)
        if self.section == 1:
            if key in self.spheroid_keys:
                raise InputError("Duplicate spheroid name !", field="name", text=name)
            self.spheroid_keys.add(key)
            self.spheroids[name] = Ellipsoid(name, values[0], values[1])
        else:
            _check_transformation(values, numbers)
            if key in self.datum_keys:
                raise InputError("Duplicate datum name !", field="name", text=name)
            self.datum_keys.add(key)
            self.datum_rows.append((name, values))


def _split_row(stripped: str, section: int) -> tuple[str, list[str], list[float]]:
    """A row's name (the leading tokens, single-spaced), its number tokens and their values."""
    tokens = stripped.split()
    fields = _SPHEROID_FIELDS if section == 1 else _DATUM_FIELDS
    count = len(fields)
    if len(tokens) < count + 1:
        layout = "NAME a 1/f" if section == 1 else "NAME a 1/f dX dY dZ Rx Ry Rz scale"
        raise InputError(f"Too few fields, expected {layout} !", field="record", text=stripped)
    if (
        section == 1
        and len(tokens) >= len(_DATUM_FIELDS) + 1
        and all(is_plain_number(t) for t in tokens[-len(_DATUM_FIELDS):])
    ):
        raise InputError(
            "Datum row in the spheroid section (missing section header?) !",
            field="section", text=stripped,
        )
    numbers = tokens[-count:]
    values = [plain_number(tok, fld) for tok, fld in zip(numbers, fields, strict=True)]
    return " ".join(tokens[:-count]), numbers, values


def _parse_lines(lines: Iterable[str], file: str) -> DatumFile:
    scan = DataLines(lines, file)
    rows = _Sections()
    for line in scan:
        if line.comment is not None:
            if not scan.is_end(line):
                rows.header(line.comment)
            continue
        try:
            rows.row(line.text)
        except InputError as exc:
            raise exc.located(file=file, line=line.line_no) from None
    if not rows.datum_rows:
        raise InputError(
            "No datums in file !", file=file, line=scan.last_line or None, field="section"
        )
    scan.require_end()
    datums = {name: _make_datum(name, values, rows.spheroids) for name, values in rows.datum_rows}
    return DatumFile(spheroids=rows.spheroids, datums=datums)


def _make_datum(name: str, v: list[float], spheroids: dict[str, Ellipsoid]) -> Datum:
    a, inv_f = v[0], v[1]
    ell_name = next(
        (s.name for s in spheroids.values() if s.a_m == a and s.inv_f == inv_f), name
    )
    return Datum(
        name,
        Ellipsoid(ell_name, a, inv_f),
        dx_m=v[2], dy_m=v[3], dz_m=v[4],
        rx_arcsec=v[5], ry_arcsec=v[6], rz_arcsec=v[7], scale_ppm=v[8],
    )


def format_datum_file(df: DatumFile) -> str:
    """Write ``df`` in the thesis layout (tab-separated, comment headers, ``* End of Data``).

    ``parse_datum_text(format_datum_file(df)) == df`` for every parsed ``df``. The datum's
    ellipsoid name is not written; on reading it is re-derived by the rule in the module doc.
    """
    out = ["*", "* Parameters of reference spheroids", "*"]
    for name, ell in df.spheroids.items():
        out.append(f"{name}\t{format_decimal(ell.a_m, 3)}\t{format_decimal(ell.inv_f, 7)}")
    out += ["*", "*", "*", "* Transformation parameters of Datums", "*", "* Datum ==> WGS84", "*"]
    for name, d in df.datums.items():
        e = d.ellipsoid
        cols = [
            format_decimal(e.a_m, 3), format_decimal(e.inv_f, 7),
            format_decimal(d.dx_m, 3), format_decimal(d.dy_m, 3), format_decimal(d.dz_m, 3),
            format_decimal(d.rx_arcsec, 2), format_decimal(d.ry_arcsec, 2),
            format_decimal(d.rz_arcsec, 2),
            format_decimal(d.scale_ppm, 2),
        ]
        out.append("\t".join([name, *cols]))
    out += ["*", "* End of Data"]
    return "\n".join(out) + "\n"

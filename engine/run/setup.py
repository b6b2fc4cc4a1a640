"""A run's set-up before any cycle: the run configuration checked against the data files
``TO_WGS84.DAT`` and ``DECCA.CHN`` (:func:`load_run_config`, :func:`load_data`,
:func:`check_config`) and the files a run reads (:func:`run_inputs`).

Only the configuration, the two data-file readers and the errors: no NumPy, no filter, no
NMEA reader, so the console can show its Parameter Initialization dialog before the numeric
engine is loaded (issue 14, start-up time). :mod:`engine.run.session` re-exports every name.
"""

from __future__ import annotations

import os
from pathlib import Path

from engine.errors import InputError
from engine.io.datafile_io import modified_bundled
from engine.io.datumfile import DatumFile, read_datum_file
from engine.io.deccafile import DeccaChain, read_chain_file
from engine.io.operator_input import parse_datum_name
from engine.run.config import UNKNOWN_CHAIN_MESSAGE, RunConfig, load_config

DATUM_FILE = "TO_WGS84.DAT"
CHAIN_FILE = "DECCA.CHN"


def check_config(cfg: RunConfig, datums: DatumFile, chains: dict[str, DeccaChain]) -> None:
    """Check the names ``cfg`` takes from the data files: ``datum`` and ``run_gps_datum`` in
    ``TO_WGS84.DAT`` (``WGS84`` is always known), ``decca.chain`` in ``DECCA.CHN``.

    Raises :class:`InputError` with the configuration ``field`` and ``text`` but no file (a
    RunConfig does not know its file; :func:`load_run_config` adds file and line).
    """
    parse_datum_name(cfg.datum, datums.datums, field="datum")
    if cfg.run_gps_datum.upper() != "WGS84":
        parse_datum_name(cfg.run_gps_datum, datums.datums, field="run_gps_datum")
    if cfg.decca.chain not in chains:
        raise InputError(UNKNOWN_CHAIN_MESSAGE, field="decca.chain", text=cfg.decca.chain)


def read_data_dir(data_dir: str | os.PathLike[str]) -> tuple[DatumFile, dict[str, DeccaChain]]:
    """Read ``TO_WGS84.DAT`` and ``DECCA.CHN`` from ``data_dir``; each chain's datum must be in
    the datum file (an unknown one is an InputError at the chain file's datum line)."""
    datums = read_datum_file(Path(data_dir) / DATUM_FILE)
    chains = read_chain_file(Path(data_dir) / CHAIN_FILE, known_datums=datums.datums)
    return datums, chains


def data_file_warnings(data_dir: str | os.PathLike[str]) -> tuple[str, ...]:
    """Warnings for the data files of ``data_dir`` that differ from the bundled ones."""
    found = (modified_bundled(Path(data_dir) / name) for name in (DATUM_FILE, CHAIN_FILE))
    return tuple(w for w in found if w is not None)


def load_data(cfg: RunConfig) -> tuple[DatumFile, dict[str, DeccaChain]]:
    """Read the data files of ``cfg``'s data directory and check ``cfg``'s names against them
    (:func:`read_data_dir`, :func:`check_config`)."""
    datums, chains = read_data_dir(cfg.data_dir)
    check_config(cfg, datums, chains)
    return datums, chains


def load_run_config(
    path: str | os.PathLike[str],
) -> tuple[RunConfig, tuple[DatumFile, dict[str, DeccaChain]]]:
    """Load a run configuration TOML and the data files it names, every name checked.

    The file is read once for its ``data_dir``, the data files are read from there, and it is
    read again with the datum names known, so an unknown ``datum`` or ``run_gps_datum`` is
    reported as ``FILE.toml:LINE: datum: Unknown datum !``; an unknown ``decca.chain`` is
    located the same way. Returns the configuration and ``(datums, chains)`` for
    :class:`Session`'s ``data``.
    """
    cfg = load_config(path)
    datums, chains = read_data_dir(cfg.data_dir)
    cfg = load_config(path, known_datums=datums.datums, known_chains=chains)
    return cfg, (datums, chains)


def run_inputs(cfg: RunConfig) -> list[tuple[str, Path]]:
    """The files a run of ``cfg`` reads (labelled for messages): no output may be one of them."""
    return [("the run file", cfg.run_path),
            (f"the data file {DATUM_FILE}", cfg.data_dir / DATUM_FILE),
            (f"the data file {CHAIN_FILE}", cfg.data_dir / CHAIN_FILE)]


__all__ = [
    "CHAIN_FILE",
    "DATUM_FILE",
    "check_config",
    "data_file_warnings",
    "load_data",
    "load_run_config",
    "read_data_dir",
    "run_inputs",
]

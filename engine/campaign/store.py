"""The results of a campaign on disk (``--out DIR``, docs/CAMPAIGN.md).

* ``DIR/spec.json``: the spec's path, name, hash and run count. A later call with another spec
  hash is refused (:data:`CHANGED_SPEC_MESSAGE`) unless restarted.
* ``DIR/parts/part-NNNN.jsonl``: one JSON object per finished run, appended and flushed as each
  run completes (one new part per call, so no two calls write the same file). A line cut short by
  a killed client is skipped when read; a run recorded twice counts once (the last).
* ``DIR/runs.parquet``: the table, one row per recorded run in the spec's order (scenario,
  variant, seed), typed by :data:`engine.campaign.run.COLUMNS`. Written to a temporary file and
  renamed, so it is always a whole table; rows are streamed from the parts in batches, so the
  memory it takes does not grow with the number of runs (only a small index of offsets does).
"""

from __future__ import annotations

import json
import math
import os
import shutil
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import IO, Any

import orjson

from engine.campaign.run import COLUMNS
from engine.campaign.spec import CampaignSpec, RunTask
from engine.errors import InputError

__all__ = ["CHANGED_SPEC_MESSAGE", "CampaignStore", "read_table"]

CHANGED_SPEC_MESSAGE = ("holds a campaign of another spec (the runs or their inputs changed): "
                        "give --restart to redo it, or another --out !")
SPEC_FILE = "spec.json"
TABLE_FILE = "runs.parquet"
PARTS_DIR = "parts"
TRACKS_DIR = "tracks"
BATCH_ROWS = 4096
"""Rows per Parquet row group (and the most rows held in memory while writing the table)."""


def _arrow_schema() -> Any:
    import pyarrow as pa

    kinds = {"str": pa.string(), "int": pa.int64(), "float": pa.float64()}
    return pa.schema([(name, kinds[kind]) for name, kind in COLUMNS])


class CampaignStore:
    """The ``--out`` directory of one campaign."""

    def __init__(self, out_dir: str | os.PathLike[str]) -> None:
        self.dir = Path(out_dir)
        self.parts = self.dir / PARTS_DIR
        self.table_path = self.dir / TABLE_FILE
        self.tracks = self.dir / TRACKS_DIR
        self._fh: IO[bytes] | None = None

    # ---------------------------------------------------------------- set-up
    def recorded_hash(self) -> str | None:
        """The spec hash of the campaign in the directory (None: no campaign there)."""
        try:
            data = json.loads((self.dir / SPEC_FILE).read_text(encoding="utf-8"))
        except FileNotFoundError:
            return None
        except (OSError, ValueError) as exc:
            raise InputError(f"Cannot read the campaign's {SPEC_FILE}: {exc} !",
                             file=str(self.dir / SPEC_FILE)) from None
        value = data.get("spec_hash") if isinstance(data, dict) else None
        return value if isinstance(value, str) else ""

    def open(self, spec: CampaignSpec, *, restart: bool = False, resume: bool = False) -> None:
        """Make the directory ready for ``spec``: refuse another spec's campaign unless
        ``restart`` (which removes every earlier result); ``resume`` requires a campaign to be
        there. Writes ``spec.json``."""
        if self.dir.exists() and not self.dir.is_dir():
            raise InputError("Not a directory !", file=str(self.dir), field="--out")
        recorded = self.recorded_hash()
        if resume and recorded is None:
            raise InputError("No campaign to resume here !", file=str(self.dir), field="--out")
        if recorded is not None and recorded != spec.spec_hash and not restart:
            raise InputError(CHANGED_SPEC_MESSAGE, file=str(self.dir), field="--out")
        if recorded is None and self.dir.is_dir() and any(self.dir.iterdir()) and not restart:
            raise InputError("The directory is not empty and holds no campaign !",
                             file=str(self.dir), field="--out")
        self.dir.mkdir(parents=True, exist_ok=True)
        if restart:
            for name in (PARTS_DIR, TRACKS_DIR):
                shutil.rmtree(self.dir / name, ignore_errors=True)
            self.table_path.unlink(missing_ok=True)
        self.parts.mkdir(exist_ok=True)
        if spec.tracks:
            self.tracks.mkdir(exist_ok=True)
        meta = {"spec": spec.path, "name": spec.name, "spec_hash": spec.spec_hash,
                "runs": len(spec.tasks), "scenarios": [s.label for s in spec.scenarios],
                "variants": [v.name for v in spec.variants]}
        _atomic_write(self.dir / SPEC_FILE, json.dumps(meta, indent=1).encode("utf-8"))

    # ---------------------------------------------------------------- rows
    def _part_files(self) -> list[Path]:
        return sorted(self.parts.glob("part-*.jsonl")) if self.parts.is_dir() else []

    def _index(self) -> dict[str, tuple[Path, int]]:
        """Key → (part file, byte offset) of the last whole line recorded for that run."""
        index: dict[str, tuple[Path, int]] = {}
        for part in self._part_files():
            with open(part, "rb") as fh:
                offset = 0
                for line in fh:
                    if line.endswith(b"\n"):
                        try:
                            key = orjson.loads(line).get("key")
                        except orjson.JSONDecodeError:
                            key = None
                        if isinstance(key, str):
                            index[key] = (part, offset)
                    offset += len(line)
        return index

    def finished(self) -> set[str]:
        """Keys of the runs recorded so far (ok or failed)."""
        return set(self._index())

    def append(self, row: Mapping[str, Any]) -> None:
        """Record one finished run (a line of this call's part file, flushed at once)."""
        if self._fh is None:
            n = len(self._part_files())
            while True:
                try:
                    self._fh = open(self.parts / f"part-{n:04d}.jsonl", "xb")  # noqa: SIM115
                    break
                except FileExistsError:
                    n += 1
        clean = {k: (None if isinstance(v, float) and math.isnan(v) else v)
                 for k, v in row.items()}
        self._fh.write(orjson.dumps(clean) + b"\n")
        self._fh.flush()

    def close(self) -> None:
        """Close this call's part file (synced to disk)."""
        if self._fh is not None:
            try:
                self._fh.flush()
                os.fsync(self._fh.fileno())
            finally:
                self._fh.close()
                self._fh = None

    def rows(self, tasks: Iterable[RunTask]) -> Iterator[dict[str, Any]]:
        """The recorded rows of ``tasks``, in the order of ``tasks`` (unrecorded ones left out),
        read one at a time from the parts."""
        index = self._index()
        handles: dict[Path, IO[bytes]] = {}
        try:
            for task in tasks:
                where = index.get(task.key)
                if where is None:
                    continue
                part, offset = where
                fh = handles.get(part)
                if fh is None:
                    fh = handles[part] = open(part, "rb")  # noqa: SIM115
                fh.seek(offset)
                yield _typed(orjson.loads(fh.readline()))
        finally:
            for fh in handles.values():
                fh.close()

    def write_table(self, spec: CampaignSpec) -> int:
        """Write ``runs.parquet`` from the recorded rows, in the spec's run order (atomic
        rename); returns the number of rows."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        schema = _arrow_schema()
        tmp = self.table_path.with_name(f".{TABLE_FILE}.{os.getpid()}.tmp")
        n = 0
        try:
            with pq.ParquetWriter(tmp, schema) as writer:
                batch: list[dict[str, Any]] = []
                for row in self.rows(spec.tasks):
                    batch.append(row)
                    if len(batch) >= BATCH_ROWS:
                        writer.write_table(pa.Table.from_pylist(batch, schema=schema))
                        n += len(batch)
                        batch = []
                if batch or n == 0:
                    writer.write_table(pa.Table.from_pylist(batch, schema=schema))
                    n += len(batch)
            os.replace(tmp, self.table_path)
        finally:
            tmp.unlink(missing_ok=True)
        return n


def _typed(obj: dict[str, Any]) -> dict[str, Any]:
    """A row as read back: every column present, JSON null → NaN for floats."""
    out: dict[str, Any] = {}
    for name, kind in COLUMNS:
        v = obj.get(name)
        if kind == "float":
            out[name] = math.nan if v is None else float(v)
        elif kind == "int":
            out[name] = 0 if v is None else int(v)
        else:
            out[name] = "" if v is None else str(v)
    return out


def _atomic_write(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)


def read_table(path: str | os.PathLike[str], columns: list[str] | None = None) -> Any:
    """``runs.parquet`` as a pyarrow Table (only ``columns`` if given)."""
    import pyarrow.parquet as pq

    return pq.read_table(path, columns=columns)

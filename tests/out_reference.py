"""Reference ``.OUT`` logs that the engine must keep reproducing byte for byte (issue 14).

Each case is a run configuration; its reference, ``tests/run/out_reference/NAME.digests``, has
one line per block of the ``.OUT`` log: ``header <digest>`` for everything before the first
cycle, then
``<n> <digest>`` for cycle ``n`` (its ``CYCLE`` … ``END`` lines and any ``BAD``/``CMD`` lines
after it), then ``tail <digest>``. Absolute paths of the repository are replaced by ``<ROOT>``
before hashing, so the references do not depend on where the clone is ("byte-identical apart
from header paths"). The thesis sample is also kept as whole text (``SAMPLE.OUT``) so a failure
shows the difference.

The references were written by the engine of commit 9578da6 (the last before issue 14's
per-epoch work: the same numbers as the bench's baseline f81acd7 for the 1993 runs).
Regenerate them only for a reviewed change of the output
(``python -m tests.out_reference``), and say why in the commit.
"""

from __future__ import annotations

import hashlib
import tempfile
from collections.abc import Iterator
from pathlib import Path

from engine.run.config import load_config
from engine.run.session import Session
from tests.paths import DATA, ROOT

HERE = Path(__file__).resolve().parent / "run" / "out_reference"
"""Where the reference files and the simulated dive live."""

CASES: dict[str, Path] = {
    "SAMPLE": DATA / "920917_1.toml",
    "DEMO": DATA / "DEMO.toml",
    "MARKERMEER": DATA / "nmea" / "avnav-markermeer-20160815.toml",
    "M5_DIVE30_S1": HERE / "M5_DIVE30_S1.toml",
}
"""Case name → run configuration: the thesis sample, the GPS + Decca demo (7200 epochs), a real
NMEA log (surface vessel, receiver weights) and a simulated 30-min dive (pressure, DR)."""


def replay(config: Path, out: Path) -> Path:
    """Replay every record of ``config``'s run into ``out`` with the configuration as loaded
    (no operator: ``lsq.lop_reject`` stays as the file sets it)."""
    session = Session(load_config(config), out_path=out, force=True, history=1)
    try:
        session.run()
    finally:
        session.close()
    return out


def normalised(text: str) -> str:
    """``.OUT`` text with the repository's absolute path replaced by ``<ROOT>``."""
    return text.replace(str(ROOT), "<ROOT>")


def blocks(text: str) -> Iterator[tuple[str, str]]:
    """The ``.OUT`` text cut into (label, text) blocks: header, each cycle, tail."""
    label, lines = "header", []
    for line in text.splitlines(keepends=True):
        if line.startswith("CYCLE n="):
            yield label, "".join(lines)
            label, lines = line.split()[1][2:], []
        elif line.startswith("# end") or line.startswith("SUMMARY"):
            yield label, "".join(lines)
            label, lines = "tail", []
        lines.append(line)
    yield label, "".join(lines)


def digests(text: str) -> list[str]:
    """One ``label digest`` line per block (BLAKE2b, 16 bytes)."""
    return [f"{label} {hashlib.blake2b(body.encode(), digest_size=16).hexdigest()}"
            for label, body in blocks(normalised(text))]


def write_references() -> None:
    """Replay every case with this tree's engine and (re)write the reference files."""
    with tempfile.TemporaryDirectory() as tmp:
        for name, config in CASES.items():
            text = replay(config, Path(tmp) / f"{name}.OUT").read_text(encoding="utf-8")
            (HERE / f"{name}.digests").write_text("\n".join(digests(text)) + "\n",
                                                   encoding="utf-8")
            if name == "SAMPLE":
                (HERE / "SAMPLE.OUT").write_text(normalised(text), encoding="utf-8")


if __name__ == "__main__":
    write_references()

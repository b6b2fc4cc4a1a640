"""Paths of the repository and its bundled data, shared by the test modules.

Test modules cannot import ``conftest.py``, so the constants live here:
``from tests.paths import DATA, ROOT`` (``python -m pytest`` from the repository root puts the
root on ``sys.path``). Fixtures stay in ``conftest.py``.
"""

from __future__ import annotations

import shutil
from pathlib import Path

__all__ = ["DATA", "DATA_FILES", "ROOT", "copy_data"]

ROOT = Path(__file__).resolve().parents[1]
"""The repository root."""

DATA = ROOT / "data"
"""The bundled data directory (``data/``): datum and chain files, runs, configs, scenarios."""

DATA_FILES = ("TO_WGS84.DAT", "DECCA.CHN", "920917_1.RUN", "920917_1.toml", "DEMO.RUN",
              "DEMO.toml")
"""The files :func:`copy_data` copies: both data files and the two bundled runs."""


def copy_data(target: Path) -> Path:
    """A private copy of the data directory (the console writes .OUT logs next to the .RUN)."""
    target.mkdir(parents=True, exist_ok=True)
    for name in DATA_FILES:
        shutil.copy(DATA / name, target / name)
    return target

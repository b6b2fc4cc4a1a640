"""Fixtures shared by the test modules (pytest loads this file first).

Paths (``ROOT``, ``DATA``) and ``copy_data`` live in :mod:`tests.paths`, which test modules
import (they cannot import this file).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.paths import copy_data


@pytest.fixture
def data_dir(tmp_path: Path) -> Path:
    """A private copy of the bundled data files (``data/``) in ``tmp_path/data``; a module may
    define its own ``data_dir`` instead."""
    return copy_data(tmp_path / "data")

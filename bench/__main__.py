"""``python -m bench``: run every benchmark in this folder."""

from __future__ import annotations

import importlib
import pkgutil
from pathlib import Path

for mod in sorted(m.name for m in pkgutil.iter_modules([str(Path(__file__).parent)])):
    if mod.startswith("bench_"):
        importlib.import_module(f"bench.{mod}").main()

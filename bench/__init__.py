"""Benchmarks (``make bench``): figures are printed as medians and ratios, never asserted.

The benches run on one core, as issue 14 asks and as ``uvnav`` itself runs: one OpenBLAS
thread (``OPENBLAS_NUM_THREADS=1``, set here before numpy loads, so for this process and every
process a bench starts, the baselines' included; a value already set is kept). Without it each
of numpy's and SciPy's bundled OpenBLAS libraries starts a helper thread that spins on the other
core after each call, which adds ~40 % to a replay's process CPU time (1500 demo epochs,
2026-12-04: 0.203 against 0.290 s, 5 alternating fresh processes) and nothing to its speed: the
engine's matrices (≤ 13×13) are below OpenBLAS's threading sizes, so the bits are the same.
"""

import os
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def child_env(pycache: Path | None) -> dict[str, str]:
    """The environment of a ``uvnav`` process a bench starts: this one's, with Python writing
    and reading its bytecode cache as it does by default (``PYTHONDONTWRITEBYTECODE`` dropped)
    in the folder ``pycache`` (``PYTHONPYCACHEPREFIX``; None: Python's own ``__pycache__``)."""
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    if pycache is not None:
        env["PYTHONPYCACHEPREFIX"] = str(pycache)
    return env

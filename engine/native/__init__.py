"""Optional compiled kernels of the engine (C, ``engine/native/*.c``), and how they are found.

The engine's hot scalar and small-matrix code has a compiled twin here, written against public
interfaces only (CPython's C API, numpy's C API through its headers, the kernels' own
small-matrix code in ``uvn_linalg.h``). The pure-Python engine is the reference: a twin agrees
with it to the tolerance contract of docs/PERFORMANCE.md (every logged number within 1e-9
relative or a small absolute floor, every discrete field identical), not bit for bit. The pure
path is what runs where no kernel was built or a kernel declines, with ``UVNAV_PURE=1`` in the
environment, and what the kernels are tested against (``tests/native/``).

:func:`kernel` returns a built module only when its ``SOURCE_DIGEST`` is the digest of the C
sources now in this folder, so an edited source with a stale build falls back to Python
instead of running old code (``make test`` / ``pip install -e .`` rebuild).
"""

from __future__ import annotations

import hashlib
import importlib
import os
from functools import cache
from pathlib import Path
from types import ModuleType

HERE = Path(__file__).resolve().parent
PURE_ENV = "UVNAV_PURE"
"""Set to 1 to run the pure-Python path everywhere (the kernels are then never loaded)."""


def pure_requested() -> bool:
    """True when the environment asks for the pure-Python path (``UVNAV_PURE=1``)."""
    return os.environ.get(PURE_ENV, "") not in ("", "0")


def source_digest(name: str) -> str | None:
    """BLAKE2b of ``<name>.c`` and the headers beside it (as setup.py computes it at build
    time), or None if the source is not in this folder (an installed wheel)."""
    c_file = HERE / f"{name}.c"
    if not c_file.is_file():
        return None
    h = hashlib.blake2b(digest_size=16)
    for path in [c_file, *sorted(HERE.glob("*.h"))]:
        h.update(path.name.encode())
        h.update(path.read_bytes())
    return h.hexdigest()


@cache
def _load(name: str) -> tuple[ModuleType | None, str]:
    """(module or None, why not) for ``engine.native.<name>``; imported once per process, then
    its ``_probe()`` (where it has one: numpy's C API imported and checked) run; a module that
    fails to import or whose probe fails is declined with the reason."""
    try:
        module = importlib.import_module(f"engine.native.{name}")
    except ImportError as exc:
        return None, f"not built ({exc})"
    want = source_digest(name)
    have = getattr(module, "SOURCE_DIGEST", None)
    if want is not None and have != want:
        return None, "stale build (source changed since it was compiled; run make venv)"
    probe = getattr(module, "_probe", None)
    if probe is not None:
        try:
            probe()
        except Exception as exc:  # any failure of the check: decline, the Python runs
            return None, f"declined: its first-use check failed ({type(exc).__name__}: {exc})"
    return module, "compiled"


def kernel(name: str) -> ModuleType | None:
    """The compiled module ``engine.native.<name>``, or None: not built, stale, or
    ``UVNAV_PURE=1``. Callers fall back to their pure-Python code on None."""
    if pure_requested():
        return None
    return _load(name)[0]


def bound_kernel(name: str) -> ModuleType | None:
    """:func:`kernel` (kept for callers: the kernels' small-matrix code is their own, there is
    nothing left to bind)."""
    return kernel(name)


def status(name: str) -> str:
    """One line on kernel ``name``: "compiled", "pure (UVNAV_PURE=1)", "not built (…)",
    "stale build (…)" or "declined: …" — for the bench and ``uvnav --version``."""
    if pure_requested():
        return f"pure ({PURE_ENV}=1)"
    return _load(name)[1]


def kernel_names() -> list[str]:
    """The kernels whose sources are in this folder (sorted)."""
    return sorted(p.stem for p in HERE.glob("*.c"))


def kernel_report() -> list[tuple[str, str]]:
    """(name, :func:`status`) of every kernel whose source is in this folder."""
    return [(name, status(name)) for name in kernel_names()]

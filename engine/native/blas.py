"""Addresses of the BLAS/LAPACK routines numpy and SciPy call, for the compiled kernels.

A kernel that replaces ``ndarray.dot`` or SciPy's ``dpotrf``/``dtrsm`` must call the very same
routine with the same arguments to give the same bits (OpenBLAS picks its kernel, its FMA use
and its summation order per routine and CPU). numpy's wheels bundle one OpenBLAS (64-bit
integers, symbols ``scipy_cblas_*64_``) and SciPy's another (32-bit, ``scipy_*_``); this module
finds both libraries beside the packages and returns the routines' addresses. Anything else
(another BLAS, another layout) gives None, and the kernels that need BLAS stay unused.

numpy routes ``a.dot(b)`` for float64 through ``cblas_matrixproduct`` (numpy
``_core/src/common/cblasfuncs.c``): ``cblas_dgemm`` for matrix × matrix, ``cblas_dsyrk`` for
``a.dot(a.T)``, ``cblas_dgemv`` for matrix × vector (a 1×n or n×1 operand counts as a vector)
and ``cblas_ddot`` for vector · vector, always with ``CblasRowMajor``.
"""

from __future__ import annotations

import ctypes
import importlib.util
from functools import lru_cache
from pathlib import Path

NUMPY_CBLAS = ("dgemm", "dgemv", "ddot", "dsyrk", "daxpy")
"""numpy's routines (its ILP64 OpenBLAS: ``scipy_cblas_<name>64_``, 64-bit integer arguments)."""

NUMPY_LAPACK = ("dgesv", "dgetrf", "dpotrf", "dsyevd")
"""numpy's own LAPACK (same ILP64 OpenBLAS, Fortran ``scipy_<name>_64_``), the routines
``numpy.linalg`` calls (``inv``/``solve`` → dgesv, ``det`` → dgetrf, ``cholesky`` → dpotrf,
``eigh``/``eigvalsh`` → dsyevd)."""

SCIPY_LAPACK = ("dpotrf", "dtrsm", "dgesv", "dgetrf", "dgetrs")
"""SciPy's routines (its LP64 OpenBLAS: Fortran ``scipy_<name>_``, 32-bit integer arguments),
the ones ``scipy.linalg.lapack``/``.blas`` call."""


def _libs(package: str, pattern: str) -> list[Path]:
    """Files matching ``pattern`` in ``<site-packages>/<package>.libs`` (how wheels bundle)."""
    spec = importlib.util.find_spec(package)
    if spec is None or not spec.submodule_search_locations:
        return []
    folder = Path(next(iter(spec.submodule_search_locations))).parent / f"{package}.libs"
    return sorted(folder.glob(pattern))


def _addresses(paths: list[Path], names: tuple[str, ...], symbol: str) -> dict[str, int] | None:
    """{name: address} of ``symbol.format(name)`` in the one library of ``paths``, or None."""
    if len(paths) != 1:
        return None
    try:
        lib = ctypes.CDLL(str(paths[0]))
        return {n: ctypes.cast(getattr(lib, symbol.format(n)), ctypes.c_void_p).value or 0
                for n in names}
    except (OSError, AttributeError):
        return None


@lru_cache(maxsize=1)
def numpy_cblas() -> dict[str, int] | None:
    """Addresses of numpy's ``cblas_dgemm``, ``_dgemv``, ``_ddot``, ``_dsyrk`` (ILP64), or None
    if numpy is not linked to its bundled scipy-openblas64."""
    import numpy as np

    if not _numpy_uses_bundled_openblas(np):
        return None
    return _addresses(_libs("numpy", "libscipy_openblas64_*.so"), NUMPY_CBLAS,
                      "scipy_cblas_{}64_")


@lru_cache(maxsize=1)
def numpy_lapack() -> dict[str, int] | None:
    """Addresses of numpy's Fortran ``dgesv``, ``dgetrf``, ``dpotrf``, ``dsyevd`` (ILP64), or
    None if numpy is not linked to its bundled scipy-openblas64."""
    import numpy as np

    if not _numpy_uses_bundled_openblas(np):
        return None
    return _addresses(_libs("numpy", "libscipy_openblas64_*.so"), NUMPY_LAPACK,
                      "scipy_{}_64_")


def _numpy_uses_bundled_openblas(np: object) -> bool:
    """True if numpy's build configuration names scipy-openblas64 (ILP64) as its BLAS."""
    try:
        blas = np.__config__.CONFIG["Build Dependencies"]["blas"]  # type: ignore[attr-defined]
    except (AttributeError, KeyError, TypeError):
        return False
    return (blas.get("name") in ("scipy-openblas", "scipy-openblas64")
            and "USE64BITINT" in str(blas.get("openblas configuration", "")))


@lru_cache(maxsize=1)
def scipy_lapack() -> dict[str, int] | None:
    """Addresses of SciPy's Fortran ``dpotrf``, ``dtrsm``, ``dgesv``, ``dgetrf``, ``dgetrs``
    (LP64), or None if SciPy's bundled OpenBLAS is not where its wheels keep it."""
    return _addresses(_libs("scipy", "libscipy_openblas-*.so"), SCIPY_LAPACK, "scipy_{}_")


def all_addresses() -> dict[str, int] | None:
    """numpy's CBLAS, numpy's LAPACK and SciPy's LAPACK addresses in one dict (keys
    ``np_<name>``, ``npl_<name>`` and ``sp_<name>``), or None if any is missing."""
    a, la, b = numpy_cblas(), numpy_lapack(), scipy_lapack()
    if a is None or la is None or b is None:
        return None
    return {**{f"np_{k}": v for k, v in a.items()}, **{f"npl_{k}": v for k, v in la.items()},
            **{f"sp_{k}": v for k, v in b.items()}}

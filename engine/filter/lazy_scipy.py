"""SciPy's linear algebra for the filter, loaded on first use rather than at start-up.

Importing ``scipy.linalg`` costs 0.2–0.4 s (its ``__init__`` loads SciPy's array-API layer,
which pulls in ``numpy.testing`` and ``numpy.f2py``), more than the rest of a short replay. The
filter calls two routines only, ``lapack.dpotrf`` and ``blas.dtrsm``, and those are the
functions of SciPy's compiled Fortran wrappers ``scipy.linalg._flapack`` / ``_fblas``
(``scipy.linalg.lapack`` and ``.blas`` re-export them unchanged: the same function objects).
So :data:`lapack` and :data:`blas` load those two extension modules directly from SciPy's
folder (about 0.04 s), and fall back to the public ``scipy.linalg.lapack`` / ``.blas`` should
that fail (another SciPy layout). Either way the same compiled routine runs: the same bits.
tests/filter/test_lazy_scipy.py checks that.

The first attribute read loads the module and copies its names here, so later reads are plain
module attributes (no extra cost on the per-epoch path). :func:`cho_factor` and
:func:`cho_solve` are ``scipy.linalg``'s, imported on the first call (the smoother's cold
path). Nothing here holds state beyond what an ``import`` holds.
"""

from __future__ import annotations

import importlib
import importlib.machinery
import importlib.util
import types
from pathlib import Path
from typing import Any


def _extension(name: str) -> types.ModuleType | None:
    """SciPy's compiled ``scipy.linalg.<name>`` loaded without ``scipy.linalg.__init__`` (not
    entered in ``sys.modules``), or None if it is not where SciPy keeps it."""
    spec = importlib.util.find_spec("scipy")
    if spec is None or not spec.submodule_search_locations:
        return None
    folder = Path(next(iter(spec.submodule_search_locations))) / "linalg"
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        path = folder / f"{name}{suffix}"
        if path.is_file():
            loader = importlib.machinery.ExtensionFileLoader(f"scipy.linalg.{name}", str(path))
            ext_spec = importlib.util.spec_from_loader(loader.name, loader)
            if ext_spec is None:
                return None
            module = importlib.util.module_from_spec(ext_spec)
            loader.exec_module(module)
            return module
    return None


class LazyModule(types.ModuleType):
    """Module ``name`` (or, first choice, the compiled module ``extension`` of
    ``scipy.linalg``), loaded when an attribute is first read; its names are then copied here,
    so later reads never reach :meth:`__getattr__`."""

    def __init__(self, name: str, extension: str | None = None) -> None:
        super().__init__(name)
        self._extension = extension

    def __getattr__(self, attr: str) -> Any:
        if attr.startswith("__"):
            raise AttributeError(attr)
        module: types.ModuleType | None = None
        if self._extension is not None:
            try:
                module = _extension(self._extension)
            except (ImportError, OSError):
                module = None
            if module is not None and not hasattr(module, attr):
                module = None
        if module is None:
            module = importlib.import_module(self.__name__)
        self.__dict__.update({k: v for k, v in vars(module).items() if not k.startswith("__")})
        return getattr(module, attr)


blas = LazyModule("scipy.linalg.blas", "_fblas")
lapack = LazyModule("scipy.linalg.lapack", "_flapack")


def cho_factor(a: Any, lower: bool = False, overwrite_a: bool = False,
               check_finite: bool = True) -> Any:
    """``scipy.linalg.cho_factor`` (Cholesky factor of ``a``, for :func:`cho_solve`)."""
    from scipy.linalg import cho_factor as factor

    return factor(a, lower=lower, overwrite_a=overwrite_a, check_finite=check_finite)


def cho_solve(c_and_lower: Any, b: Any, overwrite_b: bool = False,
              check_finite: bool = True) -> Any:
    """``scipy.linalg.cho_solve`` (solve a x = b from :func:`cho_factor`'s result)."""
    from scipy.linalg import cho_solve as solve

    return solve(c_and_lower, b, overwrite_b=overwrite_b, check_finite=check_finite)

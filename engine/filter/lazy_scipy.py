"""SciPy's linear algebra for the filter, imported on first use rather than at start-up.

Importing ``scipy.linalg`` costs 0.15–0.25 s (it loads SciPy's array-API layer), which the
console's first paint and a replay without a filter update do not need. :data:`blas` and
:data:`lapack` stand for ``scipy.linalg.blas`` / ``scipy.linalg.lapack``: the first attribute
read imports the real module and copies its names, so every later read is a plain module
attribute (no extra cost on the per-epoch path). :func:`cho_factor` and :func:`cho_solve` are
``scipy.linalg``'s, imported on the first call (the smoother's cold path). Nothing here holds
state beyond what an ``import`` holds.
"""

from __future__ import annotations

import importlib
import types
from typing import Any


class LazyModule(types.ModuleType):
    """Module ``name``, imported when an attribute is first read (then its names are copied
    here, so later reads never reach :meth:`__getattr__`)."""

    def __getattr__(self, attr: str) -> Any:
        if attr.startswith("__"):
            raise AttributeError(attr)
        module = importlib.import_module(self.__name__)
        self.__dict__.update(vars(module))
        return getattr(module, attr)


blas = LazyModule("scipy.linalg.blas")
lapack = LazyModule("scipy.linalg.lapack")


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

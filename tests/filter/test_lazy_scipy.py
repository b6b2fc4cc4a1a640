"""The filter's lazily loaded LAPACK/BLAS are SciPy's own routines (same bits)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np

from engine.filter import lazy_scipy
from tests.paths import ROOT


def test_the_direct_extension_is_scipys_routine() -> None:
    import scipy.linalg._fblas as fblas
    import scipy.linalg._flapack as flapack
    from scipy.linalg import blas, lapack

    assert lapack.dpotrf is flapack.dpotrf and blas.dtrsm is fblas.dtrsm
    direct = lazy_scipy._extension("_flapack")
    assert direct is not None and direct.dpotrf.__doc__ == flapack.dpotrf.__doc__


def test_same_bits_as_scipy_linalg() -> None:
    from scipy.linalg import blas, lapack

    rng = np.random.default_rng(14)
    for n in (1, 2, 3, 5, 8, 20):
        a = rng.normal(size=(n, n))
        s = a @ a.T + n * np.eye(n)
        b = rng.normal(size=(n, 4))
        L1, i1 = lazy_scipy.lapack.dpotrf(s, lower=1, clean=1)
        L2, i2 = lapack.dpotrf(s, lower=1, clean=1)
        assert i1 == i2 == 0 and np.array_equal(L1, L2)
        assert np.array_equal(lazy_scipy.blas.dtrsm(1.0, L1, b, lower=1),
                              blas.dtrsm(1.0, L2, b, lower=1))


def test_cho_wrappers() -> None:
    from scipy.linalg import cho_factor, cho_solve

    s = np.array([[4.0, 1.0], [1.0, 3.0]])
    b = np.array([1.0, 2.0])
    assert np.array_equal(lazy_scipy.cho_solve(lazy_scipy.cho_factor(s, lower=True), b),
                          cho_solve(cho_factor(s, lower=True), b))


def test_a_replay_loads_no_scipy_linalg_package() -> None:
    """The thesis sample replays (with filter updates) without ``scipy.linalg.__init__``."""
    code = ("import sys; from uvnav_tui.cli.main import main; "
            "rc = main(['replay', 'data/920917_1.RUN', '--no-out']); "
            "sys.exit(3 if 'scipy.linalg' in sys.modules else rc)")
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True)
    assert done.returncode == 0, done.stderr.decode()

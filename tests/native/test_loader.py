"""The compiled kernels are found, refused when stale, and built wherever a compiler exists."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

import engine.native as native
from engine.native import blas


def test_every_kernel_is_compiled_where_a_compiler_exists(monkeypatch: pytest.MonkeyPatch):
    """`make test` builds every engine/native/*.c (setup.py); on a machine with cc, a kernel
    that is not "compiled" means the speed-up silently fell back to Python."""
    monkeypatch.delenv(native.PURE_ENV, raising=False)
    if shutil.which("cc") is None and shutil.which("gcc") is None:
        pytest.skip("no C compiler here: the pure-Python path is used, by design")
    for name in native.kernel_names():
        assert native.status(name) == "compiled", name


BUNDLED = ("scipy-openblas", "scipy-openblas64")
"""The BLAS names numpy's and SciPy's wheels report for the OpenBLAS they bundle."""


def _skip_without_bundled_openblas(scipy_too: bool = False) -> None:
    """Skip where numpy (and, ``scipy_too``, SciPy) is not built on its bundled OpenBLAS: a
    build from source against another BLAS, where the kernels find no routine addresses and
    stay unused by design (docs/PERFORMANCE.md, "Compiled kernels")."""
    name = np.__config__.CONFIG["Build Dependencies"]["blas"].get("name")
    if name not in BUNDLED:
        pytest.skip(f"numpy is built against {name}, not the bundled OpenBLAS")
    if scipy_too:
        import scipy

        sp_name = scipy.show_config(mode="dicts")["Build Dependencies"]["blas"]["name"]
        if sp_name not in BUNDLED:
            pytest.skip(f"SciPy is built against {sp_name}, not the bundled OpenBLAS")


def test_every_built_kernel_is_used_with_the_bundled_openblas(monkeypatch: pytest.MonkeyPatch):
    """Built is not enough: a stage may still refuse its kernel on this machine (until
    2026-12-04 the lsq kernel was refused on every AVX-512 CPU and the fix ran in Python while
    ``status`` said "compiled"). With numpy's and SciPy's wheels (their bundled OpenBLAS), the
    only ground for a refusal left, every built kernel must be in use."""
    from engine.run import kernels

    monkeypatch.delenv(native.PURE_ENV, raising=False)
    _skip_without_bundled_openblas(scipy_too=True)
    import engine.lsq.adjustment  # noqa: F401  (registers the lsq kernel's result classes)
    import engine.lsq.confidence  # noqa: F401

    report = dict(kernels.kernel_report())
    for name in native.kernel_names():
        if native.status(name) == "compiled":
            assert report[name] == "compiled", (name, report[name])


def test_pure_env_turns_every_kernel_off(monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setenv(native.PURE_ENV, "1")
    for name in native.kernel_names():
        assert native.kernel(name) is None
        assert native.status(name) == f"pure ({native.PURE_ENV}=1)"


def test_a_stale_build_is_refused(monkeypatch: pytest.MonkeyPatch):
    """A module whose SOURCE_DIGEST is not that of the source in the tree is not used."""
    names = native.kernel_names()
    if not names:
        pytest.skip("no kernel sources")
    name = names[0]
    native._load.cache_clear()
    monkeypatch.setattr(native, "source_digest", lambda n: "0" * 32)
    try:
        mod, why = native._load(name)
        assert mod is None and why.startswith(("stale build", "not built"))
    finally:
        native._load.cache_clear()


def test_the_routine_addresses_are_found_for_the_bundled_openblas():
    """numpy's and SciPy's wheels bundle OpenBLAS; the kernels need both libraries' routines."""
    _skip_without_bundled_openblas()
    addresses = blas.all_addresses()
    assert addresses is not None
    assert set(addresses) == ({f"np_{n}" for n in blas.NUMPY_CBLAS}
                              | {f"npl_{n}" for n in blas.NUMPY_LAPACK}
                              | {f"sp_{n}" for n in blas.SCIPY_LAPACK})
    assert all(a > 0 for a in addresses.values())

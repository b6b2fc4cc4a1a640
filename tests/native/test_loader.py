"""The compiled kernels are found, refused when stale, and built wherever a compiler exists."""

from __future__ import annotations

import shutil

import pytest

import engine.native as native


def test_every_kernel_is_compiled_where_a_compiler_exists(monkeypatch: pytest.MonkeyPatch):
    """`make test` builds every engine/native/*.c (setup.py); on a machine with cc, a kernel
    that is not "compiled" means the speed-up silently fell back to Python."""
    monkeypatch.delenv(native.PURE_ENV, raising=False)
    if shutil.which("cc") is None and shutil.which("gcc") is None:
        pytest.skip("no C compiler here: the pure-Python path is used, by design")
    for name in native.kernel_names():
        assert native.status(name) == "compiled", name


def test_a_kernel_failing_its_first_use_check_is_declined(monkeypatch: pytest.MonkeyPatch):
    """A kernel whose ``_probe()`` raises is not handed out, and its status says why."""
    import types

    fake = types.ModuleType("engine.native.fake")

    def probe() -> None:
        raise RuntimeError("numpy's C API is not what this build expects")

    fake._probe = probe  # type: ignore[attr-defined]
    monkeypatch.delenv(native.PURE_ENV, raising=False)
    monkeypatch.setitem(__import__("sys").modules, "engine.native.fake", fake)
    monkeypatch.setattr(native, "source_digest", lambda n: None)
    native._load.cache_clear()
    try:
        assert native.kernel("fake") is None
        assert native.status("fake") == ("declined: its first-use check failed (RuntimeError: "
                                         "numpy's C API is not what this build expects)")
    finally:
        native._load.cache_clear()


def test_no_kernel_reaches_into_internals():
    """The kernels use public interfaces only: no private CPython symbol (``_Py…``), no type
    version tag, no member offset, no numpy struct field, no BLAS looked up in a wheel."""
    import re

    banned = re.compile(r"\b_Py[A-Za-z_]|tp_version_tag|d_member|->offset\b|_ARRAY_API|"
                        r"PyArrayObject_fields|ctypes|dlsym|geod_inverse|libscipy_openblas|"
                        r"libproj|uvn_blas|PyLong_AsVoidPtr")
    for path in sorted(native.HERE.glob("*.[ch]")):
        code = "\n".join(line for line in path.read_text().splitlines()
                         if not line.lstrip().startswith(("*", "/*")))
        hit = banned.search(code)
        assert hit is None, f"{path.name}: {hit.group(0)}"


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

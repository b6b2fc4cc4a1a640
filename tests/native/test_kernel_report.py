"""``uvnav --version`` says "compiled" only for a kernel the engine uses on this machine."""

from __future__ import annotations

import pytest

import engine.lsq.adjustment  # noqa: F401  (registers the lsq kernel's result classes)
import engine.lsq.confidence  # noqa: F401
from engine import native
from engine.lsq import _kernel
from engine.run import kernels
from uvnav_tui.cli.main import version_text

needs_lsq = pytest.mark.skipif(native.kernel("lsq") is None, reason="lsq kernel not built")


@needs_lsq
def test_lsq_reported_as_used_exactly_when_the_fix_uses_it() -> None:
    _kernel.reset()
    try:
        used = _kernel.kernel() is not None
    finally:
        _kernel.reset()
    line = dict(kernels.kernel_report())["lsq"]
    assert (line == "compiled") == used
    assert f"lsq: {line}" in version_text()


def test_every_kernel_is_in_the_report() -> None:
    assert [n for n, _ in kernels.kernel_report()] == native.kernel_names()


def test_pure_path_reported_as_such(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(native.PURE_ENV, "1")
    assert all(why == f"pure ({native.PURE_ENV}=1)" for _, why in kernels.kernel_report())

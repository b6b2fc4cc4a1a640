"""``uvnav --version`` says "compiled" only for a kernel the engine uses on this machine."""

from __future__ import annotations

import pytest

from engine import native
from engine.fast import lsq as fast_lsq
from engine.run import kernels
from uvnav_tui.cli.main import version_text

needs_lsq = pytest.mark.skipif(native.kernel("lsq") is None, reason="lsq kernel not built")


@needs_lsq
def test_lsq_reported_as_used_exactly_when_the_fix_uses_it() -> None:
    used = fast_lsq.kernel() is not None
    line = dict(kernels.kernel_report())["lsq"]
    assert (line == "compiled") == used
    assert f"lsq: {line}" in version_text()


def test_every_kernel_is_in_the_report() -> None:
    assert [n for n, _ in kernels.kernel_report()] == native.kernel_names()


def test_pure_path_reported_as_such(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(native.PURE_ENV, "1")
    assert all(why == f"pure ({native.PURE_ENV}=1)" for _, why in kernels.kernel_report())

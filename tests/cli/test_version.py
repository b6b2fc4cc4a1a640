"""``uvnav --version`` names the version and says, per compiled kernel, whether it is used."""

from __future__ import annotations

import pytest

from engine import native
from uvnav_tui.cli.main import main


def test_version_lists_every_kernel_with_its_status(capsys: pytest.CaptureFixture[str],
                                                    monkeypatch: pytest.MonkeyPatch):
    monkeypatch.delenv(native.PURE_ENV, raising=False)
    assert main(["--version"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("uvnav 0.1.0\n")
    for name in native.kernel_names():
        assert f"  {name}: {native.status(name)}" in out


def test_version_says_when_the_pure_path_is_forced(capsys: pytest.CaptureFixture[str],
                                                  monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setenv(native.PURE_ENV, "1")
    assert main(["--version"]) == 0
    out = capsys.readouterr().out
    for name in native.kernel_names():
        assert f"  {name}: pure (UVNAV_PURE=1)" in out

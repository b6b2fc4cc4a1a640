"""The ``.OUT`` logs stay byte-identical to the references (issue 14: "output unchanged").

The speed work of issue 14 must not change a single byte of what the engine writes, apart from
header paths. The references (see :mod:`tests.out_reference`) are what the engine before that
work writes on this machine's arithmetic (numpy's OpenBLAS picks its kernels by CPU); each
case here replays a run with this tree and compares block by block, so a failure names the
first cycle that differs. The thesis sample is compared as whole text, so its failure shows
the lines.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.out_reference import CASES, digests, normalised, reference_dir, replay
from tests.paths import ROOT


def _references() -> Path:
    """This machine's reference folder; skipped (with the reason) only where there are no
    committed references for its arithmetic and no git history to make them from."""
    try:
        return reference_dir()
    except RuntimeError as exc:
        if "no git history" in str(exc):
            pytest.skip(str(exc))  # a tarball without .git on an unlisted CPU: nothing to compare
        raise


@pytest.mark.parametrize("name", sorted(CASES))
def test_out_log_is_byte_identical(name: str, tmp_path: Path) -> None:
    refs = _references()
    text = replay(CASES[name], tmp_path / f"{name}.OUT").read_text(encoding="utf-8")
    if name == "SAMPLE":
        assert normalised(text) == (refs / "SAMPLE.OUT").read_text(encoding="utf-8")
    want = (refs / f"{name}.digests").read_text(encoding="utf-8").splitlines()
    got = digests(text)
    first = next((i for i, (g, w) in enumerate(zip(got, want, strict=False)) if g != w), None)
    assert first is None, (
        f"{name}: block {got[first].split()[0]} of the .OUT differs from the reference "
        f"(python -m tests.out_reference rewrites the references: only for a reviewed change)")
    assert len(got) == len(want), f"{name}: {len(got)} blocks, the reference has {len(want)}"


_PURE_CHECK = """
import sys
from pathlib import Path
from engine import native
from tests.out_reference import CASES, digests, replay
refs = Path(sys.argv[2])
assert all(native.kernel(n) is None for n in native.kernel_names())
bad = []
for name, config in sorted(CASES.items()):
    got = digests(replay(config, Path(sys.argv[1]) / (name + ".OUT")).read_text(encoding="utf-8"))
    want = (refs / (name + ".digests")).read_text(encoding="utf-8").splitlines()
    if got != want:
        first = next(i for i, (g, w) in enumerate(zip(got + [""], want + [""])) if g != w)
        bad.append(f"{name}: block {first} differs")
print("; ".join(bad) or "same")
sys.exit(1 if bad else 0)
"""


def test_out_logs_are_byte_identical_on_the_pure_python_path(tmp_path: Path) -> None:
    """With ``UVNAV_PURE=1`` (no compiled kernel, engine/native) every case gives the same
    bytes too: the kernels and the Python they mirror are both held to the references."""
    env = {**os.environ, "UVNAV_PURE": "1"}
    done = subprocess.run([sys.executable, "-c", _PURE_CHECK, str(tmp_path), str(_references())],
                          cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr

"""Reference ``.OUT`` logs that the engine must keep reproducing byte for byte (issue 14).

Each case is a run configuration; its reference, ``NAME.digests``, has one line per block of
the ``.OUT`` log: ``header <digest>`` for everything before the first cycle, then ``<n>
<digest>`` for cycle ``n`` (its ``CYCLE`` … ``END`` lines and any ``BAD``/``CMD`` lines after
it), then ``tail <digest>``. Absolute paths of the repository are replaced by ``<ROOT>`` before
hashing, so the references do not depend on where the clone is ("byte-identical apart from
header paths"). The thesis sample is also kept as whole text (``SAMPLE.OUT``) so a failure
shows the difference.

The references are what the engine of commit ``REFERENCE_REV`` (9578da6, the last before issue
14's per-epoch work) writes **on this machine's arithmetic**: numpy and SciPy hand matrix
products and factorisations to their bundled OpenBLAS, which picks its kernels (FMA use,
summation order) by CPU, so the last bits of a run differ between, say, an AVX-512 and an AVX2
machine, for the old engine as for the new. References are therefore kept per
:func:`arithmetic_key` (OpenBLAS core of numpy and of SciPy, numpy's SIMD level, both
versions): committed ones in ``out_reference/<key>/``, and for any other machine they are made
on first use by replaying the cases with the engine of ``REFERENCE_REV`` taken from the git
history (``git archive``, cached in ``out_reference/.generated/``, not committed). Write the
committed ones for this machine with ``python -m tests.out_reference`` (the old engine, never
this tree's).
"""

from __future__ import annotations

import ctypes
import hashlib
import io
import os
import subprocess
import sys
import tarfile
import tempfile
from collections.abc import Iterator
from functools import cache
from pathlib import Path

from engine.run.config import load_config
from engine.run.session import Session
from tests.paths import DATA, ROOT

HERE = Path(__file__).resolve().parent / "run" / "out_reference"
"""Where the reference files and the simulated dive live."""
GENERATED = HERE / ".generated"
"""Cache of references made on this machine from ``REFERENCE_REV`` (git-ignored)."""
REFERENCE_REV = "9578da6"
"""The engine whose output is the reference: the last commit before issue 14's work."""

CASES: dict[str, Path] = {
    "SAMPLE": DATA / "920917_1.toml",
    "DEMO": DATA / "DEMO.toml",
    "MARKERMEER": DATA / "nmea" / "avnav-markermeer-20160815.toml",
    "M5_DIVE30_S1": HERE / "M5_DIVE30_S1.toml",
}
"""Case name → run configuration: the thesis sample, the GPS + Decca demo (7200 epochs), a real
NMEA log (surface vessel, receiver weights) and a simulated 30-min dive (pressure, DR)."""


def replay(config: Path, out: Path) -> Path:
    """Replay every record of ``config``'s run into ``out`` with the configuration as loaded
    (no operator: ``lsq.lop_reject`` stays as the file sets it)."""
    session = Session(load_config(config), out_path=out, force=True, history=1)
    try:
        session.run()
    finally:
        session.close()
    return out


def normalised(text: str) -> str:
    """``.OUT`` text with the repository's absolute path replaced by ``<ROOT>``."""
    return text.replace(str(ROOT), "<ROOT>")


def blocks(text: str) -> Iterator[tuple[str, str]]:
    """The ``.OUT`` text cut into (label, text) blocks: header, each cycle, tail."""
    label, lines = "header", []
    for line in text.splitlines(keepends=True):
        if line.startswith("CYCLE n="):
            yield label, "".join(lines)
            label, lines = line.split()[1][2:], []
        elif line.startswith("# end") or line.startswith("SUMMARY"):
            yield label, "".join(lines)
            label, lines = "tail", []
        lines.append(line)
    yield label, "".join(lines)


def digests(text: str) -> list[str]:
    """One ``label digest`` line per block (BLAKE2b, 16 bytes)."""
    return [f"{label} {hashlib.blake2b(body.encode(), digest_size=16).hexdigest()}"
            for label, body in blocks(normalised(text))]


def _openblas_core(package: str, pattern: str, symbol: str) -> str:
    """The OpenBLAS core type a wheel's bundled library chose for this CPU (e.g. "Haswell",
    "SkylakeX"), or "other-blas" if the package is not linked that way."""
    spec_dirs = [Path(p) for p in sys.path if p]
    for base in spec_dirs:
        libs = sorted((base / f"{package}.libs").glob(pattern))
        if len(libs) == 1:
            try:
                fn = getattr(ctypes.CDLL(str(libs[0])), symbol)
            except (OSError, AttributeError):
                return "other-blas"
            fn.restype = ctypes.c_char_p
            return (fn() or b"unknown").decode().strip()
    return "other-blas"


@cache
def arithmetic_key() -> str:
    """What decides the last bits of a replay here: numpy's and SciPy's versions and OpenBLAS
    core types, and the highest SIMD level numpy dispatches to (e.g.
    ``numpy2.4.6-Haswell_scipy1.17.1-Haswell_X86_V3``)."""
    import numpy as np
    import scipy
    from numpy._core._multiarray_umath import __cpu_features__ as cpu  # type: ignore

    simd = next((lvl for lvl in ("X86_V4", "X86_V3", "X86_V2") if cpu.get(lvl)),
                "ASIMD" if cpu.get("ASIMD") else "baseline")
    np_core = _openblas_core("numpy", "libscipy_openblas64_*.so",
                             "scipy_openblas_get_corename64_")
    sp_core = _openblas_core("scipy", "libscipy_openblas-*.so", "scipy_openblas_get_corename")
    return f"numpy{np.__version__}-{np_core}_scipy{scipy.__version__}-{sp_core}_{simd}"


_OLD_ENGINE_RUNNER = """
import sys
from pathlib import Path
tree, out_dir = Path(sys.argv[1]).resolve(), Path(sys.argv[2])
import engine
assert Path(engine.__file__).resolve().is_relative_to(tree), engine.__file__
from engine.run.config import load_config
from engine.run.session import Session
for arg in sys.argv[3:]:
    name, config = arg.split("=", 1)
    s = Session(load_config(Path(config)), out_path=out_dir / (name + ".OUT"), force=True,
                history=1)
    try:
        s.run()
    finally:
        s.close()
"""
"""Replays each ``NAME=config`` with the engine of the tree given first (on ``PYTHONPATH``)."""


def _write_reference_files(folder: Path, texts: dict[str, str]) -> None:
    """``NAME.digests`` for every case (and ``SAMPLE.OUT``) in ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in texts.items():
        (folder / f"{name}.digests").write_text("\n".join(digests(text)) + "\n",
                                                encoding="utf-8")
        if name == "SAMPLE":
            (folder / "SAMPLE.OUT").write_text(normalised(text), encoding="utf-8")


def replay_reference_engine() -> dict[str, str]:
    """The ``.OUT`` text of every case as the engine of ``REFERENCE_REV`` writes it here (its
    tree from ``git archive``, replayed in a fresh process with this tree's run files).
    Raises RuntimeError if the git history is not available."""
    try:
        tar = subprocess.run(["git", "archive", REFERENCE_REV, "engine"], cwd=ROOT,
                             capture_output=True, check=True, timeout=120).stdout
    except (OSError, subprocess.SubprocessError) as exc:
        raise RuntimeError(f"no git history with {REFERENCE_REV} to make the references "
                           f"for {arithmetic_key()}: {exc}") from exc
    with tempfile.TemporaryDirectory() as tmp:
        tree, outs = Path(tmp) / "tree", Path(tmp) / "out"
        outs.mkdir()
        with tarfile.open(fileobj=io.BytesIO(tar)) as tf:
            tf.extractall(tree, filter="data")
        env = {**os.environ, "PYTHONPATH": str(tree), "UVNAV_PURE": "1"}
        cases = [f"{name}={config}" for name, config in CASES.items()]
        done = subprocess.run([sys.executable, "-c", _OLD_ENGINE_RUNNER, str(tree), str(outs),
                               *cases], cwd=tree, env=env, capture_output=True, text=True,
                              timeout=1800)
        if done.returncode != 0:
            raise RuntimeError(f"the reference engine {REFERENCE_REV} failed:\n{done.stderr}")
        return {name: (outs / f"{name}.OUT").read_text(encoding="utf-8") for name in CASES}


def reference_dir() -> Path:
    """The folder with this machine's references: committed (``out_reference/<key>``) or made
    here on first use from ``REFERENCE_REV`` (``out_reference/.generated/<rev>-<key>``)."""
    key = arithmetic_key()
    committed = HERE / key
    if (committed / "DEMO.digests").is_file():
        return committed
    generated = GENERATED / f"{REFERENCE_REV}-{key}"
    if not all((generated / f"{name}.digests").is_file() for name in CASES):
        _write_reference_files(generated, replay_reference_engine())
    return generated


def write_references() -> None:
    """(Re)write the committed references for this machine's arithmetic from the engine of
    ``REFERENCE_REV`` (never from this tree: the references are the old engine's output)."""
    _write_reference_files(HERE / arithmetic_key(), replay_reference_engine())


if __name__ == "__main__":
    write_references()

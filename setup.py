"""Build the optional compiled kernels of the engine (``engine/native/*.c``).

Every ``engine/native/<name>.c`` becomes the extension module ``engine.native.<name>``. They are
optional: if a kernel does not compile (no C compiler, no Python headers), the install goes on
and the engine uses its pure-Python path, the reference the kernels agree with to the tolerance
contract of docs/PERFORMANCE.md.

The kernels use only public interfaces: CPython's C API and numpy's C API through numpy's own
headers (``numpy.get_include()``; numpy is a build requirement in pyproject.toml). Flags:
``-ffp-contract=off`` and no ``-ffast-math`` keep each operation the one written (no fused
multiply-add, no reassociation), so results stay close to the Python's. Each module is built
with ``UVN_SOURCE_DIGEST``, the BLAKE2b of its source and the headers beside it;
:func:`engine.native.kernel` refuses a module whose digest is not that of the sources in the
tree (a stale build after an edit).
"""

from __future__ import annotations

import hashlib
import sys
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

NATIVE = Path("engine") / "native"
CFLAGS = ["-O2", "-std=c11", "-ffp-contract=off", "-fno-fast-math", "-fno-strict-aliasing",
          "-Wall", "-Wno-unused-function"]


def source_digest(c_file: Path) -> str:
    """BLAKE2b (16 bytes, hex) of a kernel's C source and every header in its folder."""
    h = hashlib.blake2b(digest_size=16)
    for path in [c_file, *sorted(c_file.parent.glob("*.h"))]:
        h.update(path.name.encode())
        h.update(path.read_bytes())
    return h.hexdigest()


class OptionalBuildExt(build_ext):
    """build_ext that warns instead of failing: a kernel that cannot be built is left out."""

    def build_extension(self, ext: Extension) -> None:  # noqa: D102
        try:
            super().build_extension(ext)
        except Exception as exc:  # compiler missing or failing: pure Python is used instead
            print(f"warning: compiled kernel {ext.name} not built ({exc}); "
                  "the engine uses its pure-Python path", file=sys.stderr)


def numpy_include() -> list[str]:
    """numpy's C headers (the kernels read and make arrays through numpy's C API), or none
    when numpy is not importable at build time (then the kernels fail to build: pure Python)."""
    try:
        import numpy
    except ImportError:
        print("warning: numpy not importable at build time: the compiled kernels that use "
              "numpy's C API will not build", file=sys.stderr)
        return []
    return [numpy.get_include()]


def extensions() -> list[Extension]:
    """One extension per C file in engine/native."""
    include = numpy_include()
    return [
        Extension(
            f"engine.native.{c.stem}",
            sources=[str(c)],
            define_macros=[("UVN_SOURCE_DIGEST", f'"{source_digest(c)}"')],
            include_dirs=include,
            extra_compile_args=CFLAGS,
            depends=[str(h) for h in sorted(NATIVE.glob("*.h"))],
        )
        for c in sorted(NATIVE.glob("*.c"))
    ]


setup(ext_modules=extensions(), cmdclass={"build_ext": OptionalBuildExt})

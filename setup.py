"""Build the optional compiled kernels of the engine (``engine/native/*.c``).

Every ``engine/native/<name>.c`` becomes the extension module ``engine.native.<name>``. They are
optional: if a kernel does not compile (no C compiler, no Python headers), the install goes on
and the engine uses its pure-Python path, which gives the same bits (docs/PERFORMANCE.md).

Flags: ``-ffp-contract=off`` so the compiler never fuses a*b+c into one FMA (Python and numpy's
elementwise loops round the product first: a fused result would change the last bit), and no
``-ffast-math`` (no reassociation). Each module is built with ``UVN_SOURCE_DIGEST``, the BLAKE2b
of its source and the headers beside it; :func:`engine.native.kernel` refuses a module whose
digest is not that of the sources in the tree (a stale build after an edit).
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


def extensions() -> list[Extension]:
    """One extension per C file in engine/native."""
    return [
        Extension(
            f"engine.native.{c.stem}",
            sources=[str(c)],
            define_macros=[("UVN_SOURCE_DIGEST", f'"{source_digest(c)}"')],
            extra_compile_args=CFLAGS,
            depends=[str(h) for h in sorted(NATIVE.glob("*.h"))],
        )
        for c in sorted(NATIVE.glob("*.c"))
    ]


setup(ext_modules=extensions(), cmdclass={"build_ext": OptionalBuildExt})

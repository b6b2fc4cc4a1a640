"""Which compiled kernels the engine uses on this machine, for ``uvnav --version``.

:func:`engine.native.kernel_report` says of each kernel whether it is built, current and passed
its first-use check ("compiled"), or why not (not built, stale, declined, ``UVNAV_PURE=1``);
a kernel that is not "compiled" is not used and the pure-Python reference runs in its place.
"""

from __future__ import annotations

from engine import native


def kernel_report() -> list[tuple[str, str]]:
    """(name, :func:`engine.native.status`) of every kernel whose source is in engine/native."""
    return native.kernel_report()

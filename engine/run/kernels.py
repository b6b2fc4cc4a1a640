"""Which compiled kernels the engine uses on this machine, for ``uvnav --version``.

:func:`engine.native.kernel_report` says whether each kernel is built and current; a built
kernel can still stay unused where its results could differ from the Python's: the lsq kernel
and the filter kernels' updates where numpy's (and SciPy's) bundled OpenBLAS routines are not
found (docs/PERFORMANCE.md, "Compiled kernels"). This module
asks the stages that decide, so the report says "compiled" only for a kernel in use.
"""

from __future__ import annotations

from engine import native

NOT_USED = "compiled, not used here: {reason}; the Python runs instead (same results)"
"""The report line of a built kernel its stage does not use."""


def unused_reason(name: str) -> str | None:
    """Why built kernel ``name`` is not used on this machine, or None: a part of
    :mod:`engine.fast` on it that declined (its first-use probe), or its stage's own check."""
    from engine import fast

    probe = [why for _part, kernel, why in fast.declined() if kernel == name]
    if probe:
        return probe[0]
    if name == "lsq":
        from engine.fast import lsq

        return lsq.unused_reason()
    if name in ("kalman_predict", "kalman_update") and native.bound_kernel(name) is None:
        return "numpy's and SciPy's bundled OpenBLAS routines not found (the updates)"
    return None


def kernel_report() -> list[tuple[str, str]]:
    """(name, status) of every kernel: :func:`engine.native.status`, or :data:`NOT_USED` with
    the reason for a built kernel that its stage does not use here."""
    out = []
    for name, why in native.kernel_report():
        reason = unused_reason(name) if why == "compiled" else None
        out.append((name, why if reason is None else NOT_USED.format(reason=reason)))
    return out

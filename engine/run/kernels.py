"""Which compiled kernels the engine uses on this machine, for ``uvnav --version``.

:func:`engine.native.kernel_report` says of each kernel whether it is built, current and passed
its own first-use check ("compiled"), or why not (not built, stale, declined, ``UVNAV_PURE=1``).
A compiled kernel can still stay unused for a run: the parts of :mod:`engine.fast` on it check
their numbers against the reference on first use (within the tolerance contract of
docs/PERFORMANCE.md) and a part that fails runs the reference. This module asks
:func:`engine.fast.declined`, so the report says "compiled" only for a kernel in use.
"""

from __future__ import annotations

from engine import native

NOT_USED = ("compiled, not used here: {reason}; the Python runs instead "
            "(the reference; docs/PERFORMANCE.md)")
"""The report line of a built kernel a part of the run does not use."""


def unused_reason(name: str) -> str | None:
    """Why built kernel ``name`` is not used on this machine, or None: a part of
    :mod:`engine.fast` on it that declined (its first-use probe)."""
    from engine import fast

    probe = [why for _part, kernel, why in fast.declined() if kernel == name]
    return probe[0] if probe else None


def kernel_report() -> list[tuple[str, str]]:
    """(name, status) of every kernel: :func:`engine.native.status`, or :data:`NOT_USED` with
    the reason for a built kernel that a part of the run does not use here."""
    out = []
    for name, why in native.kernel_report():
        reason = unused_reason(name) if why == "compiled" else None
        out.append((name, why if reason is None else NOT_USED.format(reason=reason)))
    return out

"""Frozen dataclasses made in one compiled call (``engine.native.runparse``).

A frozen dataclass's generated ``__init__`` sets each field with ``object.__setattr__``; the
kernel's ``make`` (``make_attrs`` for a plain one, with an instance dict) does the same
``object.__setattr__`` (``PyObject_GenericSetAttr``) for every field positionally, in one call
without the Python frames: the same instance. Where the kernel is not built these
give the class itself (or None), so a caller can always call what it gets.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import fields
from functools import partial
from typing import Any

from engine import native


def slots_maker(cls: type) -> Callable[..., Any]:
    """A constructor of the frozen slots dataclass ``cls`` taking every field positionally:
    ``engine.native.runparse.make`` bound to it, or ``cls`` itself (no kernel)."""
    kernel = native.kernel("runparse")
    if kernel is None:
        return cls
    return partial(kernel.make, cls, tuple(f.name for f in fields(cls)))


def attrs_maker(cls: type) -> Callable[..., Any] | None:
    """``engine.native.runparse.make_attrs`` bound to the plain frozen dataclass ``cls`` and
    its field names (the same instance as ``object.__new__`` plus its ``__dict__`` filled
    makes); None where the kernel is not in use."""
    kernel = native.kernel("runparse")
    if kernel is None or not hasattr(kernel, "make_attrs"):
        return None
    return partial(kernel.make_attrs, cls, tuple(f.name for f in fields(cls)))


def runparse_function(name: str) -> Any:
    """The function ``name`` of the compiled ``engine.native.runparse`` (None: the kernel not
    in use, or a build without it)."""
    return getattr(native.kernel("runparse"), name, None)

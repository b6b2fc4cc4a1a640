"""Completing a file path as it is typed (the run-file field): Tab completes, as in a shell, and
the completion shows in grey ahead of the cursor (→ accepts it).

Only text that looks like a path is completed (it has a ``/`` or starts with ``~``): a bare run
name (``DEMO``) is the thesis' field, where Tab goes on to the next field.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from textual.suggester import Suggester

MAX_ENTRIES = 5000
"""A folder's entries read at most for one completion (a huge folder must not stall typing)."""


def is_path_like(text: str) -> bool:
    """True for text typed as a path: it has a ``/`` or starts with ``~``."""
    return "/" in text or text.startswith("~")


def complete_path(text: str, bases: Sequence[Path]) -> str | None:
    """``text`` extended by the longest completion the file system allows (a folder completed
    in full gets its ``/``), or None if nothing can be added.  A relative path is completed in
    the first of ``bases`` where its folder exists.  Hidden entries only when the typed name
    starts with a dot."""
    if not is_path_like(text):
        return None
    head, _, prefix = text.rpartition("/")
    folder_text = head + "/" if head or text.startswith("/") else ""
    folder = Path(os.path.expanduser(folder_text or ".")) if folder_text else None
    if folder is None:  # "~name"
        return None
    if not folder.is_absolute():
        folder = next((b / folder for b in bases if (b / folder).is_dir()), None)
        if folder is None:
            return None
    try:
        with os.scandir(folder) as it:
            names = []
            for n, entry in enumerate(it):
                if n >= MAX_ENTRIES:
                    break
                if entry.name.startswith(prefix) and (prefix.startswith(".")
                                                       or not entry.name.startswith(".")):
                    names.append((entry.name, entry.is_dir()))
    except OSError:
        return None
    if not names:
        return None
    common = os.path.commonprefix([n for n, _d in names])
    if len(names) == 1 and names[0][1]:
        common += "/"
    return folder_text + common if len(common) > len(prefix) else None


class PathSuggester(Suggester):
    """The grey completion of :func:`complete_path` in an ``Input``."""

    def __init__(self, bases: Sequence[Path]) -> None:
        super().__init__(use_cache=False, case_sensitive=True)
        self.bases = list(bases)

    async def get_suggestion(self, value: str) -> str | None:
        """The completed text, if any."""
        return complete_path(value, self.bases)

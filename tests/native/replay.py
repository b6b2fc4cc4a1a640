"""One short replay for the kernel tests: the values a real run hands to a kernel."""

from __future__ import annotations

import dataclasses
import tempfile
from collections.abc import Iterable
from pathlib import Path

import pytest

import engine.run.parts as parts_mod
from engine.run.config import load_config
from engine.run.session import Session
from tests.paths import DATA


def replay(max_cycles: int | None = 200, config: Path = DATA / "DEMO.toml",
           history: int = 1) -> Session:
    """Replay the first ``max_cycles`` records of ``config`` (all with None), the ``.OUT`` in a
    temporary folder; returns the closed session (its ``history`` keeps the last results)."""
    with tempfile.TemporaryDirectory() as tmp:
        session = Session(load_config(config), out_path=Path(tmp) / "R.OUT", force=True,
                          history=history)
        try:
            session.run(max_cycles=max_cycles)
        finally:
            session.close()
    return session


def replay_patched(patches: Iterable[tuple[object, str, object]],
                   max_cycles: int | None = 200, config: Path = DATA / "DEMO.toml",
                   history: int = 1) -> Session:
    """:func:`replay` with each ``(target, name, value)`` of ``patches`` set by pytest's
    ``MonkeyPatch.setattr`` (in order) while it runs, all undone after however it ends: how the
    module-scoped fixtures record what a real run hands to a kernel (the function-scoped
    ``monkeypatch`` fixture is not theirs to use)."""
    with pytest.MonkeyPatch.context() as mp:
        for target, name, value in patches:
            mp.setattr(target, name, value)
        return replay(max_cycles, config, history)


def record_parts(**recorders: object) -> object:
    """A ``choose`` for the session whose parts named in ``recorders`` are wrapped: each
    recorder gets the part and returns its replacement (patch it in as
    ``engine.run.session.choose_parts``)."""
    real_choose = parts_mod.choose

    def choose() -> object:
        parts = real_choose()
        return dataclasses.replace(parts, **{name: wrap(getattr(parts, name))  # type: ignore
                                             for name, wrap in recorders.items()})
    return choose

"""The console's page modules: one module a page, none importing another. (The layers and the
absence of import cycles of the whole code base are checked in tests/test_architecture.py.)"""

from __future__ import annotations

import ast
import pathlib
import re

from tests.paths import ROOT

UI = ROOT / "uvnav_tui"


def _module(path: pathlib.Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _imported(path: pathlib.Path) -> set[str]:
    """Absolute module names imported anywhere in ``path`` (``from a import b`` counts ``a.b``
    too, as ``b`` may be a module)."""
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
            names.update(f"{node.module}.{alias.name}" for alias in node.names)
    return names


def _graph() -> dict[str, set[str]]:
    modules = {_module(p): p for p in UI.rglob("*.py")}
    return {name: {m for m in _imported(p) if m in modules and m != name}
            for name, p in modules.items()}


def test_a_page_is_one_module() -> None:
    """Every numbered page is one module ``pages/pNNN_what.py`` that imports no other page
    module (shared pieces live in ``page_text`` and ``throttled_page``), so adding a page is one
    module plus its test; the registry finds it by its name."""
    from uvnav_tui.pages.registry import pages

    graph = _graph()
    page_modules = {m for m in graph if re.fullmatch(r"uvnav_tui\.pages\.p\d{3}_\w+", m)}
    assert len(page_modules) == len(pages()) - 1  # all but the main page
    assert {m: sorted(graph[m] & page_modules) for m in page_modules if graph[m] & page_modules} \
        == {}
    registered = {factory.__module__ for p in pages().values() if (factory := p.factory)}
    assert registered == page_modules

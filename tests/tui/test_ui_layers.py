"""Layers of the console package: it uses the engine only through ``engine.api``, and its own
modules import each other without cycles (type-checking imports included)."""

from __future__ import annotations

import ast
import pathlib
import re

ROOT = pathlib.Path(__file__).resolve().parents[2]
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


def test_the_ui_uses_only_the_engine_face() -> None:
    offenders = {
        _module(p): sorted(m for m in _imported(p)
                           if m.split(".")[0] == "engine" and not m.startswith("engine.api"))
        for p in sorted(UI.rglob("*.py"))
    }
    assert {k: v for k, v in offenders.items() if v} == {}


def test_no_import_cycle_in_the_ui() -> None:
    graph = _graph()
    cycles: list[list[str]] = []
    state: dict[str, int] = {}  # 1 on the stack, 2 done

    def visit(node: str, stack: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                cycles.append([*stack[stack.index(nxt):], nxt])
            elif nxt not in state:
                visit(nxt, [*stack, nxt])
        state[node] = 2

    for name in sorted(graph):
        if name not in state:
            visit(name, [name])
    assert cycles == []


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

"""Standing rules of the code base, checked on every test run."""

from __future__ import annotations

import ast
import pathlib

ROOT = pathlib.Path(__file__).resolve().parents[1]


def _imports(path: pathlib.Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module.split(".")[0])
    return names


def test_engine_never_imports_the_ui() -> None:
    """The engine is a library: no Textual, no console package (harlequin-style rule)."""
    offenders = {
        str(p.relative_to(ROOT)): sorted(_imports(p) & {"textual", "uvnav_tui"})
        for p in sorted((ROOT / "engine").rglob("*.py"))
    }
    offenders = {k: v for k, v in offenders.items() if v}
    assert offenders == {}


def test_engine_never_prints() -> None:
    """No print() calls in the engine: results are returned, not written to a terminal."""
    found = []
    for p in sorted((ROOT / "engine").rglob("*.py")):
        tree = ast.parse(p.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "print":
                found.append(f"{p.name}:{node.lineno}")
    assert found == []


def test_every_config_key_is_in_the_readme() -> None:
    """The README documents every run-configuration key (the brief asks for it)."""
    from engine.run.config import all_keys

    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    missing = [name for name, _key, _default in all_keys() if f"`{name}`" not in readme]
    assert missing == []

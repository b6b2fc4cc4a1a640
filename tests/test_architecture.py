"""Standing rules of the code base, checked on every test run."""

from __future__ import annotations

import ast
import functools
import pathlib

from tests.paths import ROOT


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


def test_every_config_key_is_documented() -> None:
    """docs/CONFIG.md's table "Every key at a glance" documents every run-configuration key."""
    from engine.run.config import all_keys

    doc = (ROOT / "docs" / "CONFIG.md").read_text(encoding="utf-8")
    glance = doc[doc.index("## Every key at a glance") :]
    missing = [name for name, _key, _default in all_keys() if f"`{name}`" not in glance]
    assert missing == []


# --------------------------------------------------------------------------- layers and cycles
#
# The engine's rooms, lowest first (docs/ARCHITECTURE.md). A module may import its own package
# and any package of a lower rank; packages that share a rank are independent of each other
# (sim and assess). The filter sits above the fix: it takes the χ² bounds of lsq.statistics.
# ``engine.fast`` (the compiled path: the navigation modules' hot parts on engine.native) sits
# above every module it speeds up and below the run loop, which chooses it once per run.
# ``engine.api`` is the face, the top. The package root
# ``engine`` (its ``__init__``: the version only) is matched exactly and sits at the bottom.
ENGINE_ROOT = "engine"
ENGINE_LAYERS: tuple[tuple[str, ...], ...] = (
    (ENGINE_ROOT, "engine.errors", "engine.native"),
    ("engine.geodesy",),
    ("engine.io",),
    ("engine.systems",),
    ("engine.lsq",),
    ("engine.filter",),
    ("engine.fast",),
    ("engine.run",),
    ("engine.sim", "engine.assess"),
    ("engine.campaign",),
    ("engine.api",),
)
"""Rank (index) of each engine package; see the comment above."""

UI_MAY_IMPORT = (ENGINE_ROOT, "engine.api", "engine.errors")
"""The engine modules the console (``uvnav_tui``) may import: the face, the error type and the
package root (the version)."""

PACKAGES = ("engine", "uvnav_tui")
"""The packages whose modules the import graph covers."""


def _module_name(path: pathlib.Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _project_modules() -> dict[str, pathlib.Path]:
    """Every module of the covered packages: dotted name → file."""
    return {
        _module_name(p): p
        for pkg in PACKAGES
        for p in sorted((ROOT / pkg).rglob("*.py"))
    }


def _resolve(name: str, modules: dict[str, pathlib.Path]) -> str | None:
    """The project module ``name`` denotes: itself, else its longest existing prefix (a name
    imported from a module); None outside the project."""
    while name:
        if name in modules:
            return name
        name = name.rpartition(".")[0]
    return None


def _module_imports(name: str, path: pathlib.Path, modules: dict[str, pathlib.Path]
                    ) -> dict[str, int]:
    """Project modules imported anywhere in ``path`` (also inside functions and under
    ``TYPE_CHECKING``: each is a dependency), with the line of the first import."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: dict[str, int] = {}
    for node in ast.walk(tree):
        targets: list[str] = []
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")
                anchor = anchor[: len(anchor) - (node.level - 1)]
                base = ".".join([*anchor, base] if base else anchor)
            targets = [f"{base}.{alias.name}" for alias in node.names]
        for target in targets:
            resolved = _resolve(target, modules)
            if resolved is not None and resolved != name:
                found.setdefault(resolved, node.lineno)
    return found


@functools.cache
def _import_graph() -> tuple[dict[str, dict[str, int]], dict[str, pathlib.Path]]:
    modules = _project_modules()
    graph = {name: _module_imports(name, path, modules) for name, path in modules.items()}
    return graph, modules


def _cycles(graph: dict[str, dict[str, int]]) -> list[tuple[list[str], list[str]]]:
    """The strongly connected components with more than one module (Tarjan): each as its
    sorted modules and one cycle through the first (a shortest path back, by BFS)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []

    def connect(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                connect(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                components.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            connect(v)
    return [(c, _cycle_in(graph, set(c), c[0])) for c in sorted(components)]


def _cycle_in(graph: dict[str, dict[str, int]], component: set[str], start: str) -> list[str]:
    """One cycle start → … → start inside a strongly connected component (BFS back to start)."""
    parent: dict[str, str] = {}
    queue = [start]
    while queue:
        v = queue.pop(0)
        for w in sorted(graph[v]):
            if w not in component:
                continue
            if w == start:
                path = [v]
                while path[-1] != start:
                    path.append(parent[path[-1]])
                return [*reversed(path), start]
            if w not in parent:
                parent[w] = v
                queue.append(w)
    return [start]


def _layer_of(module: str) -> tuple[int, str] | None:
    """(rank, package) of an engine module from :data:`ENGINE_LAYERS` (longest match)."""
    best: tuple[int, str] | None = None
    for rank, packages in enumerate(ENGINE_LAYERS):
        for pkg in packages:
            inside = module == pkg or (pkg != ENGINE_ROOT and module.startswith(pkg + "."))
            if inside and (best is None or len(pkg) > len(best[1])):
                best = (rank, pkg)
    return best


def _where(modules: dict[str, pathlib.Path], name: str, line: int) -> str:
    return f"{modules[name].relative_to(ROOT)}:{line}"


def _layer_violations() -> list[str]:
    graph, modules = _import_graph()
    found = []
    for name, imports in sorted(graph.items()):
        own = _layer_of(name)
        if own is None:
            continue
        for target, line in sorted(imports.items()):
            other = _layer_of(target)
            if other is None or other[1] == own[1]:
                continue
            if other[0] >= own[0]:
                found.append(f"{_where(modules, name, line)}: {name} ({own[1]}, rank {own[0]}) "
                             f"imports {target} ({other[1]}, rank {other[0]})")
    return found


def _ui_violations() -> list[str]:
    graph, modules = _import_graph()
    found = []
    for name, imports in sorted(graph.items()):
        if not name.startswith("uvnav_tui"):
            continue
        for target, line in sorted(imports.items()):
            in_engine = target == ENGINE_ROOT or target.startswith(ENGINE_ROOT + ".")
            allowed = any(target == ok or (ok != ENGINE_ROOT and target.startswith(ok + "."))
                          for ok in UI_MAY_IMPORT)
            if in_engine and not allowed:
                found.append(f"{_where(modules, name, line)}: {name} imports {target}")
    return found


def test_every_engine_module_has_a_layer() -> None:
    """A new engine package must be given its place in :data:`ENGINE_LAYERS`."""
    _graph, modules = _import_graph()
    missing = [m for m in sorted(modules) if m.startswith("engine") and _layer_of(m) is None]
    assert missing == [], f"engine modules without a layer in ENGINE_LAYERS: {missing}"


def test_no_import_cycles() -> None:
    """No cycle among the modules of engine/ and uvnav_tui/ (every import counts, also the
    ones inside functions: a lazy import hides a cycle, it does not remove it)."""
    graph, modules = _import_graph()
    cycles = _cycles(graph)
    report = [
        " -> ".join(cycle)
        + "  (imports at " + ", ".join(_where(modules, a, graph[a][b])
                                       for a, b in zip(cycle, cycle[1:], strict=False))
        + f"; modules on a cycle together: {', '.join(members)})"
        for members, cycle in cycles
    ]
    assert cycles == [], f"{len(cycles)} import cycles:\n  " + "\n  ".join(report)


def test_engine_layers() -> None:
    """An engine module imports only its own package and lower layers (ENGINE_LAYERS)."""
    found = _layer_violations()
    assert found == [], f"{len(found)} imports against the layers:\n  " + "\n  ".join(found)


def test_ui_imports_only_the_engine_face() -> None:
    """The console imports only engine.api (and engine.errors) from the engine."""
    found = _ui_violations()
    assert found == [], (f"{len(found)} console imports past the engine's face "
                         f"({', '.join(UI_MAY_IMPORT)}):\n  " + "\n  ".join(found))


def test_the_checks_find_a_cycle_and_a_layer_breach() -> None:
    """The cycle finder and the layer table work on a made-up graph (the rules are not vacuous)."""
    graph = {"a": {"b": 1}, "b": {"c": 1}, "c": {"a": 1}, "d": {"a": 1}}
    assert _cycles(graph) == [(["a", "b", "c"], ["a", "b", "c", "a"])]
    assert _cycles({"a": {"b": 1}, "b": {}}) == []
    assert _layer_of("engine.io.runfile") == (2, "engine.io")
    assert _layer_of("engine") == (0, "engine")
    assert _layer_of("engine.newroom.x") is None
    sim, assess = _layer_of("engine.sim.simulate"), _layer_of("engine.assess.accuracy")
    assert sim is not None and assess is not None and sim[0] == assess[0]  # independent rooms
    lsq, flt = _layer_of("engine.lsq.fix"), _layer_of("engine.filter.kalman")
    assert lsq is not None and flt is not None and lsq[0] < flt[0]


SEAM_CLEAN = (
    "engine.filter",
    "engine.filter.estimate",
    "engine.filter.explain",
    "engine.filter.kalman",
    "engine.filter.lazy_scipy",
    "engine.filter.measurements",
    "engine.filter.model",
    "engine.filter.params",
    "engine.filter.poe",
    "engine.filter.predict",
    "engine.filter.smoother",
    "engine.filter.state",
    "engine.filter.update",
    "engine.filter.variances",
    "engine.geodesy",
    "engine.geodesy.angles",
    "engine.geodesy.ellipsoid",
    "engine.geodesy.ellipsoidal",
    "engine.geodesy.tmgrid",
    "engine.io",
    "engine.io.datafile_io",
    "engine.io.datumfile",
    "engine.io.deccafile",
    "engine.io.export_geo",
    "engine.io.export_read",
    "engine.io.export_write",
    "engine.io.formatting",
    "engine.io.live_feed",
    "engine.io.live_log",
    "engine.io.live_sources",
    "engine.io.nmea_epochs",
    "engine.io.nmea_log",
    "engine.io.nmea_send",
    "engine.io.nmea_sentences",
    "engine.io.nmea_write",
    "engine.io.operator_input",
    "engine.io.outlog",
    "engine.io.outputs",
    "engine.io.runfile",
    "engine.io.tomlsource",
    "engine.lsq",
    "engine.lsq.adjustment",
    "engine.lsq.chi2_table",
    "engine.lsq.confidence",
    "engine.lsq.fix",
    "engine.lsq.robust",
    "engine.lsq.snooping",
    "engine.lsq.statistics",
    "engine.run.cycle",
    "engine.run.commands",
    "engine.run.config",
    "engine.run.live",
    "engine.run.nmea_config",
    "engine.run.nmea_out",
    "engine.run.records",
    "engine.run.retained",
    "engine.run.session",
    "engine.run.setup",
    "engine.systems",
    "engine.systems.base",
    "engine.systems.decca",
    "engine.systems.gps",
    "engine.systems.manual",
    "engine.systems.registry",
    "engine.systems.sensors",
)
"""The navigation modules whose compiled path has moved to ``engine.fast``: they are the
reference and know of no fast path (the list grows as modules are moved)."""


def _seam_breaches(name: str, graph: dict[str, dict[str, int]],
                   modules: dict[str, pathlib.Path]) -> list[str]:
    """What in module ``name`` knows of the compiled path: an import of engine.native or
    engine.fast, or a function or method named ``*_py`` (a pure twin of a kernel call)."""
    found = [f"{_where(modules, name, line)}: imports {target}"
             for target, line in sorted(graph[name].items())
             if target.startswith(("engine.native", "engine.fast"))]
    tree = ast.parse(modules[name].read_text(encoding="utf-8"))
    found += [f"{_where(modules, name, node.lineno)}: {node.name} (a pure twin)"
              for node in ast.walk(tree)
              if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
              and node.name.endswith("_py")]
    return found


def test_navigation_modules_know_no_fast_path() -> None:
    """The cleaned navigation modules (:data:`SEAM_CLEAN`) import nothing of engine.native or
    engine.fast and have no ``_py`` twins: one reference, the compiled path in one room."""
    graph, modules = _import_graph()
    found = [b for name in SEAM_CLEAN for b in _seam_breaches(name, graph, modules)]
    assert found == [], "\n  ".join(["the compiled path outside engine.fast:", *found])


def test_the_seam_check_finds_a_breach() -> None:
    """The seam check is not vacuous: a module still dispatching to a kernel is found."""
    graph, modules = _import_graph()
    assert _seam_breaches("engine.run.kernels", graph, modules)  # reports on engine.native


def _foreign_library_loads(paths: list[pathlib.Path]) -> list[str]:
    """Sources that could load a shared library of another package (a symbol dug out of a
    wheel): Python importing ``ctypes`` or ``cffi``, C calling ``dlopen``/``dlsym``."""
    found = []
    for p in paths:
        if p.suffix == ".py":
            hits = sorted(_imports(p) & {"ctypes", "cffi", "_ctypes"})
        else:
            text = p.read_text(encoding="utf-8")
            hits = [w for w in ("dlopen", "dlsym", "LoadLibrary") if w in text]
        found += [f"{p.name}: {h}" for h in hits]
    return found


def test_no_shared_library_of_another_package_is_loaded(tmp_path: pathlib.Path) -> None:
    """The engine and the console use other packages through their public Python (or, for
    the kernels, C) interfaces only: nothing loads another package's shared library."""
    paths = [p for top in ("engine", "uvnav_tui") for pattern in ("*.py", "*.c", "*.h")
             for p in sorted((ROOT / top).rglob(pattern))]
    assert len(paths) > 100
    assert _foreign_library_loads(paths) == []
    bad = tmp_path / "bad.py"
    bad.write_text("import ctypes\nlib = ctypes.CDLL('libproj.so')\n", encoding="utf-8")
    assert _foreign_library_loads([bad]) == ["bad.py: ctypes"]

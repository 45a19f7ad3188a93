"""The packages' layering (CONTRIBUTING): no import circle between modules, ``models/`` never
imports ``heuristics/``, and no private name is imported from another module.

Imports are read from the source with :mod:`ast` (those inside functions too, since a lazy
import still ties two modules together), and the module graph's cycles are found by networkx.
"""

from __future__ import annotations

import ast
from pathlib import Path

import networkx as nx
import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("sosp", "models", "heuristics")


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for pkg in PACKAGES for p in sorted((ROOT / pkg).rglob("*.py"))}


def _resolve(name: str, modules: dict[str, Path]) -> str | None:
    """The longest known module that ``name`` (a module or ``module.attribute``) lies in."""
    while name and name not in modules:
        name = name.rpartition(".")[0]
    return name or None


def _imports(module: str, path: Path, modules: dict[str, Path]):
    """(imported module, imported names) for each import statement of ``path``."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if (target := _resolve(alias.name, modules)) is not None:
                    yield target, []
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*anchor, *([base] if base else [])])
            for alias in node.names:
                full = f"{base}.{alias.name}"
                if full in modules:  # a submodule
                    yield full, []
                elif (target := _resolve(base, modules)) is not None:
                    yield target, [alias.name]


@pytest.fixture(scope="module")
def graph() -> nx.DiGraph:
    modules = _modules()
    g = nx.DiGraph()
    g.add_nodes_from(modules)
    for module, path in modules.items():
        for target, _ in _imports(module, path, modules):
            # a package's __init__ re-exporting its own modules is not a circle
            if (
                target != module
                and not module.startswith(target + ".")
                and not (path.name == "__init__.py" and target.startswith(module + "."))
            ):
                g.add_edge(module, target)
    return g


def test_no_import_circle(graph: nx.DiGraph) -> None:
    cycles = sorted(" -> ".join(c) for c in nx.simple_cycles(graph) if len(c) > 1)
    assert cycles == []


def test_models_never_import_heuristics(graph: nx.DiGraph) -> None:
    wrong = sorted(
        (a, b) for a, b in graph.edges if a.startswith("models") and b.startswith("heuristics")
    )
    assert wrong == []


def test_no_private_name_crosses_modules() -> None:
    modules = _modules()
    crossing = sorted(
        f"{module} imports {target}.{name}"
        for module, path in modules.items()
        for target, names in _imports(module, path, modules)
        for name in names
        if name.startswith("_") and not name.startswith("__") and target != module
    )
    assert crossing == []


def test_the_checker_sees_a_circle(tmp_path: Path) -> None:
    """The graph and cycle search above do find a circle and a private import."""
    g = nx.DiGraph([("a", "b"), ("b", "a")])
    assert list(nx.simple_cycles(g))
    mods = {"sosp.x": tmp_path / "x.py", "sosp.y": tmp_path / "y.py"}
    mods["sosp.x"].write_text("from sosp.y import _hidden\n")
    assert list(_imports("sosp.x", mods["sosp.x"], mods)) == [("sosp.y", ["_hidden"])]

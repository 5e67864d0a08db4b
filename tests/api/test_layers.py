"""The api package's groups and their imports: no module of ``mfcontrol.api`` imports one
that imports it back (through any chain, top-level, function-level or ``TYPE_CHECKING``
imports alike; before the groups, controllers -> params -> loop -> controllers and
result -> plotting -> result were such circles), and the groups import one way only:
the translator of keys to arrays (``api.params``) imports no other group, the objects a
user builds (``api.model``) only the translator, the results (``api.results``) neither
running nor the bridges, running (``api.run``) any of those, and the bridge to
python-control (``api.interop``) sits on top.

Run as a script (``python tests/api/test_layers.py``) it prints the import graph among
the api's modules and the circles in it.
"""

from __future__ import annotations

import ast
from pathlib import Path

import mfcontrol

PACKAGE = Path(mfcontrol.__file__).parent
API = "mfcontrol.api"
#: the groups in the order they may import: a group imports only the groups before it
GROUPS = ("params", "model", "results", "run", "interop")


def _module_names() -> dict[str, Path]:
    """Every module of the package by dotted name (a package by its ``__init__``)."""
    names = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        names[".".join(parts)] = path
    return names


def _kind(node: ast.AST, parents: dict[ast.AST, ast.AST]) -> str:
    """Where an import sits: at import time ("top"), in a function or method ("function")
    or under ``if TYPE_CHECKING:`` ("typing")."""
    while node in parents:
        node = parents[node]
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda):
            return "function"
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            return "typing"
    return "top"


def import_graph() -> dict[str, dict[str, str]]:
    """``{module: {imported module: kind}}`` for every module of the package, the imports
    resolved to the package's own modules (``from . import x`` to the module ``x`` when it is
    one, else to the package)."""
    modules = _module_names()
    graph: dict[str, dict[str, str]] = {}
    for name, path in modules.items():
        tree = ast.parse(path.read_text(), str(path))
        parents = {child: node for node in ast.walk(tree) for child in ast.iter_child_nodes(node)}
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        edges: dict[str, str] = {}
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package.split(".")
                    base = base[: len(base) - node.level + 1]
                    base_name = ".".join(base + ([node.module] if node.module else []))
                else:
                    base_name = node.module or ""
                submodules = [f"{base_name}.{alias.name}" for alias in node.names
                              if f"{base_name}.{alias.name}" in modules]
                # the package itself only when a name is read from it, not its submodules
                whole = len(submodules) < len(node.names)
                targets = submodules + ([base_name] if whole else [])
            else:
                continue
            kind = _kind(node, parents)
            for target in targets:
                if target in modules and target != name:
                    # the strongest kind wins: top-level over function-level over typing
                    order = ("top", "function", "typing")
                    old = edges.get(target, "typing")
                    edges[target] = min(kind, old, key=order.index)
        graph[name] = edges
    return graph


def circles(graph: dict[str, dict[str, str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan's algorithm)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
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
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def _group(module: str) -> str | None:
    """The api group a module belongs to (``mfcontrol.api.run.loop`` -> ``"run"``)."""
    if not module.startswith(API + "."):
        return None
    return module[len(API) + 1:].split(".")[0]


def test_no_module_of_the_api_imports_one_that_imports_it_back():
    graph = import_graph()
    assert [c for c in circles(graph) if any(m.startswith(API) for m in c)] == []


def test_the_api_is_its_groups_and_they_import_one_way():
    graph = import_graph()
    api_modules = [m for m in graph if m.startswith(API + ".")]
    assert {_group(m) for m in api_modules} == set(GROUPS)
    wrong = []
    for module in api_modules:
        for target, kind in graph[module].items():
            mine, theirs = _group(module), _group(target)
            if theirs is not None and GROUPS.index(theirs) > GROUPS.index(mine):
                wrong.append(f"{module} -> {target} ({kind})")
    assert wrong == []


if __name__ == "__main__":
    graph = import_graph()
    for module in sorted(m for m in graph if m.startswith(API)):
        inside = {t: k for t, k in graph[module].items() if t.startswith(API)}
        listed = ", ".join(f"{t[len(API) + 1:]}" + ("" if k == "top" else f" [{k}]")
                           for t, k in sorted(inside.items()))
        print(f"{module[len(API) + 1:] or '(api)':22} -> {listed}")
    print()
    for component in circles(graph):
        if any(m.startswith(API) for m in component):
            print("circle:", " <-> ".join(component))
    print("api groups:", sorted({g for m in graph if (g := _group(m))}))

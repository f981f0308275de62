"""The layout page's picture of which folder imports which, read from the product's source
(pure: no package is imported; test/test_layout.py checks the same graphs).

A folder is a package directory of `uav_insar_planner` or `uav_insar_sim`; the modules flat
in it are one node. The two packages' own flat modules are nodes of their own: the top holds
modules of several floors (`swarm.py` below `param_specs/`, `params.py` above it), and one
node for all of them would tie those floors into a circle. A package's `__init__.py` (its
front door: `solve`, the `uav-insar` dispatcher) and `__main__.py` (its `python -m` entry)
are nodes of their own, above their folder: they import its modules to serve them. An import
of `pkg.mod` runs `pkg/__init__.py` first; that edge is Python's, not ours, and is left out.
"""
from __future__ import annotations

import ast
from collections.abc import Iterable, Mapping
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("uav_insar_planner", "uav_insar_sim")
ENTRY_FILES = ("__init__.py", "__main__.py")
Graph = dict[str, set[str]]


def product_files() -> list[Path]:
    """Every Python file of the product (the planner and the simulator)."""
    return sorted(p for package in PACKAGES for p in (ROOT / package).rglob("*.py"))


def module_name(path: Path) -> str:
    """The dotted name `path` is imported by (a package's `__init__.py`: the package's)."""
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported_modules(path: Path, known: set[str]) -> set[str]:
    """Product modules `path` imports anywhere (function bodies and TYPE_CHECKING included);
    `from pkg import mod` imports `pkg.mod`, and `pkg` itself only for a name that is no
    module of it."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            names = [f"{node.module}.{a.name}" for a in node.names]
            names += [node.module] if any(n not in known for n in names) else []
        else:
            continue
        for name in names:
            while name and name not in known:
                name = name.rpartition(".")[0]
            if name:
                found.add(name)
    return found


def module_graph() -> Graph:
    """Product module -> the product modules it imports (the parent packages' own runs of
    `__init__.py` left out)."""
    files = {module_name(p): p for p in product_files()}
    return {m: {d for d in imported_modules(p, set(files))
                if d != m and not m.startswith(d + ".")} for m, p in files.items()}


def folder_of(path: Path) -> str:
    """`path`'s node in the folder graph: `solver/ao/`, or `cli/__init__.py` for an entry."""
    rel = path.relative_to(ROOT)
    own_node = rel.name in ENTRY_FILES or len(rel.parts) == 2  # an entry, or flat at the top
    return rel.as_posix() if own_node else rel.parent.as_posix() + "/"


def folder_graph() -> Graph:
    """Folder -> the other folders its modules import (see the module docstring)."""
    files = {module_name(p): p for p in product_files()}
    graph: Graph = {folder_of(p): set() for p in files.values()}
    for module, deps in module_graph().items():
        own = folder_of(files[module])
        graph[own] |= {folder_of(files[d]) for d in deps} - {own}
    return graph


def find_circle(graph: Mapping[str, Iterable[str]]) -> list[str] | None:
    """One circle of `graph` (its first node repeated at its end), or None when it has none."""
    done: set[str] = set()

    def visit(node: str, stack: list[str]) -> list[str] | None:
        if node in stack:
            return stack[stack.index(node):] + [node]
        if node in done:
            return None
        for dep in sorted(graph.get(node, ())):
            if circle := visit(dep, [*stack, node]):
                return circle
        done.add(node)
        return None

    for node in sorted(graph):
        if circle := visit(node, []):
            return circle
    return None


def floors(graph: Graph) -> dict[str, int]:
    """Each node's floor in a graph without circles: 0 imports no other, else one above the
    highest it imports."""
    floor: dict[str, int] = {}

    def height(node: str) -> int:
        if node not in floor:
            floor[node] = 1 + max((height(d) for d in graph[node]), default=-1)
        return floor[node]

    for node in graph:
        height(node)
    return floor


def _reach(graph: Graph, node: str) -> set[str]:
    seen: set[str] = set()
    todo = list(graph[node])
    while todo:
        if (n := todo.pop()) not in seen:
            seen.add(n)
            todo += graph[n]
    return seen


def folder_imports() -> str:
    """The layout page's part: the folder graph as a Mermaid picture (an arrow A --> B: A
    imports B, directly or through the folders between) and as a list, floor by floor."""
    full = folder_graph()
    imported = set().union(*full.values())
    graph = {n: deps for n, deps in full.items() if deps or n in imported}  # no lone nodes
    if circle := find_circle(graph):
        raise ValueError("folder import circle: " + " -> ".join(circle))
    floor = floors(graph)
    ids = {n: f"f{i}" for i, n in enumerate(sorted(graph))}
    lines = ['<pre class="mermaid"><code>graph TD']
    lines += [f'  {ids[n]}["{n}"]' for n in sorted(graph, key=lambda n: (-floor[n], n))]
    for n in sorted(graph, key=lambda n: (-floor[n], n)):
        through = set().union(*(_reach(graph, d) for d in graph[n]))
        lines += [f"  {ids[n]} --&gt; {ids[d]}" for d in sorted(graph[n] - through)]
    lines += ["</code></pre>", ""]
    lines += ["Floor by floor, top down (each folder imports only folders on floors below it):",
              ""]
    for level in range(max(floor.values()), -1, -1):
        for n in sorted(k for k, v in floor.items() if v == level):
            deps = ", ".join(f"`{d}`" for d in sorted(graph[n])) or "no other folder"
            lines.append(f"- floor {level}: `{n}` imports {deps}")
    return "\n".join(lines) + "\n"

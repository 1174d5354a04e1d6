"""The package's import graph, read from its source (nothing is imported), and its circles.

Every ``import`` and ``from ... import`` statement counts, at the top of a module, inside a
function or under ``if TYPE_CHECKING:``; a name imported from a package that is one of its
modules counts as that module, and importing ``a.b.c`` imports the packages ``a`` and ``a.b``
too (their ``__init__``), but for the importer's own packages, which are importing already.
What it cannot read is an import by a computed name (``importlib.import_module(f".{x}")``:
``melange_ti.bench.cli`` picks its benchmark so, from a package above every benchmark).

``python -m melange_ti.imports`` prints the circles (none is the house's rule,
``tests/test_architecture.py``) and, with ``--floors``, each module's floor: 1 for a module
that imports none of the package, else one more than the highest it imports.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent


def modules(root: Path = PACKAGE) -> dict[str, Path]:
    """``{dotted name: file}`` for every module of the package under ``root``."""
    out = {}
    for path in sorted(root.rglob("*.py")):
        parts = path.relative_to(root.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = path
    return out


def _targets(name: str, path: Path, node: ast.AST, known: dict[str, Path]) -> list[str]:
    """The package's modules one import statement of module ``name`` reads."""
    top = name.split(".")[0]
    if isinstance(node, ast.Import):
        found = [alias.name for alias in node.names]
    else:
        if node.level:
            here = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
            base = here[: len(here) - (node.level - 1)]
            prefix = ".".join(base + ([node.module] if node.module else []))
        else:
            prefix = node.module or ""
        found = [f"{prefix}.{a.name}" if f"{prefix}.{a.name}" in known else prefix for a in node.names]
    out = []
    for target in found:
        if target.split(".")[0] != top:
            continue
        while target not in known and "." in target:  # a name from a module: that module
            target = target.rsplit(".", 1)[0]
        if target in known and target != name:
            out.append(target)
            # importing a.b.c runs the packages a and a.b first: each is imported too, but for
            # the importer's own packages, which are importing already
            parts = target.split(".")
            for k in range(1, len(parts)):
                parent = ".".join(parts[:k])
                if parent in known and not name.startswith(parent + ".") and parent != name:
                    out.append(parent)
    return out


def graph(root: Path = PACKAGE) -> dict[str, set[str]]:
    """``{module: the package's modules it imports}``."""
    known = modules(root)
    edges = {}
    for name, path in known.items():
        tree = ast.parse(path.read_text(), str(path))
        edges[name] = {
            t
            for node in ast.walk(tree)
            if isinstance(node, (ast.Import, ast.ImportFrom))
            for t in _targets(name, path, node, known)
        }
    return edges


def circles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    found: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:  # recursion depth is bounded by the package's module count
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(edges[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return found


def floors(edges: dict[str, set[str]]) -> dict[str, int]:
    """Each module's floor (the graph must have no circle)."""
    out: dict[str, int] = {}

    def floor(v: str) -> int:
        if v not in out:
            out[v] = 1 + max((floor(w) for w in edges[v]), default=0)
        return out[v]

    for v in edges:
        floor(v)
    return out


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    edges = graph()
    found = circles(edges)
    for c in found:
        print(f"circle of {len(c)}: {', '.join(c)}")
    if not found:
        print(f"{len(edges)} modules, {sum(map(len, edges.values()))} imports, no circle")
        if "--floors" in argv:
            for name, f in sorted(floors(edges).items(), key=lambda kv: (-kv[1], kv[0])):
                print(f"{f:3d}  {name}")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())

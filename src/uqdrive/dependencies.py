"""The package's own import graph, read from the source (no module is imported): the workflow's
code rerun triggers and the layering test both use it.
"""

from __future__ import annotations

import ast
import functools
import re
from pathlib import Path

__all__ = ["PACKAGE_ROOT", "module_path", "imported_modules", "import_graph", "module_closure"]

PACKAGE_ROOT = Path(__file__).resolve().parent


def module_path(name: str, root: Path = PACKAGE_ROOT) -> Path:
    """File of the dotted module ``name`` (relative to the package, e.g. ``vehicle.chaos``)."""
    base = root.joinpath(*name.split(".")) if name else root
    return base / "__init__.py" if base.is_dir() else base.with_suffix(".py")


def _resolve(importer: str, is_package: bool, level: int, target: str | None) -> str:
    parts = importer.split(".") if importer else []
    package = parts if is_package else parts[:-1]
    if level > len(package) + 1:
        raise ImportError(f"relative import beyond the package in {importer}")
    base = package[: len(package) - (level - 1)]
    return ".".join(base + (target.split(".") if target else []))


#: An import statement at the start of a line (at any indentation: imports inside functions count),
#: a parenthesised name list over several lines included.
_IMPORT_STATEMENT = re.compile(r"^[ \t]*((?:from[ \t]+[.\w]+[ \t]+)?import[ \t]+(?:\([^)]*\)|[^\n]*))", re.MULTILINE)


def _import_nodes(source: str, filename: str) -> list[ast.stmt]:
    """The import statements of ``source``: each one parsed alone (what a whole-file parse costs
    is ~5 ms a module and every Snakemake start reads all of them, ~0.4 s), or, where a statement
    does not parse alone (a backslash continuation), every import node of the whole file."""
    nodes = []
    for match in _IMPORT_STATEMENT.finditer(source):
        try:
            nodes.extend(n for n in ast.parse(match.group(1), filename).body if isinstance(n, (ast.Import, ast.ImportFrom)))
        except SyntaxError:
            return [n for n in ast.walk(ast.parse(source, filename)) if isinstance(n, (ast.Import, ast.ImportFrom))]
    return nodes


def imported_modules(name: str, root: Path = PACKAGE_ROOT) -> set[str]:
    """Package modules that module ``name`` imports (anywhere in its body), as dotted names."""
    path = module_path(name, root)
    is_package = path.name == "__init__.py"
    found: set[str] = set()
    for node in _import_nodes(path.read_text(), str(path)):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                target = _resolve(name, is_package, node.level, node.module)
            elif node.module and (node.module == "uqdrive" or node.module.startswith("uqdrive.")):
                target = node.module.removeprefix("uqdrive").lstrip(".")
            else:
                continue
            for alias in node.names:  # `from . import x` may name a module
                sub = f"{target}.{alias.name}" if target else alias.name
                found.add(sub if module_path(sub, root).exists() else target)
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("uqdrive."):
                    found.add(alias.name.removeprefix("uqdrive."))
    found.discard(name)
    return found


@functools.cache
def import_graph(root: Path = PACKAGE_ROOT) -> dict[str, frozenset[str]]:
    """Every module of the package (dotted, ``""`` for the package itself) -> what it imports."""
    graph = {}
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root).with_suffix("")
        parts = list(rel.parts[:-1]) if rel.name == "__init__" else list(rel.parts)
        name = ".".join(parts)
        graph[name] = frozenset(imported_modules(name, root))
    return graph


def module_closure(*names: str, root: Path = PACKAGE_ROOT) -> list[Path]:
    """Files of ``names`` and of every package module they import, directly or not (sorted)."""
    graph = import_graph(root)
    todo, seen = list(names), set()
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        if name not in graph:
            raise KeyError(f"no module uqdrive.{name}")
        seen.add(name)
        parent = name.rpartition(".")[0]
        todo.extend(graph[name] | ({parent} if name else set()))
    return sorted(module_path(n, root) for n in seen)

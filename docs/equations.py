"""Index of the seeds' equations cited in uqdrive's docstrings, written at every docs build.

Every numerical function cites the equation it implements, e.g. "thesis eq. (5.25)"; this scan
turns those citations into the tables of the science page, so the index cannot drift from the
code. Thesis equations are numbered chapter.number ("(5.3a)"), the wheel-slip paper's plainly
("(22)"), and only in the wheel-slip modules; a range "(5.35)-(5.36)" cites every number in it
(a range of more than eight, e.g. a package's "(6)-(27)", only its two ends).
"""

from __future__ import annotations

import ast
import re
from collections import defaultdict
from pathlib import Path

THESIS = re.compile(r"(?<![\w)])\((\d)\.(\d{1,2})([a-z]?)\)(?:\s*-\s*\((\d)\.(\d{1,2})([a-z]?)\))?")
PAPER = re.compile(r"(?<![\w)])\((\d{1,2})\)(?:\s*-\s*\((\d{1,2})\))?")
PAPER_MODULES = ("uqdrive.wheelslip", "uqdrive.studies.wheelslip", "uqdrive.plots.wheelslip")


def _documented(src: Path):
    """(dotted name, docstring) of every module, class and function docstring under ``src``."""
    for path in sorted(src.rglob("*.py")):
        module = ".".join(path.relative_to(src.parent).with_suffix("").parts).removesuffix(".__init__")
        tree = ast.parse(path.read_text(encoding="utf-8"))
        yield module, module, ast.get_docstring(tree) or ""
        stack = [(node, module) for node in tree.body]
        while stack:
            node, prefix = stack.pop()
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                name = f"{prefix}.{node.name}"
                yield module, name, ast.get_docstring(node) or ""
                if isinstance(node, ast.ClassDef):
                    stack.extend((child, name) for child in node.body)


def _span(first: int, last: int) -> list[int]:
    if last <= first:
        return [first]
    return list(range(first, last + 1)) if last - first < 8 else [first, last]


def citations(src: Path) -> tuple[dict, dict]:
    """Thesis and paper equation -> set of (module, object) citing it."""
    thesis, paper = defaultdict(set), defaultdict(set)
    for module, name, doc in _documented(src):
        for m in THESIS.finditer(doc):
            chapter, first, letter = int(m[1]), int(m[2]), m[3]
            last = int(m[5]) if m[4] and int(m[4]) == chapter else first
            for n in _span(first, last):
                thesis[(chapter, n, letter if n == first and not m[4] else "")].add((module, name))
        if module.startswith(PAPER_MODULES):
            for m in PAPER.finditer(doc):
                first, last = int(m[1]), int(m[2] or m[1])
                for n in _span(first, last):
                    paper[n].add((module, name))
    return thesis, paper


def _ref(module: str, name: str) -> str:
    if name == module:
        return f"{{py:mod}}`{module}`"
    if any(part.startswith("_") for part in name.split(".")):
        return f"`{name.removeprefix(module + '.')}` in {{py:mod}}`{module}`"
    return f"{{py:obj}}`~{name}`"


def write_index(src: Path, out: Path) -> None:
    """Write the two Markdown tables (thesis, paper) to ``out``."""
    thesis, paper = citations(src)
    lines = ["### Thesis", "", "| equation | implemented or used in |", "|---|---|"]
    for (c, n, letter) in sorted(thesis):
        lines.append(f"| ({c}.{n}{letter}) | " + ", ".join(_ref(*x) for x in sorted(thesis[(c, n, letter)])) + " |")
    lines += ["", "### Wheel-slip paper", "", "| equation | implemented or used in |", "|---|---|"]
    for n in sorted(paper):
        lines.append(f"| ({n}) | " + ", ".join(_ref(*x) for x in sorted(paper[n])) + " |")
    out.parent.mkdir(parents=True, exist_ok=True)
    text = "\n".join(lines) + "\n"
    if not out.exists() or out.read_text() != text:  # unchanged file: Sphinx keeps its cache
        out.write_text(text)

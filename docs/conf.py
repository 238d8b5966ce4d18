"""Sphinx configuration of the uqdrive documentation (`make docs`).

Why Sphinx and not mkdocs: the docstrings are numpydoc, which Sphinx reads natively (numpydoc
renders and validates them; mkdocstrings' numpy parser neither validates sections nor knows
numpydoc's conventions), autosummary writes one page per module of the package from the import
tree, and MyST-parser lets the topic pages stay plain Markdown that GitHub renders too. The build
runs with warnings as errors, so a docstring whose sections do not parse, a broken cross-reference
inside the toctree or a page outside every toctree fails `make docs` (and tests/test_docs.py).
"""

from __future__ import annotations

import importlib
import os
import re
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "src"))  # the source tree, whether or not uqdrive is installed

import uqdrive  # noqa: E402

sys.path.insert(0, str(HERE))
import equations  # noqa: E402
import generated_tables  # noqa: E402
import import_example  # noqa: E402
import measured_tables  # noqa: E402
import your_car_example  # noqa: E402

equations.write_index(HERE.parent / "src" / "uqdrive", HERE / "api" / "generated" / "equations.md")
# The candidate effects of discover (from the registry) and the workflow's rules (from its files).
generated_tables.write_all(HERE.parent, HERE / "api" / "generated")
# The measurements no build can repeat (benchmarks, cluster runs), from their committed records in
# docs/measurements/, with what the code defines (declared resources, binomial bands) computed.
measured_tables.write_all(HERE.parent, HERE / "api" / "generated")
# The import guide's worked example runs here: its logs, the import and the identification, so
# that every number the page shows comes from this build (docs/import_example.py).
import_example.write_example(HERE / "api" / "generated" / "import_example.md")
# The your-car guide's worked example (simulate the sedan, identify it with two cars), likewise.
your_car_example.write_example(HERE.parent, HERE / "api" / "generated" / "your_car_example.md")

project = "uqdrive"
author = "uqdrive contributors"
copyright = "uqdrive contributors"
version = release = uqdrive.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "api/generated/*.md", "README.md"]
templates_path = ["_templates"]

# Topic pages are Markdown; headings get anchors so that pages can link to sections.
myst_enable_extensions = ["colon_fence", "deflist", "dollarmath", "substitution"]
# Numbers quoted in running text ({{ min_runs }}), read from the code at build time.
myst_substitutions = {**generated_tables.substitutions(), **measured_tables.substitutions(HERE.parent)}
myst_heading_anchors = 3

# API reference: one page per public module, written at build time into api/generated
# (gitignored). The package __init__s export names lazily (uqdrive._lazy); autosummary lists a
# module's own members only (each object is documented once, where it is defined), and the
# package pages list their lazy exports with links through `exports` below.
autosummary_generate = True
# A module renamed or removed leaves its page behind, and autosummary would try to import it.
for _stale in (HERE / "api" / "generated").glob("uqdrive*.rst"):
    _stale.unlink()
autosummary_imported_members = False
autosummary_ignore_module_all = True
autodoc_default_options = {"members": True, "undoc-members": True, "member-order": "bysource", "show-inheritance": True}
autodoc_typehints = "none"  # the numpydoc sections state the types, with shapes and units

# No ToC entry per documented object: furo puts the whole toctree, objects included, into every
# page's navigation, which made writing the 100 pages take 80 % of the build (a table of the
# module's classes and functions heads each API page instead: docs/_templates/autosummary).
toc_object_entries = False
numpydoc_show_class_members = False  # autodoc's :members: documents methods once
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
# GL08: every public object has a docstring; the parse of every docstring's sections is checked
# by numpydoc itself (an unknown or malformed section is a warning, i.e. an error here).
numpydoc_validation_checks = {"GL08"}
# Effect subclasses implement Effect.apply, documented there (autodoc shows the inherited text).
numpydoc_validation_exclude = {r"\.__\w+__$", r"^uqdrive\.vehicle\.effects\.\w+\.apply$"}


def _lazy_exports() -> dict[str, list[tuple[str, str]]]:
    """Package -> [(exported name, module where it is defined)] for every package's ``__all__``."""
    out: dict[str, list[tuple[str, str]]] = {}
    import pkgutil

    packages = ["uqdrive"] + [m.name for m in pkgutil.walk_packages(uqdrive.__path__, "uqdrive.") if m.ispkg]
    for name in packages:
        package = importlib.import_module(name)
        rows = []
        for export in getattr(package, "__all__", []):
            value = getattr(package, export)
            home = getattr(value, "__module__", None)
            if home and home != name and (callable(value) or isinstance(value, type)):
                rows.append((export, f"{home}.{export}"))
        if rows:
            out[name] = rows
    return out


autosummary_context = {"exports": _lazy_exports()}

html_theme = "furo"
html_title = f"uqdrive {release}"
html_static_path: list[str] = []
html_show_sourcelink = False
pygments_style = "sphinx"

nitpicky = False
suppress_warnings = ["myst.header"]

# The guides of index.md that are written separately: a missing one is left out of the toctree
# (and so of the site) instead of failing the build; every other missing page still fails it.
OPTIONAL_GUIDES = ("data_schema", "your_car", "identification", "discovery", "four_wheel", "cluster")
os.environ.setdefault("MPLBACKEND", "Agg")

# The docstrings are written to read well in `help()` too: |x| is an absolute value and a norm,
# never a reST substitution (the package defines none). Escape the bars outside ``literals``.
_LITERAL = re.compile(r"(``.*?``)")


def _escape_bars(app, what, name, obj, options, lines):
    for i, line in enumerate(lines):
        if "|" in line:
            parts = _LITERAL.split(line)
            lines[i] = "".join(p if p.startswith("``") else re.sub(r"(?<!\\)\|", r"\\|", p) for p in parts)


def _drop_missing_guides(app, docname, source):
    if docname != "index":
        return
    missing = {g for g in OPTIONAL_GUIDES if not (HERE / f"{g}.md").is_file()}
    source[0] = "\n".join(line for line in source[0].split("\n") if line.strip() not in missing)


def setup(app):
    app.connect("autodoc-process-docstring", _escape_bars, priority=400)
    app.connect("source-read", _drop_missing_guides)

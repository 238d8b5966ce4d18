"""The package's layering: imports point one way (edges -> studies -> algorithms -> models ->
numerics -> foundation), with no cycle, and modules and folders stay small enough to read."""

import ast

import pytest

from uqdrive.dependencies import PACKAGE_ROOT, _import_nodes, import_graph, module_closure

# Layer of each top-level part of the package; a module may import its own layer or lower ones.
LAYERS = {
    "_version": 0, "_lazy": 0, "_errors": 0, "_yaml": 0, "config": 0, "vehicle_spec": 0, "rng": 0, "dependencies": 0,
    "settings": 0, "workflow_config": 0, "interrupts": 0,
    "numerics": 1,
    "vehicle": 2,
    "io": 3, "outputs": 3, "recordings": 3, "inference": 3, "control": 3, "wheelslip": 3,
    "studies": 4,
    "plots": 5, "cli": 5, "": 5,
}


def layer(module: str) -> int:
    return LAYERS[module.split(".")[0]]


def test_every_module_has_a_layer():
    unknown = sorted(m for m in import_graph() if m.split(".")[0] not in LAYERS)
    assert not unknown, f"add these to LAYERS: {unknown}"


def test_no_import_runs_back_up():
    upward = [
        f"uqdrive.{a} (layer {layer(a)}) imports uqdrive.{b} (layer {layer(b)})"
        for a, targets in import_graph().items()
        for b in targets
        if layer(b) > layer(a)
    ]
    assert not upward, "\n".join(upward)


def _cycle(graph):
    """One cycle of ``graph`` as a list of nodes, or None (iterative DFS, three colours)."""
    colour, parent = {n: 0 for n in graph}, {}
    for root in graph:
        if colour[root]:
            continue
        stack = [(root, iter(sorted(graph[root])))]
        colour[root] = 1
        while stack:
            node, children = stack[-1]
            child = next(children, None)
            if child is None:
                colour[node] = 2
                stack.pop()
            elif colour.get(child, 2) == 0:
                colour[child], parent[child] = 1, node
                stack.append((child, iter(sorted(graph[child]))))
            elif colour.get(child) == 1:
                cycle, n = [child], node
                while n != child:
                    cycle.append(n)
                    n = parent[n]
                return cycle[::-1]
    return None


def test_no_import_cycle_between_modules():
    assert _cycle(import_graph()) is None


def test_no_import_cycle_between_subpackages():
    parts = {}
    for a, targets in import_graph().items():
        pa = a.split(".")[0]
        parts.setdefault(pa, set()).update(b.split(".")[0] for b in targets if b.split(".")[0] != pa)
    assert _cycle(parts) is None


def test_cycle_finder_finds_a_planted_cycle():
    """The checks above can fail: a three-module loop and an upward arrow are both caught."""
    assert sorted(_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()})) == ["a", "b", "c"]
    assert _cycle({"a": {"b"}, "b": set()}) is None
    assert layer("numerics.galerkin") < layer("vehicle.chaos") < layer("studies.pce")


@pytest.mark.parametrize("path", sorted(PACKAGE_ROOT.rglob("*.py")), ids=lambda p: str(p.relative_to(PACKAGE_ROOT)))
def test_module_is_short(path):
    assert len(path.read_text().splitlines()) <= 420, f"{path} has grown past ~400 lines: split it by concept"


def test_folders_hold_at_most_twelve_modules():
    for folder in [PACKAGE_ROOT, *(p for p in PACKAGE_ROOT.rglob("*") if p.is_dir() and p.name != "__pycache__")]:
        modules = [p for p in folder.glob("*.py") if p.name != "__init__.py"]
        assert len(modules) <= 12, f"{folder} holds {len(modules)} modules"


def test_rule_dependencies_follow_imports():
    """The workflow's code trigger of a study includes the numerical core it calls."""
    files = {str(p.relative_to(PACKAGE_ROOT)) for p in module_closure("studies.identification")}
    assert {"studies/identification.py", "inference/identify.py", "vehicle/chaos.py", "numerics/galerkin.py", "config.py"} <= files
    assert "plots/data.py" not in files
    with pytest.raises(KeyError):
        module_closure("no_such_module")


def _all_import_nodes(source):
    return [n for n in ast.walk(ast.parse(source)) if isinstance(n, (ast.Import, ast.ImportFrom))]


def test_the_statement_reader_finds_what_a_whole_file_parse_finds():
    """The import statements read one by one (dependencies._import_nodes, the fast path of every
    Snakemake start) equal those of a whole-file parse, for every module of the package and for
    the forms a line-based reader can get wrong."""
    def dumped(nodes):
        return sorted(ast.dump(n, include_attributes=False) for n in nodes)

    tricky = '''"""Docstring."""
from .a import (b,
    c)  # comment
import os, uqdrive.x as x


def f():
    from ..d import e
    if True:
        import uqdrive.g; y = 1
from .h import \\
    i
'''
    continued = tricky.index("from .h")  # a backslash continuation: the whole-file fallback
    for source in [tricky, tricky[:continued], *(p.read_text() for p in sorted(PACKAGE_ROOT.rglob("*.py")))]:
        assert dumped(_import_nodes(source, "<test>")) == dumped(_all_import_nodes(source))
    assert len(_import_nodes(tricky, "<test>")) == 5 and len(_import_nodes(tricky[:continued], "<test>")) == 4


#: The parts below the edges (the command line, the studies and the workflow scripts): they read
#: typed settings (uqdrive.settings), never the config mapping.
BELOW_THE_EDGES = ("numerics", "vehicle", "inference", "control", "wheelslip")


def _config_readers(source: str) -> list[str]:
    """Functions of ``source`` with a parameter named config or cfg, and reads or writes of a
    ``config`` attribute (``self.config``, ``finder.config``)."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            a = node.args
            if any(x.arg in ("config", "cfg") for x in a.posonlyargs + a.args + a.kwonlyargs):
                found.append(f"line {node.lineno}: {getattr(node, 'name', 'lambda')} takes the config")
        elif isinstance(node, ast.Attribute) and node.attr == "config":
            found.append(f"line {node.lineno}: {ast.unparse(node)}")
    return found


def test_nothing_below_the_edges_takes_the_config_mapping():
    readers = [f"{p.relative_to(PACKAGE_ROOT)} {r}" for part in BELOW_THE_EDGES for p in sorted((PACKAGE_ROOT / part).rglob("*.py"))
               for r in _config_readers(p.read_text())]
    assert not readers, "build uqdrive.settings.Settings at the edge and pass it down:\n" + "\n".join(readers)


def test_the_config_reader_check_can_fail():
    planted = ("def f(x, *, cfg=None):\n    pass\nclass A:\n    def g(self, config):\n        self.config = config\n    h = lambda config: 0\n"
               "def k(finder):\n    return finder.config['seed']\n")
    assert len(_config_readers(planted)) == 5
    assert _config_readers("def f(settings):\n    self.settings = settings\n") == []


def _private_reach_ins(source: str) -> list[str]:
    """Uses of another object's or module's private name (``finder._chi2``, ``f._joint = ...``,
    ``from .recursion import _helper``): an attribute named ``_x`` (not a dunder) on anything but
    ``self``, ``cls`` or ``super()``, and a ``_x`` imported from a module of the package."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Attribute) and node.attr.startswith("_") and not node.attr.startswith("__"):
            owner = node.value
            if isinstance(owner, ast.Name) and owner.id in ("self", "cls"):
                continue
            if isinstance(owner, ast.Call) and isinstance(owner.func, ast.Name) and owner.func.id == "super":
                continue
            found.append(f"line {node.lineno}: {ast.unparse(node)}")
        elif isinstance(node, ast.ImportFrom) and (node.level > 0 or (node.module or "").split(".")[0] == "uqdrive"):
            found += [f"line {node.lineno}: import {a.name}" for a in node.names if a.name.startswith("_") and not a.name.startswith("__")]
    return found


def test_modules_use_each_other_through_public_names():
    """Every module of the package (the discovery's parts, the chaos model and its channels, the
    estimator and its optimisers, ...) calls another's public methods and functions and reads
    its public attributes, never its private state."""
    reach = [f"{p.relative_to(PACKAGE_ROOT)} {r}" for p in sorted(PACKAGE_ROOT.rglob("*.py")) for r in _private_reach_ins(p.read_text())]
    assert not reach, "give the other part a public name:\n" + "\n".join(reach)


def test_the_reach_in_check_can_fail():
    planted = ("def f(finder, ctx):\n    finder._joint(ctx)\n    finder.steps_.append(finder._chi2(ctx))\n"
               "class A(B):\n    def g(self):\n        self._x = super()._y()\n        return type(self)._z, self.__class__\n"
               "from .recursion import _helper, public\nfrom uqdrive.vehicle import _rhs as rhs\nfrom .._yaml import load_yaml\n"
               "import io as _io\nfrom os import _exit\n")
    assert sorted(r.split(": ", 1)[1] for r in _private_reach_ins(planted)) == [
        "finder._chi2", "finder._joint", "import _helper", "import _rhs", "type(self)._z"]


#: Where the car's settings are defined: their own methods are not a module they pass through.
SETTINGS_HOME = ("uqdrive.settings", "uqdrive.settings.car", "uqdrive.settings.run")


def _settings_path(argv):
    """Run ``uqdrive argv`` and follow the car's settings: the uqdrive modules (outside
    :data:`SETTINGS_HOME`) of every frame that holds a ``Settings`` or ``Vehicle`` when it is
    entered or left, and each step that enters a higher layer than the nearest such frame below it."""
    import sys

    from uqdrive.cli.main import main
    from uqdrive.settings import Settings, Vehicle

    def holds(frame):
        return frame.f_globals.get("__name__", "").startswith("uqdrive") and any(isinstance(v, (Settings, Vehicle)) for v in frame.f_locals.values())

    modules, climbs = {}, []

    def follow(frame, event, arg):
        if event not in ("call", "return") or not holds(frame):
            return
        name = frame.f_globals["__name__"]
        if name not in SETTINGS_HOME:
            modules.setdefault(name, frame.f_code.co_name)
        caller = frame.f_back
        while caller is not None and not holds(caller):
            caller = caller.f_back
        if event == "call" and caller is not None and layer(name[len("uqdrive."):]) > layer(caller.f_globals["__name__"][len("uqdrive."):]):
            climbs.append(f"{caller.f_globals['__name__']}.{caller.f_code.co_name} -> {name}.{frame.f_code.co_name}")

    sys.setprofile(follow)
    try:
        assert main(argv) == 0
    finally:
        sys.setprofile(None)
    return modules, climbs


def test_the_cars_settings_reach_the_right_hand_side_through_six_modules_at_most(tmp_path):
    """``uqdrive identify`` on a tiny file: the settings are built at the edge and travel down to
    the single-track equations (VehicleParameters.from_settings) through at most 6 modules,
    never handed back up a layer."""
    import yaml

    import uqdrive
    from conftest import REPO
    from uqdrive.config import load_config
    from uqdrive.io import write_dataset

    config = load_config(REPO / "config" / "test.yaml")
    config["time"].update(t_end=2.0, dt=0.05, step=0.025)
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(config))
    write_dataset(uqdrive.simulate("lst", config=str(tmp_path / "c.yaml"), samples=12), tmp_path / "runs.nc")
    modules, climbs = _settings_path(["identify", str(tmp_path / "runs.nc"), "--config", str(tmp_path / "c.yaml"), "--out", str(tmp_path / "out")])
    assert {"uqdrive.cli.identify", "uqdrive.vehicle.single_track"} <= set(modules), modules  # the edge and the equations
    assert len(modules) <= 6, modules
    assert not climbs, climbs

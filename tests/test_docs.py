"""The documentation: the site builds with warnings as errors (the command of `make docs`), every
public function, class and method has a docstring whose numpydoc sections parse, and every array
in them states its shape, and in the physical modules its unit."""

import importlib
import inspect
import pkgutil
import re
import shlex
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

import uqdrive

ROOT = Path(__file__).resolve().parents[1]

# Modules whose arrays are physical signals and parameters: each array argument names its unit.
# (The numerical cores' matrices are unit-free algebra; their shapes are what a caller needs.)
PHYSICAL = ("uqdrive.vehicle.", "uqdrive.wheelslip.", "uqdrive.studies.manoeuvres")

ARRAY = re.compile(r"\b(nd)?array(_like)?\b", re.IGNORECASE)
# "shape (n, T)", "(n,)", "(4, T)", "()" or a shape given by reference ("same shape as x").
SHAPE = re.compile(r"\bshape\b|\(\s*\)|\(\s*[\w.+\-* ]+,[^()]*\)|\(\s*[\w+\-*]+ x [\w+\-*]+\s*\)", re.IGNORECASE)
# "(rad)", "(m/s)", "(-)", "units of ...", "dimensionless", a boolean or index array, or a germ.
UNIT = re.compile(r"\((?:-|rad|rad/s|m|s|N|kg|m/s|m/s\^2|m\^2|deg|N/rad|1/s|Hz|%)[,;)\s]|(?i:\bunits?\b|"
                  r"dimensionless|unit-?free|\bbool|\bint\b|\bindex|\bindices|\bgerms?\b|\bsame\b)")


def public_modules():
    names = ["uqdrive"] + sorted(m.name for m in pkgutil.walk_packages(uqdrive.__path__, "uqdrive.")
                                 if not any(part.startswith("_") for part in m.name.split(".")))
    return [importlib.import_module(n) for n in names]


def public_objects():
    """(qualified name, object) of every public function, class and method, where defined."""
    for module in public_modules():
        for name, obj in vars(module).items():
            if name.startswith("_") or getattr(obj, "__module__", None) != module.__name__:
                continue
            if inspect.isfunction(obj):
                yield f"{module.__name__}.{name}", obj
            elif inspect.isclass(obj):
                yield f"{module.__name__}.{name}", obj
                for member, value in vars(obj).items():
                    if member.startswith("_"):
                        continue
                    if isinstance(value, (classmethod, staticmethod)):
                        value = value.__func__
                    elif isinstance(value, property):
                        value = value.fget
                    if inspect.isfunction(value):
                        yield f"{module.__name__}.{name}.{member}", value


def parsed(obj):
    from numpydoc.docscrape import NumpyDocString

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpydoc warns on unknown or malformed sections
        return NumpyDocString(inspect.getdoc(obj) or "")


def test_every_public_object_has_a_docstring_whose_sections_parse():
    pytest.importorskip("numpydoc")
    objects = dict(public_objects())
    assert len(objects) > 300  # the walk reaches the whole package
    missing = [name for name, obj in objects.items() if not inspect.getdoc(obj)]
    assert not missing, f"public objects without a docstring: {missing}"
    broken = []
    for name, obj in objects.items():
        try:
            parsed(obj)
        except Exception as exc:  # noqa: BLE001 - every parse failure is reported with its object
            broken.append(f"{name}: {exc}")
    assert not broken, "numpydoc sections that do not parse:\n" + "\n".join(broken)


def array_entries():
    """(object, section, argument, type, description) of every array in a Parameters, Returns or
    Attributes section."""
    for name, obj in public_objects():
        doc = parsed(obj)
        for section in ("Parameters", "Returns", "Attributes"):
            for p in doc[section]:
                if ARRAY.search(p.type) and "Dataset" not in p.type:
                    yield name, section, p.name or "(return)", p.type, " ".join(p.desc)


def test_every_array_in_a_docstring_states_its_shape():
    pytest.importorskip("numpydoc")
    entries = list(array_entries())
    assert len(entries) > 100
    bad = [f"{n} {sec} {arg}: {typ}" for n, sec, arg, typ, desc in entries if not SHAPE.search(f"{typ} {desc}")]
    assert not bad, "arrays without a shape, e.g. 'ndarray, shape (n, T)':\n" + "\n".join(bad)


def test_every_array_argument_of_a_physical_module_states_its_unit():
    pytest.importorskip("numpydoc")
    entries = [e for e in array_entries() if e[0].startswith(PHYSICAL) and e[1] == "Parameters"]
    assert len(entries) > 20
    bad = [f"{n} {arg}: {typ} -- {desc}" for n, sec, arg, typ, desc in entries if not UNIT.search(f"{typ} {desc}")]
    assert not bad, "physical array arguments without a unit, e.g. 'Time (s).':\n" + "\n".join(bad)


def test_the_checks_can_fail():
    """The shape and unit patterns reject what they must reject."""
    assert not SHAPE.search("ndarray Steering angle (rad).") and SHAPE.search("ndarray, shape (n,) Time.")
    assert SHAPE.search("ndarray (4, T)") and SHAPE.search("ndarray (d x d)")
    assert not UNIT.search("ndarray, shape (n,) Time.") and UNIT.search("ndarray, shape (n,) Time (s).")
    assert UNIT.search("Slip angle (rad) or slip ratio (-).")


def sphinx_command(outdir):
    """`make docs`'s Sphinx call (Makefile SPHINX_BUILD) with the output in ``outdir``."""
    line = next(l for l in (ROOT / "Makefile").read_text().splitlines() if l.startswith("SPHINX_BUILD"))
    return [sys.executable] + shlex.split(line.split("=", 1)[1]) + [str(ROOT / "docs"), str(outdir)]


@pytest.mark.long(30)
def test_the_documentation_builds_without_warnings(tmp_path):
    """What CI checks of `make docs`: every page, every API page and every docstring build with
    warnings as errors; the landing page, the API page of the estimator and the equation index
    are there."""
    pytest.importorskip("sphinx")
    pytest.importorskip("myst_parser")
    cmd = sphinx_command(tmp_path / "html")
    assert "-W" in cmd and "--keep-going" in cmd
    run = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    assert run.returncode == 0, f"make docs fails:\n{run.stderr[-6000:]}"
    html = tmp_path / "html"
    assert (html / "index.html").is_file()
    identify = (html / "api" / "generated" / "uqdrive.inference.identify.html").read_text()
    assert "DistributionEstimator" in identify and "Parameters" in identify
    science = (html / "science.html").read_text()
    assert "(5.25)" in science and "uqdrive.inference.identify" in science

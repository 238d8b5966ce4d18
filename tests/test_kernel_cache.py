"""The compiled loops' disk cache: a loop that calls closures is right whichever processes compiled
them, and a loop's cached machine code follows an edit of a helper it calls in another module."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import uqdrive
from uqdrive.vehicle.dynamics import jit

#: numba's sine and NumPy's may differ in the last bit of a few of the 105 steps; the other variant
#: (or the old helper) moves the sum by more than a tenth
RTOL = 1e-12
SRC = str(Path(uqdrive.__file__).parents[1])

# a package of compiled loops: ``outer`` closes over the compiled ``inner`` (a variant per flag,
# too long a loop for LLVM to inline), which calls a helper of another module
KERNELS = textwrap.dedent("""
    import functools
    import numpy as np
    from uqdrive.vehicle.dynamics.jit import compiled
    from .helper import bump

    @functools.lru_cache(maxsize=None)
    def make(flag):
        def inner(x, out):
            for i in range(x.shape[0]):
                a = bump(x[i])
                for _ in range(7):
                    a = np.sin(a) * (2.0 if flag else 3.0) + np.cos(a * 1.1) - np.tanh(a)
                out[i] = a
        each = compiled(inner)

        def outer(x, out, steps):
            for _ in range(steps):
                each(x, out)
                each(out, x)
            each(x, out)
        return compiled(outer)
""")
HELPER = "from numba import njit\n\n\n@njit\ndef bump(x):\n    return x + {step}\n"
# the loops run for each flag in the order given, then their numbers and cache hits
RUN = textwrap.dedent("""
    import sys
    import numpy as np
    import kpkg.kernels as k
    for flag in {flags}:
        f = k.make(flag)
        x, out = np.linspace(0.0, 1.0, 5), np.zeros(5)
        f(x, out, 3)
        print(repr(float(out.sum())), sum(f.stats.cache_hits.values()))
""")
FORKED = "import os\nimport kpkg.kernels as k\nfor flag in (True, False):\n    pid = os.fork()\n    if pid == 0:\n" \
         + textwrap.indent(RUN.format(flags="(flag,)").replace("import kpkg.kernels as k\n", ""), "        ") \
         + "        os._exit(0)\n    os.waitpid(pid, 0)\n"


def _run(tmp_path, code: str) -> list[str]:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), SRC])}
    env.pop("NUMBA_CACHE_DIR", None)
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    return out.stdout.split()


def _package(tmp_path, step: float) -> None:
    pkg = tmp_path / "kpkg"
    pkg.mkdir(exist_ok=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "kernels.py").write_text(KERNELS)
    (pkg / "helper.py").write_text(HELPER.format(step=step))


def _expected(flag: bool, step: float, passes: int = 0) -> float:
    """``outer``'s number computed in Python, the same operations in the same order (``passes``
    1: a variant's one pass, no helper)."""
    x, out = np.linspace(0.0, 1.0, 5), np.zeros(5)

    def inner(src, dst):
        for i in range(src.shape[0]):
            a = src[i] + step
            for _ in range(7):
                a = np.sin(a) * (2.0 if flag else 3.0) + np.cos(a * 1.1) - np.tanh(a)
            dst[i] = a
    if passes == 1:
        inner(x, out)
        return float(out.sum())
    for _ in range(3):
        inner(x, out)
        inner(out, x)
    inner(x, out)
    return float(out.sum())


def test_a_loop_that_calls_closures_is_right_whichever_processes_compiled_them(tmp_path):
    """Two forked workers compile a variant each (one symbol: the counter they share from the
    fork); a new process runs both, in either order. A cached caller would take the first
    variant loaded for both (checked: the second of either order gave the first's number)."""
    _package(tmp_path, 1.0)
    _run(tmp_path, FORKED)
    for flags in ((True, False), (False, True)):
        got = _run(tmp_path, RUN.format(flags=flags))
        np.testing.assert_allclose([float(v) for v in got[::2]], [_expected(f, 1.0) for f in flags], rtol=RTOL)
    assert not list((tmp_path / "kpkg" / "__pycache__").glob("*outer*.nbc"))  # compiled per process: no file more each time
    assert len(list((tmp_path / "kpkg" / "__pycache__").glob("*inner*.nbc"))) == 2  # the callees are cached


# two variants of one closure called by one loop, as the loads' loop once called its Newton pass and its final pass
VARIANTS = textwrap.dedent("""
    import functools
    import numpy as np
    from uqdrive.vehicle.dynamics.jit import compiled

    @functools.lru_cache(maxsize=None)
    def variant(flag):
        def each(x, out):
            for i in range(x.shape[0]):
                a = x[i]
                for _ in range(7):
                    a = np.sin(a) * (2.0 if flag else 3.0) + np.cos(a * 1.1) - np.tanh(a)
                out[i] = a
        return compiled(each)

    @functools.lru_cache(maxsize=None)
    def both():
        first, second = variant(True), variant(False)

        def outer(x, out, other):
            first(x, out)
            second(x, other)
        return compiled(outer)
""")


def test_a_loop_calls_each_variant_of_a_closure_that_forked_workers_compiled(tmp_path):
    """Each variant compiled and cached by a worker of its own, forked from one state (numba's
    counter in their symbols alike); a new process loads both and compiles the loop that calls
    them. With one symbol for both variants the loop called the first loaded for both (checked:
    both sums the True variant's; :func:`uqdrive.vehicle.dynamics.jit.variant_name` tells them apart)."""
    pkg = tmp_path / "vpkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "kernels.py").write_text(VARIANTS)
    _run(tmp_path, "import os\nimport numpy as np\nimport vpkg.kernels as k\nfor flag in (True, False):\n    pid = os.fork()\n"
                   "    if pid == 0:\n        k.variant(flag)(np.linspace(0.0, 1.0, 5), np.zeros(5))\n        os._exit(0)\n    os.waitpid(pid, 0)\n")
    assert len(list((pkg / "__pycache__").glob("*each*.nbc"))) == 2
    got = _run(tmp_path, "import numpy as np\nimport vpkg.kernels as k\nx, a, b = np.linspace(0.0, 1.0, 5), np.zeros(5), np.zeros(5)\n"
                         "k.both()(x, a, b)\nprint(repr(float(a.sum())), repr(float(b.sum())), sum(k.variant(True).stats.cache_hits.values()))\n")
    first, second = _expected(True, 0.0, passes=1), _expected(False, 0.0, passes=1)
    np.testing.assert_allclose([float(got[0]), float(got[1])], [first, second], rtol=RTOL)
    assert got[2] == "1" and abs(first - second) > 1.0  # loaded from the workers' cache; the variants far apart


def test_a_cached_loop_follows_an_edit_of_a_helper_in_another_module(tmp_path):
    """numba's own key reads the loop's file alone: after an edit of ``helper.py`` it would load
    the old machine code; the package's digest in the key compiles it anew."""
    _package(tmp_path, 1.0)
    assert float(_run(tmp_path, RUN.format(flags=(True,)))[0]) == pytest.approx(_expected(True, 1.0), rel=RTOL)
    _package(tmp_path, 2.0)
    assert float(_run(tmp_path, RUN.format(flags=(True,)))[0]) == pytest.approx(_expected(True, 2.0), rel=RTOL)


def test_a_loop_is_loaded_from_the_cache_in_a_new_process(tmp_path):
    _package(tmp_path, 1.0)
    _run(tmp_path, RUN.format(flags=(True,)))
    code = RUN.format(flags=(True,)) + "print(sum(k.make(True).py_func.__closure__[0].cell_contents.stats.cache_hits.values()))\n"
    assert _run(tmp_path, code)[1:] == ["0", "1"]  # outer compiled, inner loaded


def test_the_loads_loop_is_loaded_from_the_cache_in_a_new_process(tmp_path):
    """The loads' Newton loop closes over its terms alone (its passes inlined, no compiled loop
    among its cells): a second process loads it instead of compiling it."""
    code = ("import numpy as np\nfrom uqdrive.vehicle.dynamics import jit, load_newton as L\n"
            "loop = L.newton_loop(False, True, False, False, True, False)\nn = 3\n"
            "K = np.ones((len(L.ROWS), n)); T = np.zeros(n); z = np.zeros(n); pair = np.zeros((2, n))\n"
            "loop(T, K, z, np.ones(n), z, np.ones(n), pair, pair.copy(), z, pair.copy(), pair.copy(), np.zeros((4, n)), 2, 0.0, 2.5, 10.0, 11.0, 1.3)\n"
            "print(jit.calls_closures(loop.py_func), sum(loop.stats.cache_hits.values()))\n")
    env = {**os.environ, "PYTHONPATH": SRC, "NUMBA_CACHE_DIR": str(tmp_path)}
    runs = [subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300) for _ in range(2)]
    assert [r.stdout.split() for r in runs] == [["False", "0"], ["False", "1"]], [r.stderr[-2000:] for r in runs]


def test_the_sources_digest_reads_every_module_of_the_folder(tmp_path):
    for name, text in (("a.py", "x = 1\n"), ("b.py", "y = 2\n")):
        (tmp_path / name).write_text(text)
    before = jit.sources_digest(str(tmp_path))
    jit.sources_digest.cache_clear()
    (tmp_path / "b.py").write_text("y = 3\n")
    assert jit.sources_digest(str(tmp_path)) != before

"""The compiled loops' disk cache: a closure over compiled loops is found again in a new process,
and a loop's cached machine code follows an edit of a helper it calls in another module."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import uqdrive
from uqdrive.vehicle.dynamics import jit
from uqdrive.vehicle.dynamics.load_newton import newton_loop

SRC = str(Path(uqdrive.__file__).parents[1])

# a package of compiled loops: ``outer`` closes over the compiled ``inner``, which calls a helper
# of another module; only ``helper.py`` is edited between the processes
KERNELS = textwrap.dedent("""
    from uqdrive.vehicle.dynamics.jit import compiled
    from .helper import bump

    def make(flag):
        def inner(x):
            return bump(x) * (2.0 if flag else 1.0)
        each = compiled(inner)

        def outer(x):
            return each(x) + 0.5
        return compiled(outer)
""")
HELPER = "from numba import njit\n\n\n@njit\ndef bump(x):\n    return x + {step}\n"
RUN = ("import kpkg.kernels as k\nf = k.make(True)\nvalue = f(1.0)\n"
       "print(value, sum(f.stats.cache_hits.values()), sum(f.stats.cache_misses.values()))\n")


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


def test_a_closure_over_compiled_loops_is_loaded_from_the_cache_in_a_new_process(tmp_path):
    """The first process compiles ``outer`` (a miss), the second loads it (a hit, no miss), and
    the cache folder holds one machine code file per loop, however many processes ran."""
    _package(tmp_path, 1.0)
    first, second, third = (_run(tmp_path, RUN) for _ in range(3))
    assert first == ["4.5", "0", "1"]
    assert second == third == ["4.5", "1", "0"]
    cached = sorted(p.name for p in (tmp_path / "kpkg" / "__pycache__").glob("*.nbc"))
    assert len(cached) == 2 and any("outer" in name for name in cached), cached


def test_a_cached_loop_follows_an_edit_of_a_helper_in_another_module(tmp_path):
    """numba's own key reads the loop's file alone: after an edit of ``helper.py`` it would load
    the old machine code (4.5); the package's digest in the key compiles it anew (6.5)."""
    _package(tmp_path, 1.0)
    assert _run(tmp_path, RUN)[0] == "4.5"
    _package(tmp_path, 2.0)
    assert _run(tmp_path, RUN)[:1] == ["6.5"]
    assert _run(tmp_path, RUN) == ["6.5", "1", "0"]  # and is found again


def test_a_closures_key_is_one_across_processes_and_tells_its_terms_apart():
    """The loads' Newton loop closes over two compiled passes: its key is the same in another
    process and differs where a term differs (the passes' own cells)."""
    terms = dict(pitching=False, transferring=True, slipping=False, sensitive=False, saturating=True, yielding=False)
    code = ("import hashlib\nfrom uqdrive.vehicle.dynamics import jit\nfrom uqdrive.vehicle.dynamics.load_newton import newton_loop\n"
            f"print(hashlib.sha256(jit.closure_key(newton_loop(**{terms!r}).py_func)).hexdigest())\n")
    env = {**os.environ, "PYTHONPATH": SRC}
    other = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120, check=True).stdout.strip()
    import hashlib
    here = hashlib.sha256(jit.closure_key(newton_loop(**terms).py_func)).hexdigest()
    assert here == other
    flipped = jit.closure_key(newton_loop(**{**terms, "saturating": False}).py_func)
    assert hashlib.sha256(flipped).hexdigest() != here


def test_the_sources_digest_reads_every_module_of_the_folder(tmp_path):
    for name, text in (("a.py", "x = 1\n"), ("b.py", "y = 2\n")):
        (tmp_path / name).write_text(text)
    before = jit.sources_digest(str(tmp_path))
    jit.sources_digest.cache_clear()
    (tmp_path / "b.py").write_text("y = 3\n")
    assert jit.sources_digest(str(tmp_path)) != before

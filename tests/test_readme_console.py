"""Every console block of the README, run in a fresh folder, prints the lines the README shows.

The convention the README follows (and this file checks):

* A ```` ```console ```` block is a shell session: a line starting ``$ `` is a command (a line
  ending in ``\\`` continues on the next), every other line is what the commands before it print,
  stdout and stderr together in the order they are written.
* The blocks of the README run in order, in one fresh folder, with ``uqdrive`` on the PATH
  running this checkout's code; each printed line must equal the shown line exactly, in order,
  and the command must print no other line. A shown line ending in `` ...`` stands for a printed
  line that starts with the text before the ``...`` (the tail of a long warning).
* A block that must not run here (hours of work or a whole environment) carries the marker
  ``<!-- console: not run -->`` on the line above it; only blocks of :data:`NOT_RUN` commands
  may carry it, and every fenced block that shows a command is either a console block or marked.
* The tour's prose quotes no decimal number that its console blocks do not print, so that a
  number in the text cannot drift from the run.
* The tour's figures in the docs (``tools/tour_figures.py`` copies them from the tour's discover
  folder) equal, pixel for pixel, the ones this run draws.

The runs are seeded (the config's ``seed``), so the lines match exactly; no tolerance is used.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
import tour_figures  # noqa: E402

sys.path.pop(0)
README = ROOT / "README.md"
NOT_RUN_MARK = "<!-- console: not run -->"
#: The only commands a marked block may hold: a full reproduction, the test suite, the docs build
#: and the environment they set up (minutes to hours, network for the installs).
NOT_RUN = ("make reproduce", "make test", "make docs", "make lock")
FENCE = re.compile(r"^```(\S*)\s*$")


def blocks(text: str):
    """(language, first line number, lines, marked not-run) of every fenced block of ``text``."""
    lines = text.splitlines()
    out, i = [], 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        start, lang = i, m.group(1)
        j = i + 1
        while j < len(lines) and not lines[j].startswith("```"):
            j += 1
        marked = start > 0 and lines[start - 1].strip() == NOT_RUN_MARK
        out.append((lang, start + 1, lines[start + 1:j], marked))
        i = j + 1
    return out


def session(lines):
    """[(command, [shown output lines])] of a console block's lines."""
    steps, pending = [], None
    for line in lines:
        if pending is not None:
            pending += "\n" + line
            if not line.endswith("\\"):
                steps.append((pending, []))
                pending = None
        elif line.startswith("$ "):
            if line.endswith("\\"):
                pending = line[2:]
            else:
                steps.append((line[2:], []))
        elif steps:
            steps[-1][1].append(line)
        elif line.strip():
            raise AssertionError(f"output before any command: {line!r}")
    return steps


def mismatches(shown, printed):
    """Lines where the printed output differs from the shown output (empty: they agree)."""
    bad = []
    for k in range(max(len(shown), len(printed))):
        want = shown[k] if k < len(shown) else "<nothing>"
        got = printed[k] if k < len(printed) else "<nothing>"
        ok = k < len(shown) and k < len(printed) and (
            got.startswith(want[:-4]) if want.endswith(" ...") else got == want)
        if not ok:
            bad.append(f"  shown:   {want}\n  printed: {got}")
    return bad


def problems_of_markers(found):
    """A line per marked block holding a command outside :data:`NOT_RUN`, and per unmarked
    non-console block that shows a command (``$ `` or a ``uqdrive``/``make`` line)."""
    bad = []
    for lang, n, lines, marked in found:
        commands = [l.strip()[2:] if l.strip().startswith("$ ") else l.strip() for l in lines]
        commands = [c.split("#")[0].strip() for c in commands if c and not c.startswith("#")]
        if marked:
            heavy = [c for c in commands if c and not c.startswith(NOT_RUN)]
            if heavy:
                bad.append(f"README.md:{n}: marked not run but holds {heavy[0]!r}: show it in a console block")
        elif lang != "console" and lang != "python" and any(c.startswith(("$ ", "uqdrive", "make ")) for c in
                                                             [l.strip() for l in lines]):
            bad.append(f"README.md:{n}: a ```{lang} block with commands: make it a console block or mark it {NOT_RUN_MARK}")
    return bad


def tour_prose_numbers(text: str) -> set[str]:
    """The decimal numbers of the tour section's prose (outside fenced blocks)."""
    tour = text.split("## A five-minute tour", 1)[1].split("\n## ", 1)[0]
    prose = re.sub(r"```.*?```", "", tour, flags=re.S)
    return set(re.findall(r"(?<![\w.])\d+\.\d+", prose))


def test_markers_and_prose_checks_can_fail():
    page = ("## A five-minute tour\nmu comes out at 0.81.\n\n" + NOT_RUN_MARK + "\n```bash\nmake reproduce\nuqdrive simulate\n```\n"
            "```bash\nuqdrive identify x.nc\n```\n" + NOT_RUN_MARK + "\n```console\n$ make test\n```\n## next\n")
    bad = problems_of_markers(blocks(page))
    assert len(bad) == 2 and "'uqdrive simulate'" in bad[0] and "```bash" in bad[1], bad
    assert tour_prose_numbers(page) == {"0.81"}
    assert mismatches(["a b ...", "c"], ["a b c d", "c"]) == []
    assert len(mismatches(["a b ...", "c"], ["a x", "c", "extra"])) == 2
    assert session(["$ uqdrive x \\", "    --out y", "line"]) == [("uqdrive x \\\n    --out y", ["line"])]


def test_every_readme_block_is_run_or_marked_heavy():
    found = blocks(README.read_text(encoding="utf-8"))
    assert sum(lang == "console" for lang, *_ in found) >= 3  # the tour's blocks are found
    bad = problems_of_markers(found)
    assert not bad, "\n".join(bad)


def _shim(folder: Path) -> Path:
    """A folder with a ``uqdrive`` that runs this checkout's code with this interpreter."""
    bin_ = folder / "bin"
    bin_.mkdir()
    exe = bin_ / "uqdrive"
    exe.write_text(f"#!{sys.executable}\nimport sys\nsys.path.insert(0, {str(ROOT / 'src')!r})\n"
                   "from uqdrive.cli import main\nsys.exit(main())\n")
    exe.chmod(0o755)
    return bin_


@pytest.mark.long(90)
def test_every_console_block_prints_what_the_readme_shows(tmp_path):
    text = README.read_text(encoding="utf-8")
    steps = [s for lang, _, lines, marked in blocks(text) if lang == "console" and not marked for s in session(lines)]
    assert len(steps) >= 4  # simulate, identify, discover, the refit
    work = tmp_path / "fresh"
    work.mkdir()
    env = {**os.environ, "PATH": f"{_shim(tmp_path)}{os.pathsep}{os.environ['PATH']}", "PYTHONUNBUFFERED": "1",
           "PYTHONPATH": str(ROOT / "src")}
    printed_all = []
    for command, shown in steps:
        run = subprocess.run(["bash", "-c", command], cwd=work, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                             text=True, timeout=600)
        printed = run.stdout.splitlines()
        printed_all += printed
        assert run.returncode == 0, f"$ {command}\nexit status {run.returncode}:\n{run.stdout[-3000:]}"
        bad = mismatches(shown, printed)
        assert not bad, f"$ {command}\nprints other lines than the README shows (paste the printed ones):\n" + "\n".join(bad)
    folder = next(c.split("--out", 1)[1].split()[0] for c, _ in steps if c.startswith("uqdrive discover"))
    for name, target in tour_figures.FIGURES.items():
        drawn, committed = plt.imread(work / folder / name), plt.imread(ROOT / "docs" / target)
        assert drawn.shape == committed.shape and np.array_equal(drawn, committed), (
            f"docs/{target} is not the tour's {name}: run `python tools/tour_figures.py`")
    printed_numbers = set(re.findall(r"\d+\.\d+", "\n".join(printed_all)))
    stray = tour_prose_numbers(text) - printed_numbers
    assert not stray, f"the tour's prose quotes numbers its commands do not print: {sorted(stray)}"

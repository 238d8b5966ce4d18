"""Write the tour's figures of the docs (docs/tour_bands.png, docs/tour_localisation.png) by
running the README's tour: its `uqdrive simulate` and `uqdrive discover` lines, in a fresh folder.

Run `python tools/tour_figures.py` after changing a figure's code or what the tour computes;
tests/test_readme_console.py runs the same tour and fails while the committed figures differ,
pixel for pixel, from the ones it draws.
"""

from __future__ import annotations

import re
import shlex
import shutil
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
#: The discover outputs copied into docs/, and their names there.
FIGURES = {"bands.png": "tour_bands.png", "localisation.png": "tour_localisation.png"}


def tour_commands(text: str) -> list[list[str]]:
    """The argv (after `uqdrive`) of the tour's simulate and discover lines of the README."""
    lines = re.findall(r"^\$ uqdrive ((?:simulate|discover) .*)$", text, flags=re.MULTILINE)
    if [line.split()[0] for line in lines] != ["simulate", "discover"]:
        raise SystemExit("tools/tour_figures.py: the README's tour has no single `$ uqdrive simulate` then `$ uqdrive discover` line")
    return [shlex.split(line) for line in lines]


def discover_folder(argv: list[str]) -> str:
    """The --out folder of a discover command line."""
    return argv[argv.index("--out") + 1]


def main() -> int:
    sys.path.insert(0, str(ROOT / "src"))
    from uqdrive.cli import main as uqdrive

    commands = tour_commands(README.read_text(encoding="utf-8"))
    with tempfile.TemporaryDirectory() as tmp:
        import os

        here = os.getcwd()
        os.chdir(tmp)
        try:
            for argv in commands:
                if uqdrive(argv) != 0:
                    raise SystemExit(f"uqdrive {' '.join(argv)} failed")
            out = Path(tmp) / discover_folder(commands[1])
            for name, target in FIGURES.items():
                shutil.copyfile(out / name, ROOT / "docs" / target)
                print(f"wrote docs/{target}")
        finally:
            os.chdir(here)
    return 0


if __name__ == "__main__":
    sys.exit(main())

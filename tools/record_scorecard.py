#!/usr/bin/env python
"""Copy a reproduction's scorecard into the docs' committed record, from which the reproduction
page's results are written at every docs build (docs/reproduction_tables.py). Usage::

    .venv/bin/python tools/record_scorecard.py [results/scorecard.csv]
"""

from __future__ import annotations

import csv
import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RECORD = ROOT / "docs" / "measurements" / "scorecard.csv"
sys.path.insert(0, str(ROOT / "src"))

from uqdrive.studies.scorecard import COLUMNS  # noqa: E402


def main(argv: list[str]) -> int:
    source = Path(argv[0]) if argv else ROOT / "results" / "scorecard.csv"
    if not source.is_file():
        print(f"record_scorecard: no scorecard at {source}; run `make reproduce` or name the file", file=sys.stderr)
        return 2
    with open(source, newline="") as fh:
        header = tuple(csv.DictReader(fh).fieldnames or ())
    if header[: len(COLUMNS)] != COLUMNS:
        print(f"record_scorecard: {source} has the columns {','.join(header)}; expected {','.join(COLUMNS)} first", file=sys.stderr)
        return 2
    shutil.copyfile(source, RECORD)
    print(f"recorded {source} in {RECORD.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

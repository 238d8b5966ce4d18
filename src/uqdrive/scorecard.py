"""The scorecard: one row per published number of the seeds that uqdrive reproduces.

Each experiment family writes its rows; the workflow merges them into ``results/scorecard.csv``.
"""

from __future__ import annotations

import csv
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Iterable, Mapping

import numpy as np

from .control import lqr_gain
from .io import atomic_path
from .uncertainty import KarhunenLoeve
from .vehicle import VehicleParameters, lst_matrices

__all__ = ["COLUMNS", "ScoreRow", "compare", "write_scorecard", "read_scorecard", "foundation_rows"]

COLUMNS = ("quantity", "source", "published", "reproduced", "tolerance", "status")

#: Thesis eq. (6.1): LQR gain of the mean LST model, printed to two decimals.
THESIS_LQR_GAIN = (-1.85, -0.05, -0.49, -0.32)
#: Thesis sec. 7.3 / Fig 7.1: eigenpairs kept by the KLE (350 points, p_c = 0.95).
THESIS_KLE_MODES = 5


@dataclass(frozen=True)
class ScoreRow:
    quantity: str
    source: str
    published: float
    reproduced: float
    tolerance: float
    status: str


def compare(quantity: str, source: str, published: float, reproduced: float, tolerance: float) -> ScoreRow:
    """A row with status ``pass`` when |reproduced - published| <= tolerance."""
    ok = bool(np.isfinite(reproduced) and abs(reproduced - published) <= tolerance + 1e-12)
    return ScoreRow(quantity, source, float(published), float(reproduced), float(tolerance), "pass" if ok else "fail")


def write_scorecard(rows: Iterable[ScoreRow], path: str | Path) -> None:
    """Write rows as CSV with the columns of :data:`COLUMNS`, atomically."""
    with atomic_path(path) as tmp:
        with open(tmp, "w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=COLUMNS)
            writer.writeheader()
            for row in rows:
                writer.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in asdict(row).items()})


def read_scorecard(path: str | Path) -> list[ScoreRow]:
    with open(path, newline="") as fh:
        return [
            ScoreRow(r["quantity"], r["source"], float(r["published"]), float(r["reproduced"]), float(r["tolerance"]), r["status"])
            for r in csv.DictReader(fh)
        ]


def foundation_rows(config: Mapping[str, Any], kle: KarhunenLoeve) -> list[ScoreRow]:
    """Rows of the foundation: the LQR gain of the mean LST vs (6.1), the KLE mode count vs sec. 7.3.

    The gain is printed with two decimals, so the tolerance is half a unit of the last digit.
    """
    A, B, _ = lst_matrices(VehicleParameters.from_config(config))
    ctl = config["control"]
    K = lqr_gain(A, B, np.diag(ctl["Q_diag"]), ctl["R"])[0]
    rows = [
        compare(f"LQR gain K[{i + 1}] (mean LST)", "thesis eq. (6.1)", pub, K[i], 0.005)
        for i, pub in enumerate(THESIS_LQR_GAIN)
    ]
    rows.append(compare("KLE eigenpairs kept (p_c = 0.95)", "thesis sec. 7.3, Fig. 7.1", THESIS_KLE_MODES, kle.n_modes, 0.0))
    return rows

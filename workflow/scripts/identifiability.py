"""Rule identifiability: rank of the non-linear observability matrix (3.9)-(3.12)."""
import csv
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from uqdrive.inference.identifiability import observability_analysis
from uqdrive.io import atomic_path
from uqdrive.settings import Settings

r = observability_analysis(Settings.from_config(snakemake.params.config))  # noqa: F821
with atomic_path(snakemake.output[0]) as tmp:  # noqa: F821
    with open(tmp, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["column removed", "rank", "full rank", "identifiability guaranteed", "null-vector component"])
        w.writerow(["(none)", r.rank, len(r.names), r.rank == len(r.names), ""])
        for name, null in zip(r.names, r.null_vector):
            w.writerow([name, r.removal_rank[name], len(r.names), r.removal_rank[name] < r.rank, f"{null:.3g}"])

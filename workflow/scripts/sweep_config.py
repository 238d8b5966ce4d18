"""Rule sweep_config: the resolved config of one sweep point, saved next to its results."""
import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import yaml

from uqdrive.io import atomic_path

p = snakemake.params  # noqa: F821
with atomic_path(snakemake.output[0]) as tmp:  # noqa: F821
    tmp.write_text(f"# {p.header}\n" + yaml.safe_dump(dict(p.config), sort_keys=False, width=120))

"""Rule sweep_point: the workflow on one point's config into its own folder (only the outputs the
sweep collects), then the point's metrics and provenance as JSON.

Jobs marked `cache:` come from the sweep's cache when another point (or an earlier run) made them
with the same settings, code and inputs (Snakemake's between-workflow cache)."""
import sys

sys.stderr = log = open(snakemake.log[0], "w")  # noqa: F821

import json
import os
import subprocess
from pathlib import Path

from uqdrive.config import load_config, provenance
from uqdrive.io import atomic_path
from uqdrive.studies.sweep.summary import point_metrics

p = snakemake.params  # noqa: F821
Path(p.cache).mkdir(parents=True, exist_ok=True)
command = [sys.executable, "-m", "snakemake", "-s", p.snakefile, "--directory", os.getcwd(), "--configfile", snakemake.input.config,  # noqa: F821
           "--cores", str(snakemake.threads), "--nolock", "--rerun-incomplete", "--cache", "--", *p.targets]  # noqa: F821
print(" ".join(command), file=log, flush=True)
env = dict(os.environ, SNAKEMAKE_OUTPUT_CACHE=str(Path(p.cache).resolve()))
if subprocess.run(command, stdout=log, stderr=subprocess.STDOUT, env=env).returncode:
    sys.exit(f"the workflow failed on {snakemake.input.config}; see {snakemake.log[0]}")  # noqa: F821
config = load_config(snakemake.input.config)  # noqa: F821
record = {"name": Path(p.outdir).name, "values": p.values, "metrics": point_metrics(p.collect, p.outdir, config),
          "provenance": provenance(config, snakemake.input.config)}  # noqa: F821
with atomic_path(snakemake.output[0]) as tmp:  # noqa: F821
    tmp.write_text(json.dumps(record, indent=1) + "\n")

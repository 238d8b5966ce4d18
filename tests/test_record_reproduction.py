"""tools/record_reproduction.py sums Snakemake's benchmark files by rule and counts the scorecard."""

import importlib.util
import json
from pathlib import Path

TOOL = Path(__file__).resolve().parents[1] / "tools" / "record_reproduction.py"
HEADER = "s\th:m:s\tmax_rss\tmax_vms\tmax_uss\tmax_pss\tio_in\tio_out\tmean_load\tcpu_time\n"


def _tool():
    spec = importlib.util.spec_from_file_location("record_reproduction", TOOL)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_rules_summed_ranked_and_the_rest_pooled(tmp_path):
    results = tmp_path / "results"
    jobs = {"slow": [(30.0, 20.0), (50.0, 45.0)], **{f"r{i}": [(float(i), 0.5)] for i in range(1, 10)}}
    for rule, times in jobs.items():
        (results / "benchmarks" / rule).mkdir(parents=True)
        for k, (s, cpu) in enumerate(times):
            (results / "benchmarks" / rule / f"{rule}_{k}.tsv").write_text(HEADER + f"{s}\t0:00:{int(s)}\t1\t1\t1\t1\t0\t0\t50\t{cpu}\n")
    (results / "scorecard.csv").write_text("quantity,status\na,pass\nb,deviates\nc,pass\nd,fail\n")
    log = tmp_path / ".snakemake" / "log"
    log.mkdir(parents=True)
    (log / "2026-01-01T000000.snakemake.log").write_text("11 of 12 steps (92%) done\n12 of 12 steps (100%) done\n")
    out = tmp_path / "rec.json"
    _tool().main([str(results), "--wall-s", "99.6", "--machine", "m", "--json", str(out)])
    rec = json.loads(out.read_text())
    assert rec["dag_jobs"] == 12 and rec["wall_s"] == 100
    assert rec["job_seconds"] == 80 + 45 and rec["cpu_seconds"] == round(65 + 9 * 0.5)
    assert rec["rules"][0] == {"rule": "slow", "jobs": 2, "job_seconds": 80, "longest_s": 50, "cpu_seconds": 65}
    assert [r["rule"] for r in rec["rules"][1:]] == ["r9", "r8", "r7", "r6", "r5", "r4", "r3"]
    assert rec["other_rules"] == {"rules": 2, "jobs": 2, "job_seconds": 3}
    assert rec["scorecard"] == {"rows": 4, "pass": 2, "deviate": 1, "fail": 1}

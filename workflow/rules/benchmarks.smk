# Every rule writes a benchmark file (its jobs' max_rss and wall time: tools/rule_resources.py,
# docs/cluster.md). Snakemake refuses a benchmark on a rule taken from the between-workflow cache
# (a cached result has no measurement), so where --cache is on (sweep points) the cached rules
# go without one.
if CACHE:
    for cached in [r for r in workflow.rules if r.cache]:
        cached._benchmark = None

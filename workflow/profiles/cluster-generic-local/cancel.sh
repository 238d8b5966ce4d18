#!/usr/bin/env bash
# Cancel command of the local stand-in for a cluster (see submit.sh): ends every process of the
# jobs whose ids Snakemake passes (each job runs in a session and process group of its own).
for id in "$@"; do
    kill -TERM -- "-$id" 2> /dev/null || true
done

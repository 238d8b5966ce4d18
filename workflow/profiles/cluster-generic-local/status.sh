#!/usr/bin/env bash
# Status command of the local stand-in for a cluster (see submit.sh): prints exactly one of
# running, success, failed for the job id Snakemake passes.
#   success/failed: the job wrote its exit code (0 / not 0);
#   running:        no exit code yet and the job's process is alive;
#   failed:         no exit code and no process (killed with kill -9, or the machine restarted).
set -uo pipefail
# Ctrl-C reaches every process of Snakemake's process group; a status check cut short by it makes
# the plugin fail the check instead of cancelling the jobs, so this short script lets it pass.
trap '' INT
id=$1
dir=${UQDRIVE_LOCAL_CLUSTER_DIR:-.snakemake/local-cluster}
exit_code() { [ -f "$dir/$id.exit" ] && { [ "$(cat "$dir/$id.exit")" = 0 ] && echo success || echo failed; }; }
exit_code && exit 0
if kill -0 "$id" 2> /dev/null; then
    echo running
else
    exit_code || echo failed  # it may have ended between the two looks
fi

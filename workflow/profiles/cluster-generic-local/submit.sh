#!/usr/bin/env bash
# Stand-in for a batch system's submit command (sbatch, qsub, bsub) on one machine, for
# snakemake-executor-plugin-cluster-generic: runs the job script Snakemake hands over in the
# background, in a session of its own (so that cancel.sh can end the job and all its processes),
# and prints the job id (the session's process id) on one line. What a job leaves:
#   $UQDRIVE_LOCAL_CLUSTER_DIR/<id>.log   the job's output (default folder: .snakemake/local-cluster)
#   $UQDRIVE_LOCAL_CLUSTER_DIR/<id>.exit  its exit code, written when it ends (status.sh reads it)
# Snakemake calls it as `submit.sh JOBSCRIPT` in the working directory of the run.
set -euo pipefail
jobscript=$1
dir=${UQDRIVE_LOCAL_CLUSTER_DIR:-.snakemake/local-cluster}
mkdir -p "$dir"
# setsid runs bash in a new session whose id is bash's pid ($! here, $$ inside): the job id.
# The exit code goes to <id>.exit.tmp first and is renamed, so status.sh never reads half a file.
setsid bash -c 'bash "$1" > "$2/$$.log" 2>&1; echo $? > "$2/$$.exit.tmp"; mv "$2/$$.exit.tmp" "$2/$$.exit"' \
    job "$jobscript" "$dir" < /dev/null > /dev/null 2>&1 &
echo $!

#!/usr/bin/env bash
# Cancel command of the local stand-in for a cluster (see submit.sh): ends every process of the
# jobs whose ids Snakemake passes (each job runs in a session and process group of its own).
# As Slurm's scancel (SIGTERM, then SIGKILL after KillWait): a job's Snakemake that gets SIGTERM
# while it selects jobs deadlocks in its own handler (it waits forever on the scheduler lock it
# holds), so whatever is left after 10 s is killed.
for id in "$@"; do
    kill -TERM -- "-$id" 2> /dev/null || true
done
(
    sleep 10
    for id in "$@"; do
        kill -KILL -- "-$id" 2> /dev/null || true
    done
) < /dev/null > /dev/null 2>&1 &

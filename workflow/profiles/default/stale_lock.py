"""Before `make reproduce` runs Snakemake: clear a stale lock, and never start beside a run or the
jobs of a run that still work in this folder (docs/workflow.md, "Resuming, repeatability, refusals").

A Snakemake run killed hard (kill -9, out of memory, power loss) leaves its lock in
.snakemake/locks, and the next run stops with "Directory cannot be locked" (LockException); its
jobs may still be running and writing their outputs, as may the jobs of a cluster run that was
stopped with Ctrl-C before it could cancel them. Run from the folder Snakemake works in, this script
  * stops (exit 2) with one line naming the Snakemake processes that still work in this folder
    (a run in progress, or jobs a stopped run left behind) and how to end them;
  * otherwise removes a lock, as `snakemake --unlock` does, and says so in one line (exit 0);
  * does nothing when there is neither (exit 0).
Processes are read from /proc (Linux); where there is none, a lock stops it with the command that
clears the lock by hand.
"""

import os
import sys
from pathlib import Path

LOCKS = Path(".snakemake") / "locks"
UNLOCK = ".venv/bin/snakemake --unlock"


def _is_snakemake(argv):
    """A Snakemake run (`snakemake`, `python -m snakemake`, a cluster job's), a job's script
    (.snakemake/scripts/...) or a cluster job script (.snakemake/tmp.*/snakejob.*)."""
    return any(Path(a).name == "snakemake" or ".snakemake/scripts/" in a or ".snakemake/tmp." in a for a in argv)


def snakemake_processes(folder):
    """(pid, command) of the processes of this user whose command is Snakemake's and whose working
    directory is ``folder`` or below it; None where processes cannot be read."""
    proc = Path("/proc")
    if not (proc / "self" / "cwd").exists():
        return None
    own = {os.getpid(), os.getppid()}
    found = []
    for entry in proc.iterdir():
        if not entry.name.isdigit() or int(entry.name) in own:
            continue
        try:
            argv = (entry / "cmdline").read_bytes().decode(errors="replace").split("\0")
            cwd = Path(os.readlink(entry / "cwd"))
        except OSError:  # gone, or another user's
            continue
        if _is_snakemake(argv) and (cwd == folder or folder in cwd.parents):
            found.append((int(entry.name), " ".join(a for a in argv if a)))
    return sorted(found)


def main():
    locks = sorted(LOCKS.glob("*.lock")) if LOCKS.is_dir() else []
    running = snakemake_processes(Path.cwd().resolve())
    if running:
        shown = "; ".join(f"pid {pid}: {cmd[:80]}" for pid, cmd in running[:4]) + (" ..." if len(running) > 4 else "")
        print(f"uqdrive: {len(running)} Snakemake process(es) still run in this folder ({shown}): a run in progress, "
              f"or jobs left by a run that was stopped. Let them finish or end them (kill {' '.join(str(p) for p, _ in running)}; "
              f"kill -9 the ones still there after a minute: a Snakemake told to stop while it selects jobs can hang), "
              f"then run `make reproduce` again" + (f"; `{UNLOCK}` clears the lock by hand." if locks else "."), file=sys.stderr)
        return 2
    if not locks:
        return 0
    if running is None:
        print(f"uqdrive: {LOCKS} holds a lock. If no other Snakemake runs in this folder (a run was killed), "
              f"clear it with `{UNLOCK}` and run `make reproduce` again.", file=sys.stderr)
        return 2
    for lock in locks:
        lock.unlink(missing_ok=True)
    print(f"uqdrive: removed the stale lock of a Snakemake run that was killed ({len(locks)} file(s) in {LOCKS}, "
          f"what `{UNLOCK}` does); no Snakemake process runs in this folder.", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())

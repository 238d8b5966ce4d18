#!/usr/bin/env bash
# A one-node Slurm cluster with accounting on this machine, for CI, the developers and anyone who
# wants to try the workflow's Slurm path (docs/cluster.md) without a cluster:
#
#   tools/slurm_cluster.sh install   Debian's packages (munge, slurm-wlm, slurmdbd, mariadb-server)
#   tools/slurm_cluster.sh start     munged, MariaDB, slurmdbd, slurmctld, slurmd; waits until the
#                                    node takes jobs, then prints the line that points Slurm's
#                                    commands at it:  export SLURM_CONF=<folder>/etc/slurm.conf
#   tools/slurm_cluster.sh stop      cancels the cluster's jobs, ends the daemons it started
#   tools/slurm_cluster.sh status    which daemons run; sinfo
#   tools/slurm_cluster.sh conf      prints the path of slurm.conf (for SLURM_CONF)
#
# Everything (configs, munge key and socket, databases, spool, logs, the daemons' pid files) lives
# in one folder, $UQDRIVE_SLURM_DIR (default ${TMPDIR:-/tmp}/uqdrive-slurm); nothing goes to /etc,
# no systemd, no cgroups. Runs as root (the daemons and the jobs run as root). `stop` ends only the
# processes `start` launched, by the ids it recorded, and checks that each id still names the
# daemon before it signals it. The node's CPUs and memory are the machine's own (`slurmd -C`).
#
# Pitfalls this script steps around (each cost a failed start):
# * munged refuses a socket folder that others may write and a key or log below /tmp unless
#   forced: the socket folder is mode 755 and munged runs with --force;
# * slurmctld's link to slurmdbd ignores AuthInfo=socket= unless AccountingStoragePass names the
#   munge socket as well;
# * no systemd/cgroups: ProctrackType=proctrack/linuxproc, TaskPlugin=task/none;
# * every wait is bounded by wall-clock seconds (a failing sacctmgr call alone takes ~2 s);
# * snakemake-executor-plugin-slurm-jobstep drops every SLURM_* variable, SLURM_CONF too, before
#   the srun inside a job, and srun then finds no config: /etc/slurm/slurm.conf, where Slurm's
#   commands look first, is made a link to this cluster's slurm.conf (only where that path is free;
#   `stop` removes the link). Slurm's commands then need no SLURM_CONF either.
set -euo pipefail

DIR=${UQDRIVE_SLURM_DIR:-${TMPDIR:-/tmp}/uqdrive-slurm}
CLUSTER=uqdrive
ACCOUNT=uqdrive
PARTITION=debug
PORT_BASE=${UQDRIVE_SLURM_PORT_BASE:-6817}   # slurmctld, slurmd, slurmdbd: this and the next two
WAIT=${UQDRIVE_SLURM_WAIT:-60}               # seconds each daemon may take to answer
PACKAGES=(munge slurm-wlm slurmctld slurmd slurm-client slurmdbd mariadb-server)
ETC_CONF=/etc/slurm/slurm.conf
DAEMONS=(munged mariadbd slurmdbd slurmctld slurmd)   # start order; stop goes backwards

say() { echo "slurm_cluster: $*" >&2; }
die() { say "$*"; exit 1; }

# wait_for SECONDS WHAT COMMAND...: run COMMAND until it succeeds, at most SECONDS of wall clock.
wait_for() {
    local seconds=$1 what=$2 end=$((SECONDS + $1))
    shift 2
    until "$@" > /dev/null 2>&1; do
        if ((SECONDS >= end)); then
            say "$what did not happen within ${seconds} s; logs in $DIR/log:"
            tail -n 5 "$DIR"/log/*.log >&2 || true
            return 1
        fi
        sleep 0.5
    done
}

# alive NAME: the recorded process of daemon NAME runs, and it is still that daemon.
alive() {
    local pid
    pid=$(cat "$DIR/pids/$1" 2> /dev/null) || return 1
    [ -r "/proc/$pid/cmdline" ] && tr '\0' ' ' < "/proc/$pid/cmdline" | grep -q -- "$1"
}

# launch NAME COMMAND...: start a daemon in the foreground mode of its own, in the background, in
# a session of its own, and record its process id.
launch() {
    local name=$1
    shift
    setsid "$@" < /dev/null >> "$DIR/log/$name.out" 2>&1 &
    echo $! > "$DIR/pids/$name"
}

cmd_install() {
    local missing=()
    for tool in munged slurmctld slurmd sbatch slurmdbd mariadbd; do
        command -v "$tool" > /dev/null || missing+=("$tool")
    done
    if ((${#missing[@]} == 0)); then
        say "installed already ($(slurmd -V))"
        return 0
    fi
    [ "$(id -u)" = 0 ] || die "installing needs root: sudo $0 install (missing: ${missing[*]})"
    say "installing ${PACKAGES[*]} (missing: ${missing[*]})"
    export DEBIAN_FRONTEND=noninteractive
    # Packages that come with a service ask the init system not to start it: this script starts
    # its own daemons, in its own folder.
    apt-get install -y -q --no-install-recommends "${PACKAGES[@]}" > "${TMPDIR:-/tmp}/uqdrive-slurm-apt.log" 2>&1 || {
        apt-get update -q > /dev/null
        apt-get install -y -q --no-install-recommends "${PACKAGES[@]}" > "${TMPDIR:-/tmp}/uqdrive-slurm-apt.log" 2>&1
    } || die "apt-get install failed: ${TMPDIR:-/tmp}/uqdrive-slurm-apt.log"
}

write_configs() {
    local node munge_socket="$DIR/munge/munge.socket.2"
    # The machine as slurmd sees it: NodeName=<host> CPUs=.. Boards=.. ... RealMemory=<MB>.
    node=$(slurmd -C | head -n 1)
    [[ $node == NodeName=* ]] || die "slurmd -C did not describe this machine: $node"
    cat > "$DIR/etc/slurm.conf" << EOF
# Written by tools/slurm_cluster.sh: a one-node cluster in $DIR.
ClusterName=$CLUSTER
SlurmctldHost=$(hostname -s)(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$munge_socket
SlurmctldPort=$PORT_BASE
SlurmdPort=$((PORT_BASE + 1))
StateSaveLocation=$DIR/spool/ctld
SlurmdSpoolDir=$DIR/spool/d
SlurmctldPidFile=$DIR/run/slurmctld.pid
SlurmdPidFile=$DIR/run/slurmd.pid
SlurmctldLogFile=$DIR/log/slurmctld.log
SlurmdLogFile=$DIR/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
DefMemPerCPU=1000
MpiDefault=none
ReturnToService=2
SchedulerType=sched/backfill
# Memory and time of every job step, sampled each second (short jobs end between 30 s samples).
JobAcctGatherType=jobacct_gather/linux
JobAcctGatherFrequency=task=1
AccountingStorageType=accounting_storage/slurmdbd
AccountingStorageHost=localhost
AccountingStoragePort=$((PORT_BASE + 2))
AccountingStoragePass=$munge_socket
# sacct's Comment column: the plugin writes each job's group or rule there.
AccountingStoreFlags=job_comment
JobCompType=jobcomp/none
KillWait=10
$node NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=$PARTITION Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF
    # slurmdbd reads slurmdbd.conf beside slurm.conf (SLURM_CONF) and wants it private.
    cat > "$DIR/etc/slurmdbd.conf" << EOF
AuthType=auth/munge
AuthInfo=socket=$munge_socket
DbdHost=localhost
DbdPort=$((PORT_BASE + 2))
SlurmUser=root
LogFile=$DIR/log/slurmdbd.log
PidFile=$DIR/run/slurmdbd.pid
StorageType=accounting_storage/mysql
StorageHost=localhost
StorageUser=root
StorageLoc=slurm_acct_db
EOF
    chmod 600 "$DIR/etc/slurmdbd.conf"
}

cmd_start() {
    [ "$(id -u)" = 0 ] || die "the daemons run as root: sudo $0 start"
    for tool in munged slurmctld slurmd slurmdbd mariadbd sinfo; do
        command -v "$tool" > /dev/null || die "$tool is missing: run $0 install first"
    done
    local running=0
    for d in "${DAEMONS[@]}"; do alive "$d" && running=$((running + 1)); done
    if ((running == ${#DAEMONS[@]})); then
        say "running already in $DIR"
        echo "export SLURM_CONF=$DIR/etc/slurm.conf"
        return 0
    fi
    ((running == 0)) || { say "some daemons of an earlier start still run: stopping them first"; cmd_stop; }
    if [ -e "$ETC_CONF" ] || [ -L "$ETC_CONF" ]; then
        [ "$(readlink "$ETC_CONF")" = "$DIR/etc/slurm.conf" ] ||
            die "$ETC_CONF exists and is not this cluster's: on a machine with a Slurm of its own, use that Slurm"
    fi
    local t0=$SECONDS
    # Each start is a new cluster: job ids from 1 and an empty accounting database (a job left in
    # the state of a cluster that was killed would run again, and its id would repeat in sacct).
    rm -rf "${DIR:?}"/{etc,log,pids,run,spool,mysql}
    mkdir -p "$DIR"/{etc,munge,log,pids,run,spool/ctld,spool/d,mysql}
    chmod 755 "$DIR" "$DIR/munge"
    export SLURM_CONF=$DIR/etc/slurm.conf
    write_configs
    mkdir -p "$(dirname "$ETC_CONF")"
    ln -sfn "$DIR/etc/slurm.conf" "$ETC_CONF"

    # munge: its own key and socket.
    [ -s "$DIR/munge/munge.key" ] || { dd if=/dev/urandom of="$DIR/munge/munge.key" bs=1024 count=1 status=none; }
    chmod 400 "$DIR/munge/munge.key"
    launch munged munged --foreground --force --socket="$DIR/munge/munge.socket.2" --key-file="$DIR/munge/munge.key" \
        --pid-file="$DIR/run/munged.pid" --log-file="$DIR/log/munged.log" --seed-file="$DIR/munge/munged.seed"
    wait_for "$WAIT" "munged's socket" test -S "$DIR/munge/munge.socket.2"

    # MariaDB for slurmdbd: its socket only, no network port.
    export MYSQL_UNIX_PORT=$DIR/run/mysqld.sock
    if [ ! -d "$DIR/mysql/mysql" ]; then  # always, as the folder is new
        mariadb-install-db --no-defaults --datadir="$DIR/mysql" --user=root --auth-root-authentication-method=normal \
            --skip-test-db > "$DIR/log/mariadb-install.log" 2>&1 || die "mariadb-install-db failed: $DIR/log/mariadb-install.log"
    fi
    launch mariadbd mariadbd --no-defaults --datadir="$DIR/mysql" --socket="$MYSQL_UNIX_PORT" --skip-networking \
        --pid-file="$DIR/run/mariadbd.pid" --log-error="$DIR/log/mariadbd.log" --user=root
    wait_for "$WAIT" "MariaDB's socket" test -S "$MYSQL_UNIX_PORT"

    # slurmdbd (finds the database through MYSQL_UNIX_PORT), then the cluster and an account.
    launch slurmdbd slurmdbd -D
    wait_for "$WAIT" "slurmdbd answering sacctmgr" sacctmgr -n list cluster
    if ! sacctmgr -n -P list cluster format=cluster | grep -qx "$CLUSTER"; then
        sacctmgr -i add cluster "$CLUSTER" > /dev/null
        sacctmgr -i add account "$ACCOUNT" cluster="$CLUSTER" description=uqdrive organization=uqdrive > /dev/null
        sacctmgr -i add user root account="$ACCOUNT" cluster="$CLUSTER" > /dev/null
    fi

    launch slurmctld slurmctld -D -f "$SLURM_CONF"
    wait_for "$WAIT" "slurmctld answering sinfo" sinfo -h
    launch slurmd slurmd -D -f "$SLURM_CONF"
    node_idle() { sinfo -h -N -o %T | grep -qE '^(idle|mixed|allocated)'; }
    wait_for "$WAIT" "the node taking jobs" node_idle
    say "started in $((SECONDS - t0)) s: $(sinfo -h -N -o '%N %c CPUs %m MB %T'), partition $PARTITION, account $ACCOUNT"
    echo "export SLURM_CONF=$SLURM_CONF"
}

cmd_stop() {
    export SLURM_CONF=$DIR/etc/slurm.conf MYSQL_UNIX_PORT=$DIR/run/mysqld.sock
    if alive slurmctld && [ -n "$(squeue -h -o %i 2> /dev/null)" ]; then
        say "cancelling the cluster's jobs: $(squeue -h -o %i | tr '\n' ' ')"
        scancel --full "$(squeue -h -o %i)" 2> /dev/null || scancel -u root || true
        wait_for 30 "the jobs ending" test -z "$(squeue -h -o %i 2> /dev/null)" || true
    fi
    local i d pid end
    for ((i = ${#DAEMONS[@]} - 1; i >= 0; i--)); do
        d=${DAEMONS[i]}
        if alive "$d"; then
            pid=$(cat "$DIR/pids/$d")
            kill -TERM "$pid"
            end=$((SECONDS + 30))
            while alive "$d" && ((SECONDS < end)); do sleep 0.2; done
            if alive "$d"; then
                say "$d (pid $pid) still ran 30 s after SIGTERM: SIGKILL"
                kill -KILL "$pid" 2> /dev/null || true
            fi
        fi
        rm -f "$DIR/pids/$d"
    done
    [ "$(readlink "$ETC_CONF" 2> /dev/null)" = "$DIR/etc/slurm.conf" ] && rm -f "$ETC_CONF"
    say "stopped (state and logs kept in $DIR)"
}

cmd_status() {
    export SLURM_CONF=$DIR/etc/slurm.conf
    local up=0
    for d in "${DAEMONS[@]}"; do
        if alive "$d"; then echo "$d: pid $(cat "$DIR/pids/$d")"; up=$((up + 1)); else echo "$d: not running"; fi
    done
    ((up == ${#DAEMONS[@]})) && sinfo
    ((up == ${#DAEMONS[@]}))
}

case "${1:-}" in
    install) cmd_install ;;
    start) cmd_start ;;
    stop) cmd_stop ;;
    status) cmd_status ;;
    conf) echo "$DIR/etc/slurm.conf" ;;
    *) echo "usage: $0 install|start|stop|status|conf   (folder: $DIR)" >&2; exit 2 ;;
esac

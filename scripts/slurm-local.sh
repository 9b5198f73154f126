#!/usr/bin/env bash
# A one-node SLURM cluster on this machine, for trying scripts/frames.sbatch
# and for the test suite's SLURM test (tests/slurm.rs).
#
# Usage: bash scripts/slurm-local.sh [start|stop|status]
#   start   (default) installs slurm-wlm and munge through scripts/env.sh,
#           writes /etc/slurm/slurm.conf for this machine (one node, its CPUs
#           from nproc), starts munged, slurmctld and slurmd as plain daemons
#           (no systemd needed) and waits until sinfo shows the node idle.
#           Prints "started" when it started a daemon, "running" when
#           everything already ran. A SLURM that answers already (a real
#           cluster, or an earlier start) is used as it is.
#   stop    stops the daemons that `start` started (by the pids it recorded).
#   status  exits 0 when a SLURM answers and a node is up, 1 otherwise.
#
# Idempotent; as root, or re-run through sudo. Everything it writes is under
# /etc/slurm/slurm.conf (marked as ours: a configuration it did not write is
# never replaced), /var/lib/isomarch-slurm and /run/isomarch-slurm.

set -euo pipefail

if [ "$(id -u)" -ne 0 ]; then
    exec sudo -E bash "$0" "$@"
fi

action="${1:-start}"
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
conf=/etc/slurm/slurm.conf
marker="# Written by isomarch scripts/slurm-local.sh"
state=/var/lib/isomarch-slurm
run=/run/isomarch-slurm
node="$(hostname -s)"

say() { echo "slurm-local: $*" >&2; }
die() { say "$*"; exit 1; }

# Whether a controller answers and some node is in a usable state.
cluster_up() {
    command -v sinfo >/dev/null 2>&1 || return 1
    # ping fails at once without a controller, where sinfo retries for 9 s.
    timeout 10 scontrol ping >/dev/null 2>&1 || return 1
    local states
    states="$(timeout 10 sinfo -h -o '%T' 2>/dev/null)" || return 1
    [[ "$states" =~ (idle|mixed|allocated|completing) ]]
}

# The pid in pid file $run/$1.pid when that process is alive and is $1 (a
# stale file's pid may have been reused by another program).
alive_pid() {
    local file="$run/$1.pid" pid
    [ -s "$file" ] || return 1
    pid="$(cat "$file")"
    [[ "$pid" =~ ^[0-9]+$ ]] && [ "$(cat "/proc/$pid/comm" 2>/dev/null)" = "$1" ] && echo "$pid"
}

munge_works() { munge -n </dev/null 2>/dev/null | unmunge >/dev/null 2>&1; }

# Waits up to $1 seconds for the command after it to succeed.
wait_for() {
    local limit="$1" i=0
    shift
    until "$@"; do
        i=$((i + 1))
        [ "$i" -le $((limit * 4)) ] || return 1
        sleep 0.25
    done
}

write_conf() {
    if [ -e "$conf" ] && ! grep -qF "$marker" "$conf"; then
        die "$conf exists and was not written by this script: not replacing it (and the SLURM it configures does not answer: start it, or move the file away)"
    fi
    local cpus tmp
    cpus="$(nproc)"
    mkdir -p /etc/slurm "$state/ctld" "$state/d" "$run"
    tmp="$(mktemp /etc/slurm/.slurm.conf.XXXXXX)"
    cat >"$tmp" <<EOF
$marker
# A one-node cluster on $node for isomarch's batch frames; rewritten by
# every start, stopped with: bash scripts/slurm-local.sh stop
ClusterName=isomarch
SlurmctldHost=$node(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
MpiDefault=none
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
# Start queued tasks as soon as a CPU frees (the default waits up to 3 s).
SchedulerParameters=batch_sched_delay=0
ReturnToService=2
StateSaveLocation=$state/ctld
SlurmdSpoolDir=$state/d
SlurmctldPidFile=$run/slurmctld.pid
SlurmdPidFile=$run/slurmd.pid
SlurmctldLogFile=$state/slurmctld.log
SlurmdLogFile=$state/slurmd.log
SlurmctldTimeout=30
SlurmdTimeout=30
KillWait=30
MinJobAge=300
NodeName=$node NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=local Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
    chmod 644 "$tmp"
    mv -f "$tmp" "$conf"
}

start() {
    if cluster_up; then
        echo running
        return 0
    fi
    # Packages through the one place that installs them.
    # shellcheck source=env.sh
    (ISOMARCH_WITH=slurm source "$here/env.sh")
    if cluster_up; then
        echo running
        return 0
    fi
    write_conf
    mkdir -p "$run"
    local started=""
    # The daemons' own output goes to files beside their logs: a caller
    # that reads this script's output through a pipe is not held open.
    if ! munge_works; then
        [ -s /etc/munge/munge.key ] || mungekey --create --force >/dev/null
        chown munge:munge /etc/munge/munge.key && chmod 400 /etc/munge/munge.key
        mkdir -p /run/munge /var/log/munge /var/lib/munge
        chown munge:munge /run/munge /var/log/munge /var/lib/munge
        runuser -u munge -- /usr/sbin/munged </dev/null >>"$state/munged.out" 2>&1 \
            || die "munged did not start (see $state/munged.out and /var/log/munge/munged.log)"
        wait_for 15 munge_works || die "munged started but munge -n | unmunge fails (see /var/log/munge/munged.log)"
        # Recorded so that `stop` stops only a munged that this script started.
        cp /run/munge/munged.pid "$run/munged.pid"
        started=1
    fi
    if ! alive_pid slurmctld >/dev/null; then
        /usr/sbin/slurmctld </dev/null >>"$state/slurmctld.out" 2>&1 \
            || die "slurmctld did not start (see $state/slurmctld.out and $state/slurmctld.log)"
        started=1
    fi
    if ! alive_pid slurmd >/dev/null; then
        /usr/sbin/slurmd </dev/null >>"$state/slurmd.out" 2>&1 \
            || die "slurmd did not start (see $state/slurmd.out and $state/slurmd.log)"
        started=1
    fi
    local i
    for i in $(seq 1 120); do
        local s
        s="$(timeout 10 sinfo -h -n "$node" -o '%T' 2>/dev/null || true)"
        case "$s" in
            # Up; mixed or allocated when jobs recovered from a run that
            # stopped uncleanly are still running: they end on their own.
            idle*|mixed*|alloc*|completing*) break ;;
            down*|drain*|fail*)
                # Left down by an earlier run that stopped uncleanly.
                scontrol update NodeName="$node" State=RESUME >/dev/null 2>&1 || true ;;
        esac
        [ "$i" -lt 120 ] || die "node $node is not idle after 60 s (sinfo says '${s:-nothing}'); logs: $state/slurmctld.log, $state/slurmd.log"
        sleep 0.5
    done
    if [ -n "$started" ]; then echo started; else echo running; fi
}

stop() {
    # All at once: each takes one to two seconds to save its state and exit.
    local name pid pids=()
    for name in slurmd slurmctld munged; do
        if pid="$(alive_pid "$name")"; then
            kill "$pid"
            pids+=("$name:$pid")
        fi
    done
    for entry in "${pids[@]}"; do
        name="${entry%%:*}" pid="${entry#*:}"
        wait_for 30 eval "! kill -0 $pid 2>/dev/null" || die "$name (pid $pid) did not stop within 30 s"
        rm -f "$run/$name.pid"
        say "stopped $name (pid $pid)"
    done
}

case "$action" in
    start) start ;;
    stop) stop ;;
    status) cluster_up ;;
    *) die "unknown action $action (start, stop or status)" ;;
esac

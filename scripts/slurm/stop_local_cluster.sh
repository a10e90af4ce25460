#!/usr/bin/env bash
# Stop the daemons started by start_local_cluster.sh (slurmd, slurmctld, munged).
# Uses the pid files only; never kills by process name.
#   SLURM_LOCAL_DIR   same as for start_local_cluster.sh (default /var/lib/slurm-local)
#   KEEP_MUNGE=1      leave munged running
#   SLURM_PURGE_STATE=1  also delete saved controller state (job records, job ids restart at 1)
set -uo pipefail

BASE="${SLURM_LOCAL_DIR:-/var/lib/slurm-local}"
PID_DIR="$BASE/run"

log() { printf '[slurm-local] %s\n' "$*" >&2; }

stop_pidfile() {
    local name="$1" pidfile="$2" pid
    if [ ! -f "$pidfile" ]; then
        log "$name: no pid file ($pidfile), not running"
        return 0
    fi
    pid="$(cat "$pidfile")"
    if ! kill -0 "$pid" 2>/dev/null; then
        log "$name: stale pid file, removing"
        rm -f "$pidfile"
        return 0
    fi
    log "stopping $name (pid $pid)"
    kill -TERM "$pid" 2>/dev/null || true
    for _ in $(seq 1 60); do
        kill -0 "$pid" 2>/dev/null || break
        sleep 0.25
    done
    if kill -0 "$pid" 2>/dev/null; then
        log "$name did not exit after 15 s, sending SIGKILL"
        kill -KILL "$pid" 2>/dev/null || true
        sleep 0.5
    fi
    rm -f "$pidfile"
}

stop_pidfile slurmd    "$PID_DIR/slurmd.pid"
stop_pidfile slurmctld "$PID_DIR/slurmctld.pid"
if [ "${KEEP_MUNGE:-0}" != 1 ]; then
    stop_pidfile munged /run/munge/munged.pid
fi
if [ "${SLURM_PURGE_STATE:-0}" = 1 ]; then
    log "purging $BASE/slurmctld and $BASE/slurmd"
    rm -rf "${BASE:?}/slurmctld" "${BASE:?}/slurmd"
fi
log "stopped"

#!/usr/bin/env bash
# A one-node Slurm cluster on the loopback, for testing farm jobs on one
# machine: munged, slurmctld and slurmd with their state, logs, sockets and
# ports in one folder, nothing in /etc touched. Needs root (slurmd starts
# jobs as their users), Debian's slurm-wlm and munge (installed when
# missing).
#
#   source scripts/farm/local-slurm.sh DIR   # starts it; SLURM_CONF is set
#   local_slurm_stop                         # stops it
# (Sourced: it leaves the caller's shell options as they are.)

local_slurm_dir=$(realpath -m "${1:?usage: source local-slurm.sh DIR}")

if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
    if [ "$(id -u)" != 0 ]; then
        echo "local-slurm: slurm-wlm and munge are missing and installing them needs root" >&2
        return 1 2>/dev/null || exit 1
    fi
    echo "local-slurm: installing slurm-wlm and munge"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y -qq --no-install-recommends slurm-wlm munge >/dev/null
fi

mkdir -p "$local_slurm_dir"/{munge,spool,state,log}
chmod 700 "$local_slurm_dir/munge"
# munged refuses a key or socket folder that others can write to.
dd if=/dev/urandom of="$local_slurm_dir/munge/munge.key" bs=1024 count=1 status=none
chmod 400 "$local_slurm_dir/munge/munge.key"
munged --force \
    --key-file="$local_slurm_dir/munge/munge.key" \
    --socket="$local_slurm_dir/munge/munge.socket" \
    --pid-file="$local_slurm_dir/munge/munged.pid" \
    --log-file="$local_slurm_dir/log/munged.log" \
    --seed-file="$local_slurm_dir/munge/munge.seed"

# Two free TCP ports on the loopback for the controller and the node.
read -r ctld_port slurmd_port < <(python3 - <<'PY'
import socket
socks = [socket.socket() for _ in range(2)]
for s in socks:
    s.bind(("127.0.0.1", 0))
print(*(s.getsockname()[1] for s in socks))
PY
)
cpus=$(nproc)
host=$(hostname -s)
cat >"$local_slurm_dir/slurm.conf" <<CONF
ClusterName=optica-local
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$local_slurm_dir/munge/munge.socket
StateSaveLocation=$local_slurm_dir/state
SlurmdSpoolDir=$local_slurm_dir/spool
SlurmctldPidFile=$local_slurm_dir/slurmctld.pid
SlurmdPidFile=$local_slurm_dir/slurmd.pid
SlurmctldLogFile=$local_slurm_dir/log/slurmctld.log
SlurmdLogFile=$local_slurm_dir/log/slurmd.log
ProctrackType=proctrack/pgid
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
ReturnToService=2
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SlurmctldTimeout=30
SlurmdTimeout=30
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=optica Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$local_slurm_dir/slurm.conf"
slurmctld -i
slurmd

# Up when the node takes jobs.
for _ in $(seq 1 60); do
    if sinfo -h -o '%t' 2>/dev/null | grep -qx 'idle'; then
        break
    fi
    sleep 0.5
done
if ! sinfo -h -o '%t' | grep -qx 'idle'; then
    echo "local-slurm: the node did not come up; logs in $local_slurm_dir/log" >&2
    sinfo >&2 || true
    return 1 2>/dev/null || exit 1
fi
echo "local-slurm: one node ($cpus CPUs) up; SLURM_CONF=$SLURM_CONF"

local_slurm_stop() {
    local dir=$local_slurm_dir
    for pidfile in "$dir/slurmd.pid" "$dir/slurmctld.pid" "$dir/munge/munged.pid"; do
        if [ -f "$pidfile" ]; then
            kill "$(cat "$pidfile")" 2>/dev/null || true
        fi
    done
}

#!/usr/bin/env bash
# A throwaway one-node Slurm cluster on 127.0.0.1 for tests/slurm.rs.
#   cluster.sh start DIR   install Slurm and munge if needed (Debian, root), write
#                          DIR/slurm.conf, start munged, slurmctld and slurmd with all
#                          their state, sockets, logs and pid files under DIR, and wait
#                          until the node is idle. Prints `SKIPPED: slurm: <reason>` and
#                          exits 77 when Slurm cannot be installed or started here.
#   cluster.sh stop DIR    stop the daemons by their pid files (never by name).
# Clients need SLURM_CONF=DIR/slurm.conf. Recipe: ../shared/REFERENCE.md §3.
set -uo pipefail
cmd=${1:?start|stop}
dir=${2:?state directory}

skip() {
  echo "SKIPPED: slurm: $*"
  exit 77
}

stop() {
  for d in slurmd slurmctld munged; do
    f="$dir/$d.pid"
    [ -s "$f" ] || continue
    pid=$(cat "$f")
    if kill -0 "$pid" 2>/dev/null; then
      kill "$pid" 2>/dev/null
      for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
      kill -0 "$pid" 2>/dev/null && kill -9 "$pid" 2>/dev/null
    fi
    rm -f "$f"
  done
}

if [ "$cmd" = stop ]; then
  stop
  exit 0
fi
[ "$cmd" = start ] || { echo "usage: cluster.sh start|stop DIR" >&2; exit 2; }

[ "$(id -u)" = 0 ] || skip "not root (installing and starting slurmctld, slurmd and munge needs root)"
if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null || ! command -v sbatch >/dev/null || ! command -v munged >/dev/null; then
  command -v apt-get >/dev/null || skip "Slurm is not installed and there is no apt-get"
  echo "installing slurmctld slurmd slurm-client munge with apt-get"
  if ! DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends slurmctld slurmd slurm-client munge >"$dir.apt.log" 2>&1; then
    DEBIAN_FRONTEND=noninteractive apt-get update >>"$dir.apt.log" 2>&1
    DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends slurmctld slurmd slurm-client munge >>"$dir.apt.log" 2>&1 \
      || skip "apt-get install slurmctld slurmd slurm-client munge failed (see $dir.apt.log)"
  fi
fi

trap 'stop' ERR
mkdir -p "$dir"/{state,spool,munge}
host=$(hostname -s)
cpus=$(nproc)

# munge: own key, socket, pid and log under $dir, run as the munge user.
key="$dir/munge/munge.key"
if [ -r /etc/munge/munge.key ]; then cp /etc/munge/munge.key "$key"; else dd if=/dev/urandom of="$key" bs=1024 count=1 status=none; fi
chown -R munge:munge "$dir/munge" 2>/dev/null || chown -R munge "$dir/munge"
chmod 755 "$dir/munge"; chmod 400 "$key"
chmod 755 "$dir"
runuser -u munge -- munged --key-file="$key" --socket="$dir/munge/munge.socket" \
  --pid-file="$dir/munge/munged.pid" --log-file="$dir/munge/munged.log" --seed-file="$dir/munge/munged.seed" \
  || skip "munged does not start (see $dir/munge/munged.log)"
cp "$dir/munge/munged.pid" "$dir/munged.pid"

cat >"$dir/slurm.conf" <<CONF
ClusterName=laydowntest
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
AuthType=auth/munge
AuthInfo=socket=$dir/munge/munge.socket
CredType=cred/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
ReturnToService=2
SchedulerType=sched/backfill
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
SlurmctldTimeout=30
SlurmdTimeout=30
InactiveLimit=0
MinJobAge=300
KillWait=5
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=test Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$dir/slurm.conf"
slurmctld -i -f "$SLURM_CONF" || { stop; skip "slurmctld does not start (see $dir/slurmctld.log)"; }
slurmd -f "$SLURM_CONF" || { stop; skip "slurmd does not start (see $dir/slurmd.log)"; }
for _ in $(seq 60); do
  state=$(sinfo -h -N -o '%t' 2>/dev/null | head -1)
  case "$state" in idle*) echo "slurm: node $host idle ($cpus CPUs), SLURM_CONF=$SLURM_CONF"; exit 0 ;; esac
  sleep 0.5
done
echo "slurm: node never became idle (state '${state:-none}'); logs in $dir" >&2
stop
skip "the one-node cluster did not come up within 30 s (see $dir/slurmctld.log, $dir/slurmd.log)"

#!/usr/bin/env bash
# Slurm array test of `linesight batch`.
#
# Starts a private one-node Slurm cluster on 127.0.0.1 (munged, slurmctld, slurmd; every key, socket,
# config, state, log and pid file in a temp dir), renders an 8-pair sequence, and checks that
#   - an array job of 4 tasks (`sbatch --array=0-3`, each task takes its shard from
#     SLURM_ARRAY_TASK_*) followed by `batch --merge` gives byte-identical per-pair outputs (*.pfm,
#     per-pair *.json) and the same pairs, all done, as a one-process run;
#   - the array really ran 4 shards (4 shard summaries, pair i in shard i % 4);
#   - a second one-process run into the same folder skips all 8 pairs and changes no output.
# Every daemon it started is stopped on exit (also on failure), and the temp dir removed.
#
# usage: slurm_array_test.sh <linesight binary> <work dir (wiped)>
# Exit 77 (skipped) when Slurm or MUNGE is not installed, unless CI=true (then it is a failure).
set -euo pipefail

[ $# -eq 2 ] || { echo "usage: $0 <linesight binary> <work dir>" >&2; exit 2; }
LINESIGHT=$(realpath "$1")
WORK=$(realpath -m "$2")
NUM_PAIRS=8
NUM_TASKS=4
JOB_TIMEOUT_S=120   # whole array job, queueing included (about 10 s here)
export PATH="$PATH:/usr/sbin:/sbin"

log() { printf '[%s +%3ds] %s\n' "$(date +%H:%M:%S)" "$SECONDS" "$*"; }
fail() { log "FAIL: $*"; exit 1; }

# Skips (77) outside CI when the cluster cannot be started here; in CI that is a failure.
require_cluster_tools() {
  local missing=() t
  for t in munged mungekey munge unmunge slurmctld slurmd sbatch sinfo squeue scancel python3; do
    command -v "$t" >/dev/null || missing+=("$t")
  done
  [ "$(id -u)" -eq 0 ] || missing+=("root (the daemons run as SlurmUser=root)")
  [ ${#missing[@]} -eq 0 ] && return 0
  if [ "${CI:-}" = true ]; then fail "missing: ${missing[*]} (scripts/install-deps.sh installs slurm-wlm and munge)"; fi
  echo "SKIP: missing ${missing[*]} (install slurm-wlm and munge: scripts/install-deps.sh)"
  exit 77
}

# Two TCP ports free on 127.0.0.1 right now: the controller's and the node daemon's.
free_ports() {
  python3 -c 'import socket
s = [socket.socket() for _ in range(2)]
for x in s: x.bind(("127.0.0.1", 0))
print(*[x.getsockname()[1] for x in s])'
}

# Polls "${@:2}" every 0.5 s until it succeeds; returns 1 after $1 seconds.
wait_for() {
  local deadline=$((SECONDS + $1)); shift
  until "$@" >/dev/null 2>&1; do
    [ $SECONDS -lt $deadline ] || return 1
    sleep 0.5
  done
}

munge_answers() { munge -n -S "$MUNGE_SOCKET" | unmunge -S "$MUNGE_SOCKET"; }
node_idle() { [ "$(sinfo -h -N -n "$NODE" -o %T)" = idle ]; }
queue_empty() { [ -z "$(squeue -h -o %i)" ]; }

# The daemons run in the foreground of their own sessions: their pids are known, and a Ctrl-C on the
# test does not reach them before the jobs are cancelled (all three shut down on SIGINT).
start_munged() {
  chmod 755 "$STATE"   # munged insists that everyone can reach its socket's folder
  mungekey --create --keyfile="$STATE/munge.key"
  setsid munged -F --key-file="$STATE/munge.key" --socket="$MUNGE_SOCKET" --pid-file="$STATE/munged.pid" \
    --log-file="$STATE/munged.log" --seed-file="$STATE/munged.seed" 2>"$STATE/munged.stderr" &
  MUNGED_PID=$!
  wait_for 10 munge_answers || fail "munged did not answer within 10 s"
}

write_slurm_conf() {
  local ctld_port slurmd_port mem_mb
  read -r ctld_port slurmd_port < <(free_ports)
  mem_mb=$(awk '/^MemTotal:/ { print int($2 / 1024 * 0.9) }' /proc/meminfo)
  mkdir -p "$STATE/state" "$STATE/spool"
  : >"$STATE/plugstack.conf"
  cat >"$SLURM_CONF" <<EOF
ClusterName=linesight-test
SlurmctldHost=$NODE(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$MUNGE_SOCKET
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$STATE/state
SlurmdSpoolDir=$STATE/spool
SlurmctldPidFile=$STATE/slurmctld.pid
SlurmdPidFile=$STATE/slurmd.pid
SlurmctldLogFile=$STATE/slurmctld.log
SlurmdLogFile=$STATE/slurmd.log
PlugStackConfig=$STATE/plugstack.conf
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SlurmdParameters=config_overrides
MpiDefault=none
MailProg=/bin/true
ReturnToService=2
KillWait=5
NodeName=$NODE NodeAddr=127.0.0.1 CPUs=$(nproc) RealMemory=$mem_mb State=UNKNOWN
PartitionName=test Nodes=$NODE Default=YES MaxTime=10 State=UP
EOF
  log "slurm.conf: controller port $ctld_port, node port $slurmd_port, $(nproc) CPUs, ${mem_mb} MB"
}

start_slurm() {
  setsid slurmctld -D -c 2>"$STATE/slurmctld.stderr" &
  SLURMCTLD_PID=$!
  setsid slurmd -D 2>"$STATE/slurmd.stderr" &
  SLURMD_PID=$!
  wait_for 30 node_idle || fail "node $NODE not idle in sinfo within 30 s"
}

# Stops a daemon started by this script: TERM, up to 10 s, then KILL.
stop_pid() {
  local pid=$1 i
  [ -n "$pid" ] && kill "$pid" 2>/dev/null || return 0
  for i in $(seq 20); do kill -0 "$pid" 2>/dev/null || return 0; sleep 0.5; done
  kill -9 "$pid" 2>/dev/null || true
}

# Whatever still holds a file in the temp dir once the daemons are gone (job steps whose slurmd died).
kill_leftovers() {
  local fd pid
  for fd in /proc/[0-9]*/fd/*; do
    [[ $(readlink "$fd" 2>/dev/null) == "$STATE"/* ]] || continue
    pid=${fd#/proc/}; pid=${pid%%/*}
    [ "$pid" = $$ ] || kill -9 "$pid" 2>/dev/null
  done
}

dump_logs() {
  local f
  for f in munged slurmctld slurmd; do
    log "---- $f log"
    cat "$STATE/$f.log" 2>/dev/null || cat "$STATE/$f.stderr" 2>/dev/null || true
  done
  for f in "$STATE"/task-*.out; do [ -e "$f" ] && { log "---- $f"; cat "$f"; }; done
  return 0
}

cleanup() {
  local rc=$?
  set +e
  [ $rc -eq 0 ] || dump_logs
  stop_pid "$SBATCH_PID"
  if [ -n "$SLURMCTLD_PID" ] && kill -0 "$SLURMCTLD_PID" 2>/dev/null; then
    timeout 10 scancel --quiet --user=root
    wait_for 15 queue_empty
  fi
  stop_pid "$SLURMD_PID"; stop_pid "$SLURMCTLD_PID"; stop_pid "$MUNGED_PID"
  kill_leftovers
  rm -rf "$STATE"
  log "daemons stopped, $STATE removed; exit $rc"
  exit $rc
}

# The 8 pairs and their manifest (paths relative to the manifest; odd pairs named explicitly).
make_data() {
  "$LINESIGHT" render --sequence $NUM_PAIRS --seed 11 --supersampling 1 --out "$WORK/seq" >/dev/null
  MANIFEST=$WORK/manifest.txt
  NAMES=()
  { echo "# left right [name]"; echo; } >"$MANIFEST"
  local i f
  for ((i = 0; i < NUM_PAIRS; i++)); do
    printf -v f '%04d' $i
    if ((i % 2)); then
      echo "seq/left_$f.png seq/right_$f.png frame_$f" >>"$MANIFEST"; NAMES+=("frame_$f")
    else
      echo "seq/left_$f.png  seq/right_$f.png" >>"$MANIFEST"; NAMES+=("left_$f")
    fi
  done
}

run_array_job() {
  cat >"$STATE/task.sh" <<EOF
#!/bin/bash
set -euo pipefail
echo "array task \$SLURM_ARRAY_TASK_ID of \$SLURM_ARRAY_TASK_COUNT (min \$SLURM_ARRAY_TASK_MIN) on \$(hostname)"
exec $(printf '%q ' "$LINESIGHT" batch --manifest "$MANIFEST" --out "$WORK/sharded" \
  --calib "$WORK/seq/stereo.yml" --threads 1)
EOF
  # In the background so that a signal to the test is handled at once, not after the job.
  timeout $JOB_TIMEOUT_S sbatch --wait --array=0-$((NUM_TASKS - 1)) --cpus-per-task=1 --time=5 \
    --chdir="$STATE" --output="$STATE/task-%a.out" --job-name=linesight-batch "$STATE/task.sh" &
  SBATCH_PID=$!
  wait $SBATCH_PID || fail "array job failed or timed out (sbatch exit $?)"
  SBATCH_PID=""
  cat "$STATE"/task-*.out
}

# Summaries: the same pairs, all done, in the one-process run and the merge; shard i holds the pairs
# i, i + 4; after a rerun into the one-process folder every pair is skipped.
check_summaries() {
  python3 - "$WORK" "$NUM_TASKS" "$1" "${NAMES[@]}" <<'EOF'
import json, sys
work, tasks, phase, names = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4:]
def statuses(path):
    with open(path) as f:
        return {p["name"]: p["status"] for p in json.load(f)["pairs"]}
def expect(path, wanted):
    got = statuses(path)
    if got != wanted:
        sys.exit(f"{path}: pairs {got}, expected {wanted}")
if phase == "resumed":
    expect(f"{work}/single/summary.json", {n: "skipped" for n in names})
    sys.exit(0)
expect(f"{work}/single/summary.json", {n: "done" for n in names})
expect(f"{work}/sharded/summary.json", {n: "done" for n in names})
for i in range(tasks):
    expect(f"{work}/sharded/summary.shard-{i}-of-{tasks}.json", {n: "done" for n in names[i::tasks]})
for n in names:  # with --calib every per-pair report lists the obstacles found (maybe none)
    with open(f"{work}/sharded/{n}.json") as f:
        if not isinstance(json.load(f).get("obstacles"), list):
            sys.exit(f"{n}.json: no obstacles list")
EOF
}

same_outputs() {
  diff -r --exclude='summary*.json' "$WORK/single" "$WORK/sharded" || fail "per-pair outputs differ"
  local pfms=("$WORK/single"/*.pfm)
  [ ${#pfms[@]} -eq $NUM_PAIRS ] || fail "expected $NUM_PAIRS .pfm files, found ${#pfms[@]}"
}

main() {
  require_cluster_tools
  "$LINESIGHT" batch --help >/dev/null || fail "$LINESIGHT has no batch command"
  # A run inside a Slurm job must not pass its own array variables on to the one-process runs.
  local v
  for v in $(compgen -e SLURM_ || true); do unset "$v"; done

  SLURMCTLD_PID="" SLURMD_PID="" MUNGED_PID="" SBATCH_PID=""
  STATE=$(mktemp -d /tmp/linesight-slurm.XXXXXX)   # short: the MUNGE socket path has a length limit
  trap cleanup EXIT
  trap 'exit 130' INT TERM
  export SLURM_CONF=$STATE/slurm.conf
  MUNGE_SOCKET=$STATE/munge.socket
  NODE=$(hostname -s)

  log "starting munged, slurmctld, slurmd on $NODE (127.0.0.1) in $STATE"
  start_munged
  write_slurm_conf
  start_slurm
  log "cluster up: $(sinfo -h -o '%P %a %D %T %C')"

  log "rendering $NUM_PAIRS pairs into $WORK/seq"
  [ "$WORK" != / ] || fail "refusing to wipe /"
  rm -rf "$WORK" && mkdir -p "$WORK"
  make_data
  log "one-process run into $WORK/single"
  "$LINESIGHT" batch --manifest "$MANIFEST" --out "$WORK/single" --calib "$WORK/seq/stereo.yml" --threads 1
  log "array job of $NUM_TASKS tasks into $WORK/sharded"
  run_array_job
  log "merging the shards"
  "$LINESIGHT" batch --manifest "$MANIFEST" --out "$WORK/sharded" --merge
  log "comparing the merged results with the one-process run"
  same_outputs
  check_summaries fresh
  log "rerun into $WORK/single: every pair must be skipped"
  "$LINESIGHT" batch --manifest "$MANIFEST" --out "$WORK/single" --calib "$WORK/seq/stereo.yml" --threads 1
  check_summaries resumed
  same_outputs
  log "PASS: $NUM_TASKS-task array job == one-process run over $NUM_PAIRS pairs"
}

main

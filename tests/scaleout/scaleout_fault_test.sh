#!/usr/bin/env bash
# Scale-out under faults, on loopback: one real PostgreSQL 15, two `fleetd --role server`, two
# `fleetd --role worker`. A simulated fleet uploads half its robots through each server; one worker is
# SIGKILLed while it holds a job lease and one server is SIGKILLed during an upload; everything not
# acknowledged is uploaded again. Then: every run is stored exactly once, every job is done (the killed
# worker's job retaken by the other after its lease expired), and `fleetctl stats --json` equals a single
# `fleetd --role all` on SQLite fed the same run files.
#   scaleout_fault_test.sh BIN_DIR DATA_DIR   (the repository's data/ or a larger set of the same layout)
set -euo pipefail
bin=$(realpath "$1")
data=$(realpath "$2")
source "$(dirname "$0")/loopback_topology.sh"
topology_init scaleout
fail() {
  echo "FAIL: $*" >&2
  for log in "$work"/*.log; do echo "--- $log (tail)" >&2; tail -5 "$log" >&2; done
  exit 1
}
started=$(date +%s)

# ---- PostgreSQL and the fleetd processes ------------------------------------------------------------------
start_postgres
admin="admin:scaleout.$(od -An -N16 -tx1 /dev/urandom | tr -d ' \n')"
export FLEET_TOKEN=$admin

# wait_jobs_done SERVER: until no job is queued or leased (3 minutes at most).
wait_jobs_done() {
  for _ in $(seq 900); do
    busy=$(FLEET_SERVER=$1 "$bin/fleetctl" jobs --json --limit 100000 | json '
sum(1 for j in d.get("jobs", []) if j.get("state") in ("queued", "leased", "JOB_STATE_QUEUED", "JOB_STATE_LEASED"))')
    [[ "$busy" == 0 ]] && return 0
    sleep 0.2
  done
  fail "jobs still queued or leased after 3 minutes: $(sql "SELECT state, count(*) FROM jobs GROUP BY state")"
}

# ---- The fleet: 6 robots x 3 runs x 2 minutes, written to files ------------------------------------------
"$bin/fleetsim" --world "$data/floorplans" --robots 6 --runs 3 --minutes 2 --seed 11 --out "$work/runs" \
  >/dev/null 2>"$work/fleetsim.log" || fail "fleetsim"
total=$(find "$work/runs" -name '*.runpb' | wc -l)
[[ $total == 18 ]] || fail "fleetsim wrote $total runs, expected 18"
# Each robot's runs chain through their maps, so a robot stays on one server: robots 0-2 and 3-5.
half1=() half2=()
for dir in "$work"/runs/robot-*; do
  n=${dir##*-}; n=$((10#$n))
  if ((n < 3)); then half1+=("$dir"); else half2+=("$dir"); fi
done
((${#half1[@]} == 3 && ${#half2[@]} == 3)) || fail "expected robot directories 0-5 in $work/runs"

# ---- Reference: one process on SQLite --------------------------------------------------------------------
start_fleetd single --db "sqlite:$work/single.db" --role all --workers 2 --listen 127.0.0.1:0
single_pid=$last_pid
single=$(grpc_of single)
FLEET_SERVER=$single "$bin/fleetctl" upload --json "$work/runs" >"$work/single-upload.json" 2>>"$work/fleetctl.log" ||
  fail "upload to the single process: $(cat "$work/single-upload.json")"
wait_jobs_done "$single"
FLEET_SERVER=$single "$bin/fleetctl" stats --json >"$work/single-stats.json"
kill "$single_pid"; wait "$single_pid" 2>/dev/null || true

# ---- The scaled-out topology -----------------------------------------------------------------------------
# Short leases so the killed worker's job is retaken within seconds.
start_fleetd worker1 --db "$db" --role worker --workers 1 --lease-seconds 4
worker1=$last_pid
start_fleetd worker2 --db "$db" --role worker --workers 1 --lease-seconds 4
start_fleetd server1 --db "$db" --role server --listen 127.0.0.1:0
s1=$(grpc_of server1)
start_fleetd server2 --db "$db" --role server --listen 127.0.0.1:0
server2=$last_pid
s2=$(grpc_of server2)
echo "PostgreSQL :$port; servers $s1 $s2; workers $worker1 and another"

# Half the fleet through server 1, in the background; meanwhile SIGKILL worker 1 once it holds a lease.
FLEET_SERVER=$s1 "$bin/fleetctl" upload --json --threads 3 "${half1[@]}" >"$work/upload1.json" 2>>"$work/fleetctl.log" &
upload1=$!
killed_job=
deadline=$((SECONDS + 90))
while ((SECONDS < deadline)); do
  # Worker lease owners are host:pid/thread. A job seen leased may finish before a kill lands: freeze the
  # worker first, let statements it already sent settle, and look again.
  candidate=$(sql "SELECT job_id FROM jobs WHERE state = 'leased' AND lease_owner LIKE '%:$worker1/%' LIMIT 1")
  if [[ -n "$candidate" ]]; then
    kill -STOP "$worker1"
    sleep 0.3
    if [[ $(sql "SELECT state = 'leased' AND lease_owner LIKE '%:$worker1/%' FROM jobs WHERE job_id = $candidate") == t ]]; then
      killed_job=$candidate
      break
    fi
    kill -CONT "$worker1"
  fi
  # Worker 2 may have drained the queue before a poll saw worker 1 holding a lease: queue more analysis
  # (reprocessing with the same parameter set rewrites identical reports).
  if ! kill -0 "$upload1" 2>/dev/null && [[ $(sql "SELECT count(*) FROM jobs WHERE state IN ('queued', 'leased')") == 0 ]]; then
    echo "worker 1 not caught holding a lease yet: queueing a reprocess"
    FLEET_SERVER=$s1 "$bin/fleetctl" reprocess --with default --no-wait >/dev/null || fail "reprocess"
  fi
  sleep 0.01
done
[[ -n "$killed_job" ]] || fail "worker 1 never leased a job"
kill -KILL "$worker1"
wait "$worker1" 2>/dev/null || true
echo "SIGKILLed worker 1 (pid $worker1) holding job $killed_job"
wait "$upload1" || fail "upload through server 1: $(cat "$work/upload1.json")"

# The other half through server 2, SIGKILLed once its first runs are stored.
before=$(sql "SELECT count(*) FROM runs")
FLEET_SERVER=$s2 "$bin/fleetctl" upload --json --threads 3 "${half2[@]}" >"$work/upload2.json" 2>>"$work/fleetctl.log" &
upload2=$!
deadline=$((SECONDS + 60))
while ((SECONDS < deadline)); do
  grep -q 'event=run_uploaded' "$work/server2.log" && break
  sleep 0.002
done
kill -KILL "$server2"
wait "$server2" 2>/dev/null || true
echo "SIGKILLed server 2 (pid $server2) after $(( $(sql "SELECT count(*) FROM runs") - before )) of its 9 runs were stored"
if wait "$upload2"; then upload2_rc=0; else upload2_rc=$?; fi
acknowledged2=$(json 'd["uploaded"] + d["already_present"]' <"$work/upload2.json")
[[ $upload2_rc != 0 && $acknowledged2 -lt 9 ]] || fail "the upload through server 2 was not interrupted ($(cat "$work/upload2.json"))"

# Everything again through the surviving server: acknowledged runs come back as already present.
FLEET_SERVER=$s1 "$bin/fleetctl" upload --json "$work/runs" >"$work/reupload.json" 2>>"$work/fleetctl.log" ||
  fail "re-upload: $(cat "$work/reupload.json")"
read -r uploaded present failed < <(json 'd["uploaded"], d["already_present"], d["failed"]' <"$work/reupload.json" | tr -d '(),')
(( failed == 0 && uploaded + present == 18 )) || fail "re-upload: $(cat "$work/reupload.json")"
(( present >= 9 + acknowledged2 )) || fail "re-upload stored again runs that were acknowledged ($(cat "$work/reupload.json"))"
wait_jobs_done "$s1"

# ---- Checks ----------------------------------------------------------------------------------------------
runs=$(FLEET_SERVER=$s1 "$bin/fleetctl" runs --json --limit 1000 | json 'len(d["runs"]), len({r["run_id"] for r in d["runs"]})')
[[ "$runs" == "18 18" ]] || fail "runs listed (all, distinct): $runs, expected 18 once each"
[[ $(sql "SELECT count(*), count(DISTINCT payload_sha256) FROM runs") == "18|18" ]] || fail "runs table: $(sql "SELECT count(*), count(DISTINCT payload_sha256) FROM runs")"
[[ $(sql "SELECT count(*) FROM reports") == 18 ]] || fail "reports: $(sql "SELECT count(*) FROM reports"), expected 18"
# Every job completed: none is queued, leased or failed. The server enqueues before it stores, so a duplicate
# upload's job is cancelled again (at most one cancelled job per "already present" answer), and the job of an
# upload the killed server had enqueued but never stored finds no run, is retried, and is done on its last
# attempt (there is nothing to analyse; the run came back through the re-upload with a job of its own).
unfinished=$(sql "SELECT count(*) FROM jobs WHERE state IN ('queued', 'leased', 'failed')")
[[ $unfinished == 0 ]] || fail "jobs not completed: $(sql "SELECT job_id, kind, state, last_error FROM jobs WHERE state IN ('queued', 'leased', 'failed')")"
duplicates=$(cat "$work/upload1.json" "$work/upload2.json" "$work/reupload.json" | "$py" -c '
import json, sys
print(sum(json.loads(line)["already_present"] for line in sys.stdin if line.strip()))')
cancelled=$(sql "SELECT count(*) FROM jobs WHERE state = 'cancelled'")
# (a duplicate's job that a worker leased before the cancel simply runs and rewrites the same report)
((cancelled <= duplicates)) || fail "$cancelled cancelled jobs but only $duplicates duplicate uploads"
retaken=$(sql "SELECT state || ' after ' || attempts || ' leases' FROM jobs WHERE job_id = $killed_job")
[[ $(sql "SELECT state = 'done' AND attempts >= 2 FROM jobs WHERE job_id = $killed_job") == t ]] ||
  fail "the killed worker's job $killed_job was not retaken and finished: $retaken"
FLEET_SERVER=$s1 "$bin/fleetctl" stats --json >"$work/scaled-stats.json"
"$py" - "$work/single-stats.json" "$work/scaled-stats.json" <<'PY' || fail "statistics differ"
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
reports = int(a.get("total", a).get("reports", 0))
if reports != 18:
    print("the single process's statistics cover", reports, "reports, expected 18"); sys.exit(1)
if a != b:
    print("single process:", json.dumps(a, sort_keys=True)[:2000]); print("scaled out:   ", json.dumps(b, sort_keys=True)[:2000])
    sys.exit(1)
PY
# The Grafana dashboard's SQL runs on this database: every panel query succeeds, runs per day add up to 18.
"$py" - "$(dirname "$0")/../../deploy/grafana/fleet-dashboard.json" >"$work/panels.tsv" <<'PY'
import json, sys
for panel in json.load(open(sys.argv[1]))["panels"]:
    for target in panel["targets"]:
        sql = target["rawSql"].replace("$__from", "0").replace("$__to", "9000000000000").replace("${parameter_set}", "default")
        print(panel["title"] + "\t" + sql)
PY
while IFS=$'\t' read -r title query; do
  result=$(sql "$query" 2>&1) || fail "dashboard panel '$title': $result"
  if [[ $title == "Runs per day" ]]; then
    per_day=$(awk -F'|' '{n += $2} END {print n}' <<<"$result")
    [[ $per_day == 18 ]] || fail "dashboard runs per day add up to $per_day: $result"
  fi
done <"$work/panels.tsv"
[[ $(wc -l <"$work/panels.tsv") -ge 10 ]] || fail "dashboard panels not read"

echo "scale-out under faults: 18 runs stored once, $(sql "SELECT count(*) FROM jobs WHERE state = 'done'") jobs done and $cancelled duplicates cancelled, none failed (job $killed_job: $retaken), statistics equal the single process, $(wc -l <"$work/panels.tsv") dashboard queries ran ($(( $(date +%s) - started )) s)"

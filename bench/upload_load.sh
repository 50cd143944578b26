#!/usr/bin/env bash
# Load test of issue #9 on loopback: starts a fleetd topology, runs bin/upload_load against it (a one-robot
# baseline, then N robots uploading at once for S seconds), checks that the database holds exactly the
# acknowledged runs, and stops everything again.
#
#   upload_load.sh BIN_DIR SHARED_DATA_DIR [--robots N] [--seconds S] [--topology single|scaleout]
#                  [--rate-limit R] [--drain-timeout D] [-- UPLOAD_LOAD_ARGS...]
#
# scaleout (default): a throwaway PostgreSQL 15 (started as tests/scaleout/scaleout_fault_test.sh does), two
#   `fleetd --role server` and two `fleetd --role worker`; robots alternate between the two servers.
# single: one `fleetd --role all` on a fresh SQLite file.
#
# Every simulated robot uploads with the same admin token, i.e. as one principal. fleetd's rate limit is per
# principal (per robot in production), so it is off by default here; --rate-limit R turns it on and its
# refusals show up as RESOURCE_EXHAUSTED errors in the table. (One robot token per robot would be closer to
# production, but every server would then verify 500 PBKDF2 hashes of 600k iterations each at the start of
# the load — minutes of CPU on a small machine — and the test would measure that instead of ingest.)
#
# After the storage check the script waits for the analysis workers to drain the jobs still queued or leased
# (issue 18's goal: within 2x the upload time), polling once a second for at most --drain-timeout seconds
# (default 600; 0: do not wait), and prints how long that took after the load ended.
set -euo pipefail
usage() { echo "usage: $0 BIN_DIR SHARED_DATA_DIR [--robots N] [--seconds S] [--topology single|scaleout] [--rate-limit R] [--drain-timeout D] [-- UPLOAD_LOAD_ARGS...]" >&2; exit 2; }
(($# >= 2)) || usage
bin=$(realpath "$1")
data=$(realpath "$2")
shift 2
robots=500 seconds=60 topology=scaleout rate_limit=0 drain_timeout=600
extra=()
while (($#)); do
  case $1 in
    --robots) robots=${2:?}; shift 2 ;;
    --seconds) seconds=${2:?}; shift 2 ;;
    --topology) topology=${2:?}; shift 2 ;;
    --rate-limit) rate_limit=${2:?}; shift 2 ;;
    --drain-timeout) drain_timeout=${2:?}; shift 2 ;;
    --) shift; extra=("$@"); break ;;
    *) usage ;;
  esac
done
[[ $topology == single || $topology == scaleout ]] || usage
for tool in fleetd upload_load; do
  [[ -x $bin/$tool ]] || { echo "upload_load.sh: no $bin/$tool (build the targets fleetd and upload_load)" >&2; exit 2; }
done
[[ -d $data/floorplans ]] || { echo "upload_load.sh: no $data/floorplans" >&2; exit 2; }

source "$(dirname "$0")/../tests/scaleout/loopback_topology.sh"
topology_init upload-load
fail() {
  echo "upload_load.sh: FAIL: $*" >&2
  for log in "$work"/*.log; do [[ -e $log ]] && { echo "--- $log (tail)" >&2; tail -5 "$log" >&2; }; done
  exit 1
}

# ---- Process limits: every robot is a thread of upload_load and a stream (a thread) in a server ------------
need_files=$((2 * robots + 1024))
if (($(ulimit -n) < need_files)); then
  ulimit -n "$(ulimit -Hn)" 2>/dev/null || true
  (($(ulimit -n) >= need_files)) || fail "ulimit -n is $(ulimit -n) (hard limit $(ulimit -Hn)), need $need_files for $robots robots"
fi
need_threads=$((4 * robots + 1024))
if [[ $(ulimit -u) != unlimited ]] && (($(ulimit -u) < need_threads)); then
  ulimit -u "$(ulimit -Hu)" 2>/dev/null || true
  [[ $(ulimit -u) == unlimited ]] || (($(ulimit -u) >= need_threads)) ||
    fail "ulimit -u is $(ulimit -u), need $need_threads threads for $robots robots"
fi
# Client, servers, workers and the database share this machine's cores: say how busy it was.
loadavg() { cut -d' ' -f1-3 /proc/loadavg; }
echo "upload_load.sh: $topology topology, $robots robots, $seconds s; ulimit -n $(ulimit -n), -u $(ulimit -u);" \
  "$(nproc) cores, load average $(loadavg)"

admin="admin:load.$(od -An -N16 -tx1 /dev/urandom | tr -d ' \n')"
export FLEET_TOKEN=$admin

# One principal for all robots: its in-flight stream limit is raised with the rate limit.
FLEETD_COMMON_ARGS=(--rate-limit "$rate_limit" --max-upload-streams 4096 --max-upload-streams-per-principal 4096
                    --max-upload-bytes-in-flight 8589934592)

if [[ $topology == scaleout ]]; then
  start_postgres
  count_sql() { sql "$1"; }
  start_fleetd worker1 --db "$db" --role worker --workers 1
  start_fleetd worker2 --db "$db" --role worker --workers 1
  start_fleetd server1 --db "$db" --role server --listen 127.0.0.1:0
  start_fleetd server2 --db "$db" --role server --listen 127.0.0.1:0
  servers="$(grpc_of server1),$(grpc_of server2)"
  echo "upload_load.sh: PostgreSQL 15 on :$port (fsync off), servers $servers, two workers"
else
  start_fleetd single --db "sqlite:$work/fleet.db" --role all --listen 127.0.0.1:0
  count_sql() { sqlite3 "$work/fleet.db" "$1"; }
  servers=$(grpc_of single)
  echo "upload_load.sh: fleetd --role all on SQLite, $servers"
fi

# ---- The load ----------------------------------------------------------------------------------------------
set +e
"$bin/upload_load" --server "$servers" --robots "$robots" --seconds "$seconds" --world "$data/floorplans" --json \
  "${extra[@]}" | tee "$work/upload_load.txt"
load_rc=${PIPESTATUS[0]}
load_ended=$SECONDS
set -e
((load_rc == 0)) || fail "upload_load exited with $load_rc"
tail -1 "$work/upload_load.txt" >"$work/upload_load.json"
echo "load average after the load: $(loadavg)"

# ---- Every acknowledged upload is stored, once -----------------------------------------------------------
read -r tag acknowledged present errors < <(json 'd["run_tag"], d["acknowledged_total"], d["already_present_total"], d["baseline"]["errors"] + d["load"]["errors"]' \
  <"$work/upload_load.json" | tr -d "(),'")
stored=$(count_sql "SELECT count(*) FROM runs WHERE run_id LIKE '$tag-%'")
expected=$((acknowledged - present))
backlog=$(count_sql "SELECT state || ' ' || count(*) FROM jobs GROUP BY state ORDER BY state" | paste -sd, - | sed 's/,/, /g')
echo "analysis jobs at the end (workers keep running behind ingest): $backlog"
# Every upload is a first run (no parent map), so each robot's first becomes its approved map and the rest
# are kept as stale versions (upload_load.cc says why).
versions=$(count_sql "SELECT approval || ' ' || count(*) FROM map_versions WHERE robot_id LIKE '$tag-%' GROUP BY approval ORDER BY approval" |
  paste -sd, - | sed 's/,/, /g')
echo "map versions recorded by the uploads: $versions"
if ((stored == expected)); then
  echo "storage check: $stored runs stored = $expected new uploads acknowledged: OK"
elif ((stored > expected && stored - expected <= errors)); then
  # An upload the client gave up on (deadline) may still have been stored by the server; such runs are not lost.
  echo "storage check: $stored runs stored, $expected acknowledged; the $((stored - expected)) extra are among the $errors uploads reported as errors: OK"
else
  fail "storage check: $stored runs stored, but $expected new uploads were acknowledged ($errors errors)"
fi

# ---- How long the analysis workers take to catch up ------------------------------------------------------
unfinished_sql="SELECT count(*) FROM jobs WHERE state IN ('queued', 'leased')"
unfinished=$(count_sql "$unfinished_sql")
echo "analysis jobs unfinished at the end of the load: $unfinished (queued or leased)"
if ((drain_timeout > 0)); then
  drain_started=$SECONDS
  while ((unfinished > 0 && SECONDS - drain_started < drain_timeout)); do
    sleep 1
    unfinished=$(count_sql "$unfinished_sql")
  done
  after_load=$((SECONDS - load_ended))
  final=$(count_sql "SELECT state || ' ' || count(*) FROM jobs GROUP BY state ORDER BY state" | paste -sd, - | sed 's/,/, /g')
  if ((unfinished == 0)); then
    verdict=$( ((after_load <= 2 * ${seconds%.*})) && echo "within" || echo "beyond")
    echo "analysis backlog drained ${after_load} s after the load ended ($verdict 2x the upload time;" \
      "load and drain $((${seconds%.*} + after_load)) s); jobs: $final"
  else
    echo "analysis backlog NOT drained ${after_load} s after the load ended (--drain-timeout $drain_timeout): $unfinished unfinished; jobs: $final"
  fi
fi

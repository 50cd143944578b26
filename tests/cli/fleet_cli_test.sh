#!/usr/bin/env bash
# fleetctl as a user runs it against a real fleetd on loopback: a small simulated fleet uploads with
# fleetsim --upload, then runs, report, stats (table and --json), credentials, label-from-truth, and
# refusals (no token, a robot token reading). Arguments: the build's bin directory, the shared data directory.
set -euo pipefail
bin=$1
data=$2
work=$(mktemp -d)
fleetd_pid=
cleanup() { [[ -n "$fleetd_pid" ]] && kill "$fleetd_pid" 2>/dev/null; wait 2>/dev/null; rm -rf "$work"; }
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

admin="admin:cli-test.$(od -An -N16 -tx1 /dev/urandom | tr -d ' \n')"
FLEETD_BOOTSTRAP_ADMIN_TOKEN=$admin "$bin/fleetd" --db "sqlite:$work/fleet.db" --listen 127.0.0.1:0 \
  --http 127.0.0.1:0 >"$work/out" 2>"$work/log" &
fleetd_pid=$!
for _ in $(seq 300); do [[ -s "$work/out" ]] && break; sleep 0.1; done
[[ -s "$work/out" ]] || fail "fleetd did not start: $(tail -3 "$work/log")"
export FLEET_SERVER=$(python3 -c 'import json,sys; print(json.loads(sys.argv[1])["grpc"])' "$(head -1 "$work/out")")

# Without a token nothing is read.
if "$bin/fleetctl" runs 2>"$work/err"; then fail "runs without a token succeeded"; fi
grep -q UNAUTHENTICATED "$work/err" || fail "no UNAUTHENTICATED: $(cat "$work/err")"

export FLEET_TOKEN=$admin
"$bin/fleetsim" --world "$data/floorplans" --robots 2 --runs 2 --minutes 3 --seed 5 --upload "$FLEET_SERVER" \
  --out "$work/runs" --json >"$work/sim.json"
for _ in $(seq 600); do
  analysed=$("$bin/fleetctl" stats --json | python3 -c 'import json,sys; d=json.load(sys.stdin); print(d.get("total", d).get("reports", 0))')
  [[ "$analysed" == 4 ]] && break
  sleep 0.2
done
[[ "$analysed" == 4 ]] || fail "expected 4 analysed runs, have $analysed"

[[ $("$bin/fleetctl" runs --json | python3 -c 'import json,sys; print(len(json.load(sys.stdin)["runs"]))') == 4 ]] ||
  fail "runs does not list 4 runs"
run=$("$bin/fleetctl" runs --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["runs"][0]["run_id"])')
"$bin/fleetctl" report "$run" --json | python3 -c '
import json, sys
report = json.load(sys.stdin)["report"]
assert report["parameter_set"] == "default", report.keys()
assert report["decisions"], "no decisions"
assert "ground_truth" in report, "no ground-truth errors"'
"$bin/fleetctl" stats | grep -q "total" || fail "stats table lacks the total row"
"$bin/fleetctl" label-from-truth | grep -q "regions of 4 runs labelled from ground truth" || fail "label-from-truth"

# A robot token may upload but not read.
robot_token=$("$bin/fleetctl" credentials robot:robot-0000 --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["token"])')
if FLEET_TOKEN=$robot_token "$bin/fleetctl" runs 2>"$work/err"; then fail "a robot token read runs"; fi
grep -q PERMISSION_DENIED "$work/err" || fail "no PERMISSION_DENIED: $(cat "$work/err")"
echo "fleetctl against fleetd: all checks passed"

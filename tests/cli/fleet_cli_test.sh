#!/usr/bin/env bash
# fleetctl as a user runs it against a real fleetd on loopback: a small simulated fleet uploads with
# fleetsim --upload, then runs, report, stats (table and --json), credentials, label-from-truth, and
# refusals (no token, a robot token reading). Arguments: the build's bin directory, a data directory (the repository's data/).
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

# Map history: each robot's two runs made versions 1 and 2; a repair from the CLI, review, hand-back, export.
robot=robot-0000
"$bin/fleetctl" maps list "$robot" | grep -q "current version: 2" || fail "maps list: $("$bin/fleetctl" maps list "$robot")"
"$bin/fleetctl" maps show "$robot" --json | python3 -c '
import json, sys
shown = json.load(sys.stdin)
assert shown["version"]["version"] == "2" and shown["version"]["origin"] == "upload", shown["version"]'
"$bin/fleetctl" maps repair "$robot" --base 2 --rollback --reason "cli test" --json >"$work/repair.json"
python3 -c '
import json, sys
v = json.load(open(sys.argv[1]))["version"]
assert v["version"] == "3" and v["approval"] == "pending" and v["origin"] == "rollback", v' "$work/repair.json"
if "$bin/fleetctl" maps repair "$robot" --base 2 --undo 2>"$work/err"; then fail "a repair of an old version succeeded"; fi
grep -q ABORTED "$work/err" || fail "no ABORTED for a stale base: $(cat "$work/err")"
if "$bin/fleetctl" maps repair "$robot" --base 3 --reject-edge 1-2 2>"$work/err"; then fail "a malformed edge was accepted"; fi
"$bin/fleetctl" maps approve "$robot" 3 | grep -q approved || fail "maps approve"
FLEET_TOKEN=$robot_token "$bin/fleetctl" maps get "$robot" --held 2 --out "$work/handed.map" | grep -q "^version 3" ||
  fail "the robot did not get version 3"
[[ -s "$work/handed.map" ]] || fail "maps get wrote no map"
FLEET_TOKEN=$robot_token "$bin/fleetctl" maps get "$robot" --held 3 | grep -q "up to date" || fail "maps get --held 3"
"$bin/fleetctl" maps export "$robot" 3 --format map_server --out "$work/export" >/dev/null
grep -q "^image: $robot-v3.pgm" "$work/export/$robot-v3.yaml" || fail "export: yaml does not name its image"
[[ -s "$work/export/$robot-v3.pgm" ]] || fail "export: no pgm"
"$bin/fleetctl" maps export "$robot" 3 --format g2o --out "$work/export" >/dev/null
grep -q "^VERTEX_SE2" "$work/export/$robot-v3.g2o" || fail "export: g2o has no vertices"
echo "fleetctl against fleetd: all checks passed"

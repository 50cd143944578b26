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

# Maps made elsewhere: two Valetudo exports of one real home at two times (dreame_d9_1058) become versions 1 and
# 2 of a new robot's history, the robot gets the second, and its export has the very cells of the conversion in
# data/maps; a map_server map waits for review; imports cannot be repaired; bad files and robots are refused.
home=home-d9-1058
"$bin/fleetctl" import valetudo "$data/valetudo/dreame_d9_1058_no_segments.json" \
  "$data/valetudo/dreame_d9_1058_with_segments.json" --robot "$home" --approve --reason "user exports" >"$work/import.txt"
grep -q "dreame_d9_1058_with_segments.json → robot $home version 2 (approved" "$work/import.txt" ||
  fail "import valetudo: $(cat "$work/import.txt")"
"$bin/fleetctl" maps list "$home" --json >"$work/home.json"
python3 - "$work/home.json" "$data/maps/valetudo_dreame_d9_1058_with_segments.pgm" <<'PY'
import json, sys
listed = json.load(open(sys.argv[1]))
v = listed["versions"]
assert len(v) == 2 and listed["current_version"] == "2", listed
assert [x["origin"] for x in v] == ["import", "import"], v
assert v[0]["action_detail"] == "valetudo:dreame_d9_1058_no_segments.json" and v[1]["parent_version"] == "1", v
assert v[1]["reason"] == "user exports" and v[1]["nodes"] == "1" and v[1]["approval"] == "approved", v[1]
# Known area: the cells that are not unknown in the same export converted to PGM (data/maps), 0.05 m cells.
pgm = open(sys.argv[2], "rb").read()
known = sum(1 for b in pgm[-143 * 226:] if b != 205) * 0.0025
assert abs(v[1]["known_area_m2"] - known) < 1e-6, (v[1]["known_area_m2"], known)
PY
home_token=$("$bin/fleetctl" credentials "robot:$home" --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["token"])')
FLEET_TOKEN=$home_token "$bin/fleetctl" maps get "$home" | grep -q "^version 2: 1 nodes" || fail "the robot did not get its import"
"$bin/fleetctl" maps export "$home" 2 --format map_server --out "$work/export" >/dev/null
python3 - "$work/export/$home-v2.pgm" "$data/maps/valetudo_dreame_d9_1058_with_segments.pgm" <<'PY'
import sys
def counts(path):  # free and occupied pixels of an 8-bit PGM (the header has no 0 or 254 byte values)
    data = open(path, "rb").read()
    width, height = 0, 0
    header = data.split(b"\n")
    sizes = [line for line in header[1:4] if not line.startswith(b"#")][0].split()
    width, height = int(sizes[0]), int(sizes[1])
    pixels = data[-width * height:]
    return pixels.count(254), pixels.count(0)
ours, theirs = counts(sys.argv[1]), counts(sys.argv[2])
assert ours == theirs, (ours, theirs)
PY
"$bin/fleetctl" import map-server "$data/maps/aws_small_house.yaml" --robot "$home" --json >"$work/import.json"
python3 - "$work/import.json" <<'PY'
import json, sys
v = json.load(open(sys.argv[1]))["version"]
assert v["version"] == "3" and v["approval"] == "pending" and v["parent_version"] == "2", v
assert v["action_detail"] == "map_server:aws_small_house.yaml", v
PY
if "$bin/fleetctl" maps repair "$home" --base 3 --rollback 2>"$work/err"; then fail "an imported map was repaired"; fi
grep -q "FAILED_PRECONDITION: version 3 is an imported map" "$work/err" || fail "unclear refusal: $(cat "$work/err")"
python3 - "$data/valetudo/dreame_d9_1058_with_segments.json" "$work/broken.json" <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))
m["layers"][1]["type"] = "carpet"
json.dump(m, open(sys.argv[2], "w"))
PY
if "$bin/fleetctl" import valetudo "$work/broken.json" --robot "$home" 2>"$work/err"; then fail "a broken export was imported"; fi
grep -q 'INVALID_ARGUMENT: .*broken.json: layers\[1\].type: unknown layer type "carpet"' "$work/err" ||
  fail "unclear error: $(cat "$work/err")"
if FLEET_TOKEN=$home_token "$bin/fleetctl" import map-server "$data/maps/aws_small_house.yaml" --robot "$home" 2>"$work/err"; then
  fail "a robot token imported a map"
fi
grep -q PERMISSION_DENIED "$work/err" || fail "no PERMISSION_DENIED for a robot's import: $(cat "$work/err")"
[[ $("$bin/fleetctl" maps list "$home" --json | python3 -c 'import json,sys; print(len(json.load(sys.stdin)["versions"]))') == 3 ]] ||
  fail "refused imports changed the history"
echo "fleetctl against fleetd: all checks passed"

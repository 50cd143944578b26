#!/usr/bin/env bash
# The README's main job: installs dependencies, builds, runs the shared SLAM core on real public pose graphs,
# starts fleetd on its embedded SQLite default, drives it with a simulated fleet in real homes, labels the
# regions from the simulator's ground truth, trains and activates the protrusion classifier, reprocesses the
# fleet with it, and prints the fleet statistics, each robot's map health (the fleet's map-health line: healthy /
# repaired / corrupted robots by ground truth) and the dashboard URL. fleetd keeps running afterwards so
# the dashboard can be opened; the last lines say how to stop it.
#
# Knobs (environment): FLEET_ROBOTS (12), FLEET_RUNS (4), FLEET_MINUTES (10), FLEET_SEED (1),
# FLEET_HOME_CLUTTER (high: homes with more rugs and low furniture, so the small fleet gets stuck often enough to
# show protrusions; typical: the default physics, ~1 % of maps),
# FLEET_HTTP (127.0.0.1:8080; port 0 picks a free one), FLEET_WORK_DIR (out/main), SHARED_DATA_DIR (the larger
# data set, ../shared/data; the repository's own data/ when it is absent).
set -euo pipefail
cd "$(dirname "$0")/.."
bash deploy/bootstrap.sh
source deploy/build.sh
# Homes and graphs: the larger data set beside the repository when there is one, else the repository's data/
# (the same layout; every file read below is in both).
data=${SHARED_DATA_DIR:-../shared/data}
[[ -d "$data" ]] || data=data
echo "data: $data"
bin=$BUILD_DIR/bin
work=${FLEET_WORK_DIR:-out/main}
rm -rf "$work"
mkdir -p "$work"

echo
echo "== The shared SLAM core on real public pose graphs =="
for graph in vertigo/ring.g2o sesync/CSAIL.g2o sesync/MIT.g2o; do
  "$bin/slamtool" optimize "$data/posegraphs/$graph"
done
"$bin/slamtool" corrupt-g2o "$data/posegraphs/vertigo/intel.g2o" --out "$work/intel-outliers.g2o" --count 100 --seed 1
"$bin/slamtool" replay-g2o "$work/intel-outliers.g2o"

echo
echo "== fleetd on its embedded SQLite default =="
admin_token="admin:main.$(od -An -N16 -tx1 /dev/urandom | tr -d ' \n')"
FLEETD_BOOTSTRAP_ADMIN_TOKEN="$admin_token" nohup "$bin/fleetd" --db "sqlite:$work/fleet.db" \
  --listen 127.0.0.1:0 --http "${FLEET_HTTP:-127.0.0.1:8080}" --log-format text \
  >"$work/fleetd.out" 2>"$work/fleetd.log" &
fleetd_pid=$!
echo "$fleetd_pid" >"$work/fleetd.pid"
for _ in $(seq 300); do
  [[ -s "$work/fleetd.out" ]] && break
  kill -0 "$fleetd_pid" 2>/dev/null || { echo "fleetd did not start:"; tail -5 "$work/fleetd.log"; exit 1; }
  sleep 0.1
done
addresses=$(head -1 "$work/fleetd.out")
grpc=$(python3 -c 'import json,sys; print(json.loads(sys.argv[1])["grpc"])' "$addresses")
http=$(python3 -c 'import json,sys; print(json.loads(sys.argv[1])["http"])' "$addresses")
echo "fleetd $fleetd_pid: gRPC $grpc, HTTP $http, database $work/fleet.db"
export FLEET_SERVER=$grpc FLEET_TOKEN=$admin_token
engineer_token=$("$bin/fleetctl" credentials engineer:main --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["token"])')

wait_for_jobs() {  # until no job is queued or running
  for _ in $(seq 1200); do
    busy=$("$bin/fleetctl" jobs --json | python3 -c '
import json, sys
jobs = json.load(sys.stdin).get("jobs", [])
print(sum(1 for job in jobs if job.get("state") in ("queued", "leased", "running", "JOB_STATE_QUEUED", "JOB_STATE_LEASED")))')
    [[ "$busy" == 0 ]] && return 0
    sleep 0.5
  done
  echo "jobs still running after 10 minutes"; return 1
}

echo
echo "== A simulated fleet in real homes uploads its runs =="
"$bin/fleetsim" --world "$data/floorplans" --robots "${FLEET_ROBOTS:-12}" --runs "${FLEET_RUNS:-4}" \
  --minutes "${FLEET_MINUTES:-10}" --seed "${FLEET_SEED:-1}" --home-clutter "${FLEET_HOME_CLUTTER:-high}" \
  --out "$work/runs" --upload "$grpc" --follow-service --map-health | tee "$work/fleetsim.txt"
wait_for_jobs

echo
echo "== Labels from ground truth train the protrusion classifier; the fleet is reprocessed with it =="
"$bin/fleetctl" label-from-truth
# A small fleet may not have slipped at all: then there is nothing to learn protrusions from yet.
if "$bin/fleetctl" models train protrusion --classifier random_forest; then
  "$bin/fleetctl" models activate protrusion 1
  "$bin/fleetctl" reprocess --with default
  wait_for_jobs
else
  echo "(classifier not trained: regions stay unclassified until both classes are labelled)"
fi

echo
echo "== The protrusion classifier against the simulator's ground truth (every region of every run) =="
python3 - "$bin/fleetctl" <<'PY'
import json, subprocess, sys
fleetctl = sys.argv[1]
def call(*args):
    return json.loads(subprocess.run([fleetctl, *args, "--json"], check=True, capture_output=True, text=True).stdout)
# labels come from label-from-truth (the simulator's ground truth), classes from the reports' classifier
matrix = {(t, p): 0 for t in ("protrusion", "new_space") for p in ("protrusion", "new_space", "unclassified")}
unlabelled = 0
for run in call("runs", "--limit", "100000").get("runs", []):
    for region in call("regions", run["run_id"]).get("regions", []):
        truth, predicted = region.get("label", ""), region.get("predicted_class", "unclassified")
        if truth not in ("protrusion", "new_space"):
            unlabelled += 1
            continue
        matrix[(truth, predicted if predicted in ("protrusion", "new_space") else "unclassified")] += 1
print(f"{'':<22} {'predicted protrusion':>21} {'predicted new space':>20} {'unclassified':>13}")
for truth in ("protrusion", "new_space"):
    row = [matrix[(truth, p)] for p in ("protrusion", "new_space", "unclassified")]
    print(f"{'true ' + truth.replace('_', ' '):<22} {row[0]:>21} {row[1]:>20} {row[2]:>13}")
tp, fp = matrix[("protrusion", "protrusion")], matrix[("new_space", "protrusion")]
fn = matrix[("protrusion", "new_space")] + matrix[("protrusion", "unclassified")]
precision = f"{100 * tp / (tp + fp):.1f} %" if tp + fp else "n/a"
recall = f"{100 * tp / (tp + fn):.1f} %" if tp + fn else "n/a"
print(f"precision {precision}, recall {recall} (unclassified counts as missed); {unlabelled} regions without a label")
PY

echo
echo "== Fleet statistics (the paper's Fig. 6, 7, 8, 12) =="
"$bin/fleetctl" stats
echo
echo "== Map health: each robot's map versions and open findings (review and repair at #/maps) =="
python3 - "$http" <<'PY'
import json, os, sys, urllib.parse, urllib.request
# fleetd serves no data without a token; FLEET_TOKEN comes through the environment, not the command line.
def page(after):
    query = "limit=1000" + (f"&after={urllib.parse.quote(after)}" if after else "")
    request = urllib.request.Request(f"http://{sys.argv[1]}/api/robots?{query}",
                                     headers={"Authorization": f"Bearer {os.environ['FLEET_TOKEN']}"})
    return json.load(urllib.request.urlopen(request))
robots, after = [], ""
while True:  # the robots page is paged (1,000 robots at most a page)
    answer = page(after)
    robots += answer["robots"]
    if not answer["next"]:
        break
    after = answer["next"]["after"]
print(f"{'robot':<14} {'versions':>8} {'current':>8} {'open findings':>14}")
for robot in robots:
    print(f"{robot['robot_id']:<14} {robot['versions']:>8} {robot['current_version']:>8} {robot.get('open_findings', 0):>14}")
PY
# Each robot's map after its last run against the simulator's ground truth (docs/fleetsim.md, "Map health"):
# corrupted past the documented threshold, else repaired when it took a repaired version from the service.
grep '^map health' "$work/fleetsim.txt"
first_robot=$("$bin/fleetctl" runs --limit 1 --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["runs"][0]["robot_id"])')
"$bin/fleetctl" maps show "$first_robot"
echo
echo "Dashboard: http://$http/"
echo "Engineer token to sign in to the dashboard (labelling, repairs): $engineer_token"
echo "fleetd keeps running (pid $fleetd_pid, log $work/fleetd.log); stop it with: kill $fleetd_pid"

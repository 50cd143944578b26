#!/usr/bin/env bash
# The lifelong regimes' ordering on a small fixed fleet (seed 1; README "Lifelong maps" measured it on seeds
# 1-3): after ten daily runs the service (filter + fleetd's repair policy) leaves fewer robots' maps corrupted
# than the filter alone, over the last run and over all runs; and without protection more maps are corrupted
# than with the filter (three runs suffice: the unprotected firmware corrupts most maps in its first run).
# Arguments: the build's bin directory, a data directory.
set -euo pipefail
bin=$1
data=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
common=(--lifelong --world "$data/floorplans" --robots 6 --minutes 4 --seed 1 --json)
"$bin/fleetsim" "${common[@]}" --runs 10 --regimes filter,service --work-dir "$work/fleetd" >"$work/service.out" 2>/dev/null
"$bin/fleetsim" "${common[@]}" --runs 3 --regimes none,filter >"$work/none.out" 2>/dev/null
python3 - "$work/service.out" "$work/none.out" <<'PY'
import json, sys
service = json.loads(open(sys.argv[1]).read().strip().splitlines()[-1])["regimes"]
early = json.loads(open(sys.argv[2]).read().strip().splitlines()[-1])["regimes"]
mean = lambda regime: sum(regime["corrupted_by_run"]) / len(regime["corrupted_by_run"])
print("corrupted after run 10: filter %.3f, service %.3f; mean over runs: filter %.3f, service %.3f" %
      (service["filter"]["corrupted_share"], service["service"]["corrupted_share"], mean(service["filter"]), mean(service["service"])))
print("corrupted after run 3: none %.3f, filter %.3f" % (early["none"]["corrupted_share"], early["filter"]["corrupted_share"]))
assert service["service"]["repairs_taken"] > 0, "the service repaired nothing"
assert service["service"]["corrupted_share"] < service["filter"]["corrupted_share"]
assert mean(service["service"]) < mean(service["filter"])
assert early["none"]["corrupted_share"] > early["filter"]["corrupted_share"]
assert mean(early["none"]) > mean(early["filter"])
PY

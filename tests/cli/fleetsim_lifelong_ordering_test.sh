#!/usr/bin/env bash
# The lifelong regimes' ordering on a small fixed fleet (README "Lifelong maps"): over seeds 1-3, after ten
# daily runs the service (filter + fleetd's repair policy) leaves fewer robots' maps corrupted than the filter
# alone, summed over the last runs and over all runs, and no more on any one seed's last run; and without
# protection more maps are corrupted than with the filter (three runs suffice: the unprotected firmware
# corrupts most maps in its first run). Six robots disagree by one map in a run, so one seed alone decides
# little: seed 1's ten runs tie on their mean.
# Arguments: the build's bin directory, a data directory.
set -euo pipefail
bin=$1
data=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
common=(--lifelong --world "$data/floorplans" --robots 6 --minutes 4 --json)
pids=()
for seed in 1 2 3; do
  "$bin/fleetsim" "${common[@]}" --seed "$seed" --runs 10 --regimes filter,service --work-dir "$work/fleetd$seed" \
    >"$work/service$seed.out" 2>/dev/null &
  pids+=($!)
done
for pid in "${pids[@]}"; do wait "$pid"; done
"$bin/fleetsim" "${common[@]}" --seed 1 --runs 3 --regimes none,filter >"$work/none.out" 2>/dev/null
python3 - "$work" <<'PY'
import json, sys
last = lambda path: json.loads(open(path).read().strip().splitlines()[-1])["regimes"]
mean = lambda regime: sum(regime["corrupted_by_run"]) / len(regime["corrupted_by_run"])
final = {"filter": 0.0, "service": 0.0}
means = {"filter": 0.0, "service": 0.0}
for seed in (1, 2, 3):
    regimes = last("%s/service%d.out" % (sys.argv[1], seed))
    print("seed %d, corrupted after run 10: filter %.3f, service %.3f; mean over runs: filter %.3f, service %.3f" %
          (seed, regimes["filter"]["corrupted_share"], regimes["service"]["corrupted_share"], mean(regimes["filter"]),
           mean(regimes["service"])))
    assert regimes["service"]["repairs_taken"] > 0, "the service repaired nothing on seed %d" % seed
    assert regimes["service"]["corrupted_share"] <= regimes["filter"]["corrupted_share"], "seed %d" % seed
    for regime in final:
        final[regime] += regimes[regime]["corrupted_share"]
        means[regime] += mean(regimes[regime])
print("seeds 1-3 summed: after run 10 filter %.3f, service %.3f; means filter %.3f, service %.3f" %
      (final["filter"], final["service"], means["filter"], means["service"]))
assert final["service"] < final["filter"]
assert means["service"] < means["filter"]
early = last(sys.argv[1] + "/none.out")
print("corrupted after run 3: none %.3f, filter %.3f" % (early["none"]["corrupted_share"], early["filter"]["corrupted_share"]))
assert early["none"]["corrupted_share"] > early["filter"]["corrupted_share"]
assert mean(early["none"]) > mean(early["filter"])
PY

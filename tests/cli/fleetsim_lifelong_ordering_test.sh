#!/usr/bin/env bash
# The lifelong regimes' ordering on a small fixed fleet (README "Lifelong maps"), seeds 1-3, ten daily runs:
# the service (filter + fleetd's repair policy) repairs maps, leaves no more robots' maps corrupted than the
# filter alone after the last run on any seed, and leaves at most 80 % of the filter's false floor (the
# fleet's maps after the last run, summed over robots and seeds: fleetd's analysis is not bit-for-bit
# repeatable, and one seed's margin can be small); and without protection more maps are corrupted than with the filter (three
# runs suffice: the unprotected firmware corrupts most maps in its first run). At this size the service and
# the filter end with the same share corrupted: what is left corrupts by trajectory error (wrong acceptances
# the server's rerun accepts too), which no repair of false floor mends.
# Arguments: the build's bin directory, a data directory.
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
bin=$1
data=$2
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
# per_robot holds each robot's runs as [trajectory_rmse_m, false_free_m2, components, repairs_taken, outcome,
# known_floor_m2].
false_floor = lambda regime: sum(robot[-1][1] for robot in regime["per_robot"])
total = {"filter": 0.0, "service": 0.0}
for seed in (1, 2, 3):
    regimes = last("%s/service%d.out" % (sys.argv[1], seed))
    filter_, service = regimes["filter"], regimes["service"]
    print("seed %d after run 10: corrupted filter %.3f, service %.3f; false floor filter %.2f m2, service %.2f m2; "
          "repairs %d" % (seed, filter_["corrupted_share"], service["corrupted_share"], false_floor(filter_),
                          false_floor(service), service["repairs_taken"]))
    assert service["repairs_taken"] > 0, "the service repaired nothing on seed %d" % seed
    assert service["corrupted_share"] <= filter_["corrupted_share"], "seed %d" % seed
    total["filter"] += false_floor(filter_)
    total["service"] += false_floor(service)
print("false floor after run 10, seeds 1-3: filter %.2f m2, service %.2f m2" % (total["filter"], total["service"]))
assert total["service"] <= 0.8 * total["filter"]
early = last(sys.argv[1] + "/none.out")
print("corrupted after run 3: none %.3f, filter %.3f" % (early["none"]["corrupted_share"], early["filter"]["corrupted_share"]))
assert early["none"]["corrupted_share"] > early["filter"]["corrupted_share"]
assert mean(early["none"]) > mean(early["filter"])
PY

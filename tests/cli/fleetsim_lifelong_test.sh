#!/usr/bin/env bash
# fleetsim --lifelong as a user runs it: bad sizes and regimes are refused naming the option, nothing written;
# a small experiment of all four regimes (it starts and stops its own fleetd beside fleetsim for two of them)
# prints one JSON object on the last line with regimes none, filter, service, review, each holding
# corrupted_share and corrupted_by_run (one share per run), writes the same object to --results, and keeps its
# progress on one updating line of stderr; a regime that fails after another finished leaves the finished one
# in --results with the rest named in regimes_to_come. Arguments: the build's bin directory, a data directory.
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
bin=$1
data=$2

refused() {  # refused EXPECTED-MESSAGE ARGS...
  local expected=$1
  shift
  if "$bin/fleetsim" --lifelong --world "$data/floorplans" --results "$work/refused.json" "$@" >"$work/out" 2>"$work/err"; then
    fail "fleetsim --lifelong $* succeeded"
  fi
  grep -qF -- "$expected" "$work/err" || fail "fleetsim --lifelong $*: expected \"$expected\", got: $(cat "$work/err")"
  [[ ! -e "$work/refused.json" ]] || fail "fleetsim --lifelong $* wrote results"
}
refused "--robots: Value 0 not in range" --robots 0
refused "--robots: expected 1..200, got 201" --robots 201
refused "--runs: expected 1..400, got 401" --runs 401
refused "--regimes: \"magic\" is not one of none, filter, service, review" --regimes filter,magic
refused "--min-severity: expected 0..1" --min-severity 2
refused "--cut-protrusions: expected any or views, got \"model\"" --cut-protrusions model
refused "--review-every: expected 1..400 runs" --review-every 0
refused "is not an executable" --regimes service --fleetd "$work/no-such-fleetd" --robots 1 --runs 1 --minutes 1
# A regime that fails after another finished: the finished one is kept in --results, the rest named.
if "$bin/fleetsim" --lifelong --world "$data/floorplans" --robots 1 --runs 1 --minutes 1 --regimes filter,service \
  --fleetd "$work/no-such-fleetd" --results "$work/partial.json" >"$work/out" 2>"$work/err"; then
  fail "a lifelong experiment whose service regime cannot start succeeded"
fi
grep -qF "regime service: fleetd:" "$work/err" || fail "no reason for the failed regime: $(cat "$work/err")"
python3 - "$work/partial.json" <<'PY'
import json, sys
partial = json.loads(open(sys.argv[1]).read())
assert sorted(partial["regimes"]) == ["filter"], sorted(partial["regimes"])
assert partial["regimes_to_come"] == ["service"], partial["regimes_to_come"]
assert len(partial["regimes"]["filter"]["corrupted_by_run"]) == 1, partial["regimes"]["filter"]
PY
if "$bin/fleetsim" --world "$data/floorplans" --follow-service 2>"$work/err"; then fail "--follow-service without --upload ran"; fi
grep -q -- "--follow-service needs --upload" "$work/err" || fail "no reason for --follow-service: $(cat "$work/err")"

"$bin/fleetsim" --lifelong --world "$data/floorplans" --robots 2 --runs 2 --minutes 2 --seed 3 --json \
  --results "$work/results.json" --work-dir "$work/fleetd" >"$work/out" 2>"$work/err" || fail "lifelong failed: $(tail -3 "$work/err")"
python3 - "$work/out" "$work/results.json" "$work/err" <<'PY'
import json, re, sys
last = open(sys.argv[1]).read().strip().splitlines()[-1]
result = json.loads(last)
assert json.loads(open(sys.argv[2]).read()) == result, "--results holds the printed object"
regimes = result["regimes"]
assert sorted(regimes) == ["filter", "none", "review", "service"], sorted(regimes)
assert result["regimes_to_come"] == [], result["regimes_to_come"]
for name, regime in regimes.items():
    assert 0.0 <= regime["corrupted_share"] <= 1.0, (name, regime["corrupted_share"])
    assert len(regime["corrupted_by_run"]) == 2, (name, regime["corrupted_by_run"])
    assert regime["corrupted_share"] == regime["corrupted_by_run"][-1], name
    assert len(regime["per_robot"]) == 2 and all(len(robot) == 2 for robot in regime["per_robot"]), name
    assert 0.0 < regime["known_floor_share"] <= 1.0, (name, regime["known_floor_share"])
    for rmse, false_m2, components, repairs, outcome, known_m2 in (run for robot in regime["per_robot"] for run in robot):
        assert rmse >= 0 and false_m2 >= 0 and components >= 1 and repairs >= 0, (name, rmse, false_m2, components)
        assert known_m2 > 0, (name, known_m2)
        assert outcome in ("healthy", "repaired", "corrupted"), outcome
        # the threshold (the printed figures are rounded: 1 mm, 0.01 m²)
        t = result["threshold"]
        if rmse > t["trajectory_rmse_m"] + 0.001 or false_m2 > t["false_free_m2"] + 0.01:
            assert outcome == "corrupted", (name, rmse, false_m2, outcome)
        if rmse < t["trajectory_rmse_m"] - 0.001 and false_m2 < t["false_free_m2"] - 0.01:
            assert outcome != "corrupted", (name, rmse, false_m2, outcome)
stderr = open(sys.argv[3], newline="").read()  # keep the carriage returns
assert stderr.count("\n") == 1 and stderr.count("\r") >= 8, repr(stderr[-200:])
# Each regime's line starts at 0 runs as the regime starts and says how long the regime has run.
lines = [line.strip() for line in re.split(r"[\r\n]", stderr) if line.startswith("fleetsim lifelong:")]
elapsed = r"(\d+ s|\d+ min \d\d s|\d+ h \d\d min)"
for name in regimes:
    mine = [line for line in lines if re.match(r"fleetsim lifelong: regime %s\s" % name, line)]
    assert mine and re.search(r" 0/4 runs, %s$" % elapsed, mine[0]), (name, mine[:1])
    assert re.search(r" 4/4 runs, %s$" % elapsed, mine[-1]), (name, mine[-1])
print("lifelong:", {name: regime["corrupted_share"] for name, regime in regimes.items()})
PY
echo "fleetsim --lifelong: refusals, JSON object, results file and progress line ok"

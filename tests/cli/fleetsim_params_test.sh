#!/usr/bin/env bash
# `fleetsim --params`: the robots' on-board Mapper runs with a parameter set (a candidate tried on a
# simulated fleet), and a bad set is refused by name before anything runs.
# Arguments: the directory of the built programs, the repository's data/, its docs/parameter-sets.
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
fleetsim="$1/fleetsim"
data=$2
sets=$3
fleet=(--world "$data/floorplans" --robots 3 --runs 2 --minutes 5 --seed 1 --json)

accepted_share() {  # the fleet's share of recovery hypotheses accepted, from the JSON on stdout's last line
  python3 -c 'import json, sys; print(json.loads(sys.stdin.read().strip().splitlines()[-1])["recovery_accepted_share"])'
}

# The set reaches the robots: with a recovery needing 1000 observations none is ever accepted, where the
# defaults accept some on the same fleet (the same seed, so the same homes, robots and runs).
default_share=$("$fleetsim" "${fleet[@]}" 2>/dev/null | accepted_share)
python3 -c "import sys; sys.exit(0 if float('$default_share') > 0 else 1)" ||
  fail "the defaults accepted no recovery on the test fleet: the check below would be void"
echo '{"name": "never", "mapper": {"recovery": {"minObservations": 1000}}}' >"$work/never.json"
never_share=$("$fleetsim" "${fleet[@]}" --params "$work/never.json" 2>/dev/null | accepted_share)
[[ $never_share == 0.0 || $never_share == 0 ]] || fail "--params never.json still accepted $never_share of recoveries"

# Every shipped set runs a fleet.
for set_file in "$sets"/*.json; do
  "$fleetsim" "${fleet[@]}" --params "$set_file" >/dev/null 2>&1 || fail "fleetsim refused $set_file"
done

# A bad value is refused naming the field; nothing is simulated (no statistics on stdout).
echo '{"mapper": {"gateChi2": -3}}' >"$work/bad.json"
status=0
"$fleetsim" "${fleet[@]}" --params "$work/bad.json" >"$work/bad.out" 2>"$work/bad.err" || status=$?
[[ $status == 2 ]] || fail "a bad set exited $status, not 2"
grep -q "gate_chi2 = -3" "$work/bad.err" || fail "the refusal does not name the field: $(cat "$work/bad.err")"
[[ ! -s "$work/bad.out" ]] || fail "a refused set still printed statistics"
# The lifelong experiment sets its regimes' parameters itself.
status=0
"$fleetsim" --lifelong --world "$data/floorplans" --params "$sets/paper-filter.json" >/dev/null 2>"$work/life.err" ||
  status=$?
[[ $status == 2 ]] && grep -q "not with --lifelong" "$work/life.err" || fail "--params with --lifelong: $(cat "$work/life.err")"
echo "fleetsim --params: defaults accept $default_share of recoveries, the never-set 0; a bad set refused by name"

#!/usr/bin/env bash
# slamtool generate-manhattan as a user runs it: the graph and its ground truth are written, the same seed
# writes the same files, the graph replays, and bad input is refused naming the option with nothing written.
# Argument: slamtool.
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
slamtool=$1

"$slamtool" generate-manhattan --poses 300 --seed 4 "$work/city.g2o" >"$work/out.txt"
grep -q "300 poses" "$work/out.txt" || fail "summary: $(cat "$work/out.txt")"
[[ $(grep -c '^VERTEX_SE2' "$work/city.g2o") == 300 ]] || fail "vertices"
[[ $(wc -l <"$work/city_groundtruth.txt") == 300 ]] || fail "ground truth beside the graph"
"$slamtool" generate-manhattan --poses 300 --seed 4 --truth "$work/again_truth.txt" "$work/again.g2o" >/dev/null
cmp -s "$work/city.g2o" "$work/again.g2o" || fail "same seed, different graph"
cmp -s "$work/city_groundtruth.txt" "$work/again_truth.txt" || fail "same seed, different truth"
"$slamtool" generate-manhattan --poses 300 --seed 5 "$work/other.g2o" >/dev/null
if cmp -s "$work/city.g2o" "$work/other.g2o"; then fail "another seed wrote the same graph"; fi
"$slamtool" replay-g2o "$work/city.g2o" >"$work/replay.txt" || fail "replay of the generated graph"
# Both back-ends on the generated graph (all its closures true): each accepts most closures, and they agree on
# nearly all (identical decisions are asserted on the shared real graphs, slamcore incremental_solver_test; on
# generated cities 2–5 % of closures sit at the edge of the gates and go either way).
"$slamtool" replay-g2o "$work/city.g2o" --json --backend batch >"$work/batch.json"
"$slamtool" replay-g2o "$work/city.g2o" --json >"$work/incremental.json"
python3 - "$work/batch.json" "$work/incremental.json" <<'PY'
import json, sys
batch, incremental = (json.load(open(path)) for path in sys.argv[1:3])
assert batch["backend"] == "batch" and incremental["backend"] == "incremental", (batch["backend"], incremental["backend"])
closures = len(batch["accepted"]) + len(batch["rejected"])
a, b = set(map(tuple, batch["accepted"])), set(map(tuple, incremental["accepted"]))
assert len(a) >= 0.8 * closures and len(b) >= 0.8 * closures, (len(a), len(b), closures)
assert len(a ^ b) <= 0.1 * closures, f"{len(a ^ b)} of {closures} closures decided differently"
assert abs(incremental["mapper_chi2"] - incremental["final_chi2"]) <= 1e-6 * incremental["final_chi2"] + 1e-9
PY
if "$slamtool" replay-g2o "$work/city.g2o" --backend fast 2>/dev/null; then fail "accepted an unknown back-end"; fi
# The decision log, one JSON object per decision: every closure accepted is a direct edge or part of an
# accepted hypothesis, and the log's direct edges are as many as the JSON summary counts.
"$slamtool" replay-g2o "$work/city.g2o" --json --decisions "$work/decisions.jsonl" >"$work/summary.json"
python3 - "$work/summary.json" "$work/decisions.jsonl" <<'PY'
import json, sys
summary = json.load(open(sys.argv[1]))
decisions = [json.loads(line) for line in open(sys.argv[2])]
kinds = [d["kind"] for d in decisions]
assert kinds.count("direct_edge") == summary["direct_edges"], (kinds.count("direct_edge"), summary["direct_edges"])
assert kinds[0] == "component_created", kinds[0]
assert all({"time", "kind", "node", "view", "reason"} <= d.keys() for d in decisions)
assert all(d["reason"] for d in decisions if d["kind"] == "direct_edge"), "a direct edge without its reason"
PY
if "$slamtool" replay-g2o "$work/city.g2o" --decisions "$work/missing/decisions.jsonl" 2>"$work/err.txt" >/dev/null; then
  fail "wrote the decision log into a missing directory"
fi
grep -q "missing/decisions.jsonl" "$work/err.txt" || fail "unclear error: $(cat "$work/err.txt")"

if "$slamtool" generate-manhattan --poses 1 "$work/bad.g2o" 2>"$work/err.txt"; then fail "accepted 1 pose"; fi
grep -q -- "--poses" "$work/err.txt" || fail "unclear error: $(cat "$work/err.txt")"
[[ ! -e "$work/bad.g2o" ]] || fail "wrote output for refused input"
echo "slamtool generate-manhattan: all checks passed"

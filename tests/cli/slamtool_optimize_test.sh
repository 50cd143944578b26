#!/usr/bin/env bash
# slamtool optimize as a user runs it: JSON keys and values, the written file, and refusals of bad input.
# Arguments: slamtool, a data directory (the repository's data/: the ring graph, optimum χ² 11.1631).
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
slamtool=$1
data=$2

"$slamtool" optimize "$data/posegraphs/vertigo/ring.g2o" --json --out "$work/out.g2o" >"$work/report.json"
python3 - "$work/report.json" <<'PY'
import json, sys
report = json.load(open(sys.argv[1]))
for key in ("initial_chi2", "final_chi2", "iterations", "seconds"):
    assert key in report, f"missing key {key}"
assert report["initial_chi2"] > 1e6, report
assert abs(report["final_chi2"] - 11.1631) < 0.001, report
assert report["iterations"] >= 1 and report["seconds"] > 0, report
PY
[[ $(grep -c '^VERTEX_SE2' "$work/out.g2o") == 434 ]] || fail "written graph lacks vertices"

# The written, optimised graph is already at the optimum.
"$slamtool" optimize "$work/out.g2o" --init warm --json >"$work/again.json"
python3 -c "import json,sys; r=json.load(open(sys.argv[1])); assert abs(r['initial_chi2']-11.1631)<0.001, r" "$work/again.json"

printf 'VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 7 1 0 0 1 0 0 1 0 1\n' >"$work/bad.g2o"
if "$slamtool" optimize "$work/bad.g2o" 2>"$work/err.txt"; then fail "accepted an edge to a missing vertex"; fi
grep -q "bad.g2o:3: edge refers to vertex 7" "$work/err.txt" || fail "unclear error: $(cat "$work/err.txt")"
[[ ! -e "$work/bad-out.g2o" ]] || fail "wrote output for refused input"
echo "slamtool optimize: all checks passed"

#!/usr/bin/env bash
# The protrusion data commands as an engineer chains them on the repository's robot-vacuum maps: generate a
# training family and a held-out family (same seed, same files), train a model, evaluate it on the held-out
# pairs and leave one home out, list every region or only the misclassified ones, and refuse bad requests
# naming what was wrong. Arguments: slamtool, a data directory (the repository's data/).
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
slamtool=$1
data=$2

"$slamtool" make-protrusion-data "$data/maps" --out "$work/train" --family physical --variants 2 --seed 1 \
  >"$work/make.txt"
grep -Eq "^10 pairs from 5 maps: [0-9]+ protrusions, [0-9]+ new spaces" "$work/make.txt" ||
  fail "make-protrusion-data: $(cat "$work/make.txt")"
"$slamtool" make-protrusion-data "$data/maps" --out "$work/again" --family physical --variants 2 --seed 1 \
  >/dev/null
diff -r -q "$work/train" "$work/again" >/dev/null || fail "the same seed wrote another data set"
"$slamtool" make-protrusion-data "$data/maps" --out "$work/heldout" --family heldout --variants 1 --seed 7 \
  >/dev/null
if "$slamtool" make-protrusion-data "$data/maps" --out "$work/train" --family physical --variants 1 --seed 2 \
  2>"$work/err"; then
  fail "a second data set was written over the first"
fi
grep -q "index.csv" "$work/err" || fail "unclear refusal of a used directory: $(cat "$work/err")"

"$slamtool" train-protrusions "$work/train" --out "$work/model.yml" --classifier random_forest --trees 5 \
  --max-depth 4 --json >"$work/train.json"
python3 - "$work/train.json" <<'PY' || fail "train-protrusions --json"
import json, sys
trained = json.load(open(sys.argv[1]))
assert trained["classifier"] == "random_forest", trained.keys()
assert len(trained["features"]) == 21 and any(f["selected"] for f in trained["features"]), trained["features"]
PY
grep -q "format: slamcore-protrusion-model" "$work/model.yml" || fail "the model file names no format"

# The held-out pairs, the trained model: the matrix counts every region once, and --list-regions names each
# of them (its truth agrees with the matrix's rows), --list-errors exactly the off-diagonal ones.
"$slamtool" eval-protrusions "$work/heldout" --model "$work/model.yml" --json --list-regions \
  >"$work/eval.json" 2>"$work/regions.txt"
"$slamtool" eval-protrusions "$work/heldout" --model "$work/model.yml" --json --list-errors \
  >/dev/null 2>"$work/errors.txt"
python3 - "$work/eval.json" "$work/regions.txt" "$work/errors.txt" <<'PY' || fail "eval-protrusions listings"
import json, re, sys
result = json.load(open(sys.argv[1]))
c = result["confusion"]
listed = [l for l in open(sys.argv[2]) if re.match(r"\S+ region \d+ truth (protrusion|new_space) p=", l)]
errors = [l for l in open(sys.argv[3]) if re.match(r"\S+ region \d+ truth (protrusion|new_space) p=", l)]
# Protrusions the segmentation lost count as false negatives but are no region.
missed = result["missed_by_segmentation"]
protrusion_regions = c["true_positives"] + c["false_negatives"] - missed
assert result["mode"] == "model" and result["pairs"] == 5, result
assert len(listed) == result["regions"] == protrusion_regions + c["false_positives"] + c["true_negatives"], result
assert sum(" truth protrusion " in l for l in listed) == protrusion_regions, listed
assert len(errors) == c["false_positives"] + c["false_negatives"] - missed, (len(errors), c)
assert set(errors) <= set(listed), "a listed error is not among the regions"
assert all(len(re.findall(r" \w+=[-0-9.e+]+", l)) >= 21 for l in listed), "a region without its features"
PY

"$slamtool" eval-protrusions "$work/train" --leave-one-home-out --trees 5 --max-depth 4 --json \
  >"$work/loho.json"
# Each of the four homes is tested once on a model of the other three: every region is classed once.
python3 -c '
import json, sys
r = json.load(open(sys.argv[1]))
c = r["confusion"]
assert r["mode"] == "leave_one_home_out" and r["pairs"] == 10, r
assert c["true_positives"] + c["false_negatives"] - r["missed_by_segmentation"] + c["false_positives"] + \
    c["true_negatives"] == r["regions"], r
' "$work/loho.json" || fail "leave one home out: $(head -c 300 "$work/loho.json")"

# Refusals name what was wrong.
if "$slamtool" eval-protrusions "$work/heldout" 2>"$work/err"; then fail "eval without a model ran"; fi
grep -q -- "--model MODEL or --leave-one-home-out" "$work/err" || fail "unclear refusal: $(cat "$work/err")"
if "$slamtool" eval-protrusions "$work/heldout" --model "$work/model.yml" --list-errors --list-regions \
  2>"$work/err"; then
  fail "--list-errors and --list-regions together ran"
fi
grep -q -- "--list-errors excludes --list-regions" "$work/err" || fail "unclear refusal: $(cat "$work/err")"
if "$slamtool" eval-protrusions "$work/heldout" --model "$work/model.yml" --homes nowhere 2>"$work/err"; then
  fail "an unknown home was evaluated"
fi
grep -q "no pairs to evaluate (check --homes)" "$work/err" || fail "unclear refusal: $(cat "$work/err")"
echo "slamtool protrusion data commands: all checks passed"

#!/usr/bin/env bash
# slamtool valetudo-to-map as a user runs it on a real Valetudo export from data/valetudo: the written
# map_server YAML + PGM, the printed areas against the file's own metaData.area, a refused broken file, and
# refused output names that would replace an image or an input map.
# Arguments: slamtool, a data directory (the repository's data/).
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
slamtool=$1
data=$2
export_file="$data/valetudo/dreame_d9_1058_with_segments.json"

"$slamtool" valetudo-to-map "$export_file" --out "$work/home.yaml" --json >"$work/report.json"
[[ -s "$work/home.yaml" && -s "$work/home.pgm" ]] || fail "no YAML + PGM written"
grep -q '^image: home.pgm' "$work/home.yaml" || fail "YAML does not name its image: $(cat "$work/home.yaml")"
python3 - "$work/report.json" "$export_file" <<'PY'
import json, sys
report = json.load(open(sys.argv[1]))
source = json.load(open(sys.argv[2]))
for key in ("version", "pixel_size_cm", "grid", "area_m2", "layers", "robot", "dock", "paths", "virtual_walls", "zones"):
    assert key in report, f"missing key {key}"
assert len(report["layers"]) == len(source["layers"]), report["layers"]
for ours, theirs in zip(report["layers"], source["layers"]):
    assert abs(ours["area_m2"] - theirs["metaData"]["area"] / 1e4) < 1e-9, (ours, theirs["metaData"])
total = source["metaData"]["totalLayerArea"] / 1e4
assert abs(sum(report["area_m2"].values()) - total) < 1e-9, (report["area_m2"], total)
assert report["grid"]["width"] == 143 and report["grid"]["height"] == 226, report["grid"]
assert abs(report["robot"]["x"] - 34.60) < 1e-9 and abs(report["robot"]["y"] + 31.14) < 1e-9, report["robot"]
PY
# The written map equals the map_server conversion of the same export carried in data/maps.
cmp <(tail -c $((143 * 226)) "$work/home.pgm") <(tail -c $((143 * 226)) "$data/maps/valetudo_dreame_d9_1058_with_segments.pgm") \
  || fail "pixels differ from data/maps/valetudo_dreame_d9_1058_with_segments.pgm"

# The table: one row per layer with the file's area beside ours.
"$slamtool" valetudo-to-map "$export_file" --out "$work/table.yaml" >"$work/table.txt"
grep -q "^segment  2 .* 35.9975 " "$work/table.txt" || fail "layer table lacks segment 2's area: $(cat "$work/table.txt")"

# A truncated export is refused, naming the field, and nothing is written.
python3 - "$export_file" "$work/broken.json" <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))
m["layers"][0]["compressedPixels"] = m["layers"][0]["compressedPixels"][:-1]
json.dump(m, open(sys.argv[2], "w"))
PY
if "$slamtool" valetudo-to-map "$work/broken.json" --out "$work/broken.yaml" 2>"$work/err.txt"; then
  fail "accepted a truncated pixel array"
fi
grep -q "INVALID_ARGUMENT: .*broken.json: layers\[0\].compressedPixels: length .* is not a multiple of 3" "$work/err.txt" \
  || fail "unclear error: $(cat "$work/err.txt")"
[[ ! -e "$work/broken.yaml" ]] || fail "wrote a map for refused input"

# An --out named like the image would have been written over by its own YAML: refused, the image kept.
cp "$work/home.pgm" "$work/kept.pgm"
if "$slamtool" valetudo-to-map "$export_file" --out "$work/kept.pgm" 2>"$work/err.txt"; then
  fail "wrote the YAML over its own image"
fi
grep -q "kept.pgm: names the map's image" "$work/err.txt" || fail "unclear error: $(cat "$work/err.txt")"
cmp "$work/kept.pgm" "$work/home.pgm" || fail "the image named by --out was changed"

# protrusions --repair writes beside its inputs, never over them.
cp "$work/home.yaml" "$work/parent.yaml"; sed -i 's/^image: .*/image: home.pgm/' "$work/parent.yaml"
if "$slamtool" protrusions --parent "$work/parent.yaml" --child "$work/home.yaml" --repair cut \
    --repaired "$work/parent.yaml" >/dev/null 2>"$work/err.txt"; then
  fail "--repaired replaced the parent map"
fi
grep -q "would overwrite the input" "$work/err.txt" || fail "unclear error: $(cat "$work/err.txt")"
echo "slamtool valetudo-to-map: all checks passed"

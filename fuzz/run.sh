#!/usr/bin/env bash
# Builds the libFuzzer harnesses with Debian's clang (their own build directory, build-fuzz/) against the main
# build (build/, made first by deploy/build.sh), then runs each for FUZZ_SECONDS (default 60) on a seed corpus:
# fuzz/corpus/<harness>/ (checked in); for telemetry a few runs written by fleetsim; for g2o, map_server
# and valetudo excerpts or files of data/. Prints executions
# per harness; exits non-zero when a harness crashed (the input is left as build-fuzz/<harness>/crash-*;
# turn it into a regression test).
#
#   bash fuzz/run.sh            FUZZ_SECONDS=300 bash fuzz/run.sh
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
seconds=${FUZZ_SECONDS:-60}
out=$root/build-fuzz
mkdir -p "$out"
CXX=clang++ cmake -S "$root/fuzz" -B "$out" -G Ninja -DFLEET_BUILD_DIR="$root/build" >"$out/configure.log" 2>&1 ||
  { tail -n 30 "$out/configure.log"; echo "fuzz harness configure failed (log: $out/configure.log)"; exit 1; }
ninja -C "$out" -j2 >"$out/build.log" 2>&1 ||
  { tail -n 30 "$out/build.log"; echo "fuzz harness build failed (log: $out/build.log)"; exit 1; }

# Telemetry seeds: one small simulated run per robot, as fleet.v1.RunFile bytes.
telemetry_seeds=$out/seeds/telemetry
if [[ ! -d $telemetry_seeds ]]; then
  mkdir -p "$telemetry_seeds"
  "$root/build/bin/fleetsim" --world "$root/data/floorplans" --robots 2 --runs 1 --minutes 0.5 --seed 3 \
    --out "$out/seeds/sim" >/dev/null
  find "$out/seeds/sim" -name '*.runpb' -exec cp {} "$telemetry_seeds/" \;
fi

# g2o and map_server seeds from the repository's data/ (licensed there; not copied into fuzz/corpus).
if [[ ! -d $out/seeds/g2o ]]; then
  mkdir -p "$out/seeds/g2o" "$out/seeds/map_server"
  for graph in "$root"/data/posegraphs/*/*.g2o "$root"/data/posegraphs/*/*.graph; do
    [[ -e $graph ]] && head -n 200 "$graph" >"$out/seeds/g2o/$(basename "$graph")"
  done
  cp "$root"/data/maps/*.yaml "$out/seeds/map_server/"
  printf 'P5\n4 2\n255\n\xfe\x00\xcd\xfe\x00\x00\xfe\xcd' >"$out/seeds/map_server/small.pgm"
  printf 'P2\n2 2\n255\n254 0\n205 254\n' >"$out/seeds/map_server/ascii.pgm"
fi
# Valetudo seeds: data/'s real exports and fuzz/corpus/valetudo's small hand-made ones (one deflated, as
# Valetudo publishes over MQTT).
if [[ ! -d $out/seeds/valetudo ]]; then
  mkdir -p "$out/seeds/valetudo"
  cp "$root"/data/valetudo/*.json "$root"/fuzz/corpus/valetudo/* "$out/seeds/valetudo/"
fi

status=0
for harness in telemetry parameters valetudo http_request g2o map_server; do
  work=$out/$harness
  mkdir -p "$work/corpus"
  seeds=$root/fuzz/corpus/$harness
  [[ $harness == telemetry ]] && seeds=$telemetry_seeds
  [[ $harness == g2o || $harness == map_server || $harness == valetudo ]] && seeds=$out/seeds/$harness
  log=$work/fuzz.log
  if (cd "$work" && "$out/${harness}_fuzzer" -max_total_time="$seconds" -rss_limit_mb=2048 -max_len=1048576 \
        -print_final_stats=1 corpus "$seeds" >"$log" 2>&1); then
    verdict="0 crashes"
  else
    verdict="CRASH (see $work)"
    status=1
  fi
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo "?")
  echo "$harness: $runs executions in $seconds s, $verdict"
done
exit $status

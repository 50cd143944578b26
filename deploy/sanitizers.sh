#!/usr/bin/env bash
# Sanitizer lanes (issue #20), run by .ci/run after the README's test command; not part of the test command
# itself (a cold build of the instrumented targets takes most of an hour on 2 cores; with the ccache warm,
# minutes).
#
#   ASan+UBSan, build-asan/ (-O1 -g1, asserts on, -fsanitize=address,undefined, every UBSan finding fatal):
#     the unit test binaries slamcore_tests, storage_tests (SQLite and a throwaway PostgreSQL server),
#     analyzer_tests, server_tests, proto_tests, fleet_client_tests, and the fleetd integration tests on
#     loopback (fleetd_integration, _map_repair, _hostile, _operations, _erasure), whose fleetd and fleetctl
#     children are instrumented too.
#   TSan, build-tsan/ (Release plus -fsanitize=thread on server/, storage/, analyzer/, the client library and
#     the executables; deploy/sanitizers/tsan.cmake says why slamcore/ stays uninstrumented): server_tests,
#     fleet_client_tests, fleetd_hostile and fleetd_erasure (not _integration, _map_repair, _operations: their
#     deadlines do not hold under TSan's slowdown). Debian's gRPC, OpenSSL, OpenCV and CHOLMOD are not
#     instrumented; deploy/sanitizers/tsan.supp says what that hides.
#
# Both lanes use the repository's data/ only (SHARED_DATA_DIR points at nothing), as in a user's clone: the
# tests over the larger set (whole-dataset replays such as slamcore's SharedGraphs/BackendEquivalenceTest)
# cover no other code and take tens of minutes instrumented (one such case ran over 7 min under ASan).
# The unit binaries run as one process each, two at a time, not one process per test case under ctest: each
# storage_tests process starts its own PostgreSQL server (~3 s, more under ASan). The fleetd tests run under
# ctest (they are one process each anyway).
# Not run here: sim_tests, filter_accuracy_test, the slamtool/fleetctl/fleetsim CLI tests, fleetsim's
# lifelong tests and scaleout_fault (minutes of simulation and optimisation in Release, several times that
# sanitized, and no code path the tests above leave out), fleetd_python_client and dashboard_browser (their
# client side is Python and a browser, not our C++; the server side they exercise is the one above), the
# benches and the deploy manifests check.
#
# Every sanitizer writes its reports to a log directory (log_path), so a report inside a fleetd or fleetctl
# child process fails the lane even when the test talking to it passes. Suppressions in deploy/sanitizers/
# name third-party internals only, each with its reason. Exits non-zero on any report or test failure.
#
#   bash deploy/sanitizers.sh          SANITIZER_LANES=tsan bash deploy/sanitizers.sh
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
export CCACHE_DIR=${CCACHE_DIR:-$HOME/.cache/ccache}
export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$PWD}
export CCACHE_NOHASHDIR=1
jobs=${SANITIZER_JOBS:-2}
lanes=${SANITIZER_LANES:-asan,tsan}
supp=$root/deploy/sanitizers
unit_binaries=(storage_tests slamcore_tests analyzer_tests server_tests proto_tests fleet_client_tests)
fleetd_tests=(fleetd_integration fleetd_map_repair fleetd_hostile fleetd_operations fleetd_erasure)
# Under TSan fleetd runs several times slower: fleetd_integration's and fleetd_map_repair's waits for the
# analysis time out, and fleetd_operations' in-flight-limit test misses its stream deadlines; the threads
# they drive are the same fleetd's that these two exercise.
tsan_fleetd_tests=(fleetd_hostile fleetd_erasure)
fleetd_targets=(fleetd_integration_tests fleetd_map_repair_tests fleetd_hostile_tests fleetd_operations_tests
                fleetd_erasure_tests)
status=0

# Runs the named unit binaries of build dir $1, two at a time; a binary's output is shown when it fails.
run_binaries() {
  local dir=$1; shift
  local logs=$dir/sanitizer-logs
  for binary in "$@"; do
    ( rc=0; "$dir/bin/$binary" --gtest_brief=1 >"$logs/$binary.out" 2>&1 || rc=$?; echo $rc >"$logs/$binary.rc" ) &
    while (( $(jobs -rp | wc -l) >= jobs )); do wait -n || true; done
  done
  wait
  for binary in "$@"; do
    if [[ $(cat "$logs/$binary.rc") == 0 ]]; then
      echo "$binary: $(grep -o '\[  PASSED  \] [0-9]* tests\?' "$logs/$binary.out" || echo passed)"
    else
      echo "$binary: FAILED (exit $(cat "$logs/$binary.rc"))"; cat "$logs/$binary.out"; status=1
    fi
  done
}

# Runs the lane's tests in build dir $1 and fails the lane on any report in its log directory.
run_lane() {
  local dir=$1; shift
  local start=$SECONDS
  local -a binaries=() fleetd=()
  for name in "$@"; do
    case $name in fleetd_*) fleetd+=("$name") ;; *) binaries+=("$name") ;; esac
  done
  run_binaries "$dir" "${binaries[@]}"
  if (( ${#fleetd[@]} )); then
    local regex; regex="^($(IFS='|'; echo "${fleetd[*]}"))\$"
    ctest --test-dir "$dir" --output-on-failure -j "$jobs" --timeout 1200 -R "$regex" || status=1
  fi
  if compgen -G "$dir/sanitizer-logs/report.*" >/dev/null; then
    echo "sanitizer reports:"; cat "$dir"/sanitizer-logs/report.*; status=1
  fi
  echo "tests: $((SECONDS - start)) s"
}

if [[ $lanes == *asan* ]]; then
  echo "== ASan+UBSan (build-asan/) =="
  lane_start=$SECONDS
  flags="-fsanitize=address,undefined -fno-sanitize-recover=undefined"
  cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1" \
    -DSHARED_DATA_DIR="$root/build-asan/no-shared-data" \
    -DCMAKE_CXX_FLAGS="$flags -fno-omit-frame-pointer" -DCMAKE_EXE_LINKER_FLAGS="$flags" \
    -DCMAKE_SHARED_LINKER_FLAGS="$flags" >/dev/null
  rm -rf build-asan/sanitizer-logs && mkdir -p build-asan/sanitizer-logs
  log=$root/build-asan/sanitizer-logs/report
  # Set before building too: gtest_discover_tests runs each test binary to list its tests. No
  # detect_stack_use_after_return: its fake stack frames make Ceres's per-residual calls several times slower.
  export ASAN_OPTIONS="log_path=$log:detect_leaks=1:check_initialization_order=1:strict_init_order=1"
  export LSAN_OPTIONS="suppressions=$supp/lsan.supp:print_suppressions=0"
  export UBSAN_OPTIONS="log_path=$log:print_stacktrace=1:halt_on_error=1:suppressions=$supp/ubsan.supp"
  cmake --build build-asan -j "$jobs" --target "${unit_binaries[@]}" "${fleetd_targets[@]}"
  rm -f build-asan/sanitizer-logs/report.*
  echo "ASan+UBSan build: $((SECONDS - lane_start)) s"
  run_lane build-asan "${unit_binaries[@]}" "${fleetd_tests[@]}"
  echo "ASan+UBSan lane: $((SECONDS - lane_start)) s"
  unset ASAN_OPTIONS LSAN_OPTIONS UBSAN_OPTIONS
fi

if [[ $lanes == *tsan* ]]; then
  echo "== TSan (build-tsan/) =="
  lane_start=$SECONDS
  cmake -S . -B build-tsan -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_EXE_LINKER_FLAGS=-fsanitize=thread \
    -DSHARED_DATA_DIR="$root/build-tsan/no-shared-data" \
    -DCMAKE_PROJECT_INCLUDE="$supp/tsan.cmake" >/dev/null
  rm -rf build-tsan/sanitizer-logs && mkdir -p build-tsan/sanitizer-logs
  export TSAN_OPTIONS="log_path=$root/build-tsan/sanitizer-logs/report:halt_on_error=1:second_deadlock_stack=1:suppressions=$supp/tsan.supp"
  cmake --build build-tsan -j "$jobs" --target server_tests fleet_client_tests "${fleetd_targets[@]}"
  rm -f build-tsan/sanitizer-logs/report.*
  echo "TSan build: $((SECONDS - lane_start)) s"
  run_lane build-tsan server_tests fleet_client_tests "${tsan_fleetd_tests[@]}"
  echo "TSan lane: $((SECONDS - lane_start)) s"
  unset TSAN_OPTIONS
fi
exit $status

#!/usr/bin/env bash
# The README's test command: install dependencies, build, run every test. Exits non-zero when any fails.
set -euo pipefail
cd "$(dirname "$0")/.."
bash deploy/bootstrap.sh
source deploy/build.sh
ctest --test-dir "$BUILD_DIR" --output-on-failure -j "$(nproc)" --timeout 1200

#!/usr/bin/env bash
# Configures and builds the project into build/ (Release, Ninja, ccache when present). Sourced by the
# two README commands; sets BUILD_DIR.
set -euo pipefail
BUILD_DIR=${BUILD_DIR:-build}
export CCACHE_DIR=${CCACHE_DIR:-$HOME/.cache/ccache}
cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$BUILD_DIR" -j "$(nproc)"

#!/usr/bin/env bash
# Configures and builds the project into build/ (Release, Ninja, ccache when present). Sourced by the
# two README commands; sets BUILD_DIR.
set -euo pipefail
BUILD_DIR=${BUILD_DIR:-build}
export CCACHE_DIR=${CCACHE_DIR:-$HOME/.cache/ccache}
# Paths inside the checkout are hashed relative to it, so a fresh clone elsewhere (CI, a second work tree)
# reuses the cache instead of compiling everything again.
export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$PWD}
export CCACHE_NOHASHDIR=1
cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$BUILD_DIR" -j "$(nproc)"

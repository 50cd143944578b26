#!/usr/bin/env bash
# Installs every Debian package the project needs. Idempotent: when everything is present it only checks
# (dpkg-query) and returns in well under a second; otherwise it runs `apt-get update` once and installs the
# missing packages. Downloads nothing but Debian packages.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config ccache git clang-format clang libclang-rt-14-dev
  libeigen3-dev libceres-dev libsuitesparse-dev libopencv-dev
  libboost-dev libboost-math-dev
  libprotobuf-dev protobuf-compiler libgrpc++-dev protobuf-compiler-grpc
  libsqlite3-dev sqlite3 libpqxx-dev postgresql zlib1g-dev libssl-dev openssl
  libspdlog-dev libcli11-dev nlohmann-json3-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  chromium chromium-driver
  python3 python3-grpcio python3-grpc-tools
  yamllint python3-yaml python3-jsonschema
)

# Node.js and npm (dashboard assets, browser tests): Debian's packages only where no node/npm is installed;
# a machine that ships its own Node.js (with npm inside) conflicts with Debian's separate npm package.
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then packages+=(nodejs npm); fi

missing=()
for package in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${db:Status-Status}' "$package" 2>/dev/null || true)
  [[ "$status" == "installed" ]] || missing+=("$package")
done

if ((${#missing[@]} == 0)); then
  echo "bootstrap: all ${#packages[@]} packages present"
  exit 0
fi

echo "bootstrap: installing ${#missing[@]} packages: ${missing[*]}"
sudo_cmd=()
if ((EUID != 0)); then sudo_cmd=(sudo); fi
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "bootstrap: done"

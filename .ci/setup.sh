#!/usr/bin/env bash
# Installs perifx's build dependencies (Debian 12 packages) when missing, then configures and builds
# a Release tree in ./build. Idempotent: a second run only rebuilds what changed.
#   bash .ci/setup.sh        everything (library, CLI, tests, benchmarks): what CI runs
#   bash .ci/setup.sh cli    only the perifx command line and the library it links (the quick start)
#   bash .ci/setup.sh mpi    the distributed runtime: Open MPI, and perifx built with PERIFX_MPI=ON in
#                            ./build-mpi (the command line only; `ctest --test-dir build-mpi` runs its test)
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(cmake g++ make libeigen3-dev libtbb-dev nlohmann-json3-dev doctest-dev libbenchmark-dev libpng-dev libcli11-dev libspectra-dev tetgen
          pybind11-dev python3-dev python3-numpy python3-pytest)
missing=()
[[ "${1:-}" == "mpi" ]] && packages+=(libopenmpi-dev openmpi-bin)
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "perifx setup: installing ${missing[*]}"
  if [[ $(id -u) -eq 0 ]]; then sudo=""; else sudo="sudo"; fi
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

if [[ "${1:-}" == "mpi" ]]; then
  cmake -S . -B build-mpi -DCMAKE_BUILD_TYPE=Release -DPERIFX_MPI=ON -DPERIFX_TESTS=OFF -DPERIFX_BENCH=OFF \
        -DPERIFX_PYTHON=OFF >/dev/null
  cmake --build build-mpi -j "$(nproc)" --target perifx
  exit 0
fi
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
if [[ "${1:-}" == "cli" ]]; then
  cmake --build build -j "$(nproc)" --target perifx
else
  cmake --build build -j "$(nproc)"
fi

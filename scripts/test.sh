#!/usr/bin/env bash
# Installs what is missing, builds prism and its tests, and runs the whole suite
# with ctest. Exits non-zero on any failure.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bash scripts/setup.sh
werror=OFF
if [ "${CI:-}" = true ]; then werror=ON; fi
cmake -S . -B build/test -G Ninja -DCMAKE_BUILD_TYPE=Release -DPRISM_WERROR=$werror \
  -DPRISM_BUILD_BENCH=OFF >/dev/null
cmake --build build/test
cd build/test
ctest --output-on-failure -j "$(nproc)" "$@"

#!/usr/bin/env bash
# Installs what is missing, builds prism in Release and renders the built-in
# default scene to out/default.png and out/default.exr.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bash scripts/setup.sh
cmake -S . -B build/release -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build/release --target prism-render
mkdir -p out
./build/release/examples/prism-render --out out/default.png --out out/default.exr "$@"
echo "prism: wrote $root/out/default.png and $root/out/default.exr"

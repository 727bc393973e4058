#!/usr/bin/env bash
# The convergence harness (bench/convergence/): installs gnuplot-nox if missing
# (through scripts/setup.sh, Debian), builds convergence_bench in build/bench
# (Release, -O3 -march=native), runs it from the project root and draws one
# log-log chart per scene into docs/images/convergence_<scene>.png.
# References are cached in bench/convergence/cache/ (gitignored) and reused;
# delete that directory to render them again.
# Results: bench/results/convergence.csv and bench/results/convergence_slopes.csv;
# the adaptive-sampling comparison in bench/results/convergence_adaptive*.csv and
# docs/images/convergence_adaptive_default.png.
# Usage: scripts/convergence.sh [shared=../shared] [reference spp=0] [options...]
#   reference spp 0: each scene's own (bench/convergence/convergence.cpp);
#   options go to convergence_bench: --scenes=a,b,... runs only those scenes
#   (their rows replace theirs in the CSVs; the adaptive comparison then runs
#   only if the default scene is among them), --seeds=N (3 by default).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bash scripts/setup.sh gnuplot-nox
shared="${1:-$root/../shared}"
ref_spp="${2:-0}"
shift $(( $# > 2 ? 2 : $# ))
opts=("$@")
cmake -S . -B build/bench -G Ninja -DCMAKE_BUILD_TYPE=Release -DPRISM_BUILD_BENCH=ON \
  -DPRISM_BUILD_TESTS=OFF -DPRISM_BUILD_EXAMPLES=OFF >/dev/null
cmake --build build/bench --target convergence_bench
mkdir -p bench/results docs/images
./build/bench/bench/convergence_bench bench/results "$shared" bench/convergence/cache "$ref_spp" "${opts[@]}"
# Uniform against adaptive sampling on the default scene (docs/adaptive.md).
if [[ " ${opts[*]} " != *" --scenes="* || " ${opts[*]} " == *"--scenes="*default* ]]; then
  ./build/bench/bench/convergence_bench bench/results "$shared" bench/convergence/cache "$ref_spp" adaptive
fi
python3 bench/convergence/plot.py bench/results docs/images
echo "--- bench/results/convergence_slopes.csv"; cat bench/results/convergence_slopes.csv

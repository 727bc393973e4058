#!/usr/bin/env bash
# Installs what the benchmarks need (Embree 3, Google Benchmark), builds them in
# Release with -O3 -march=native (bench targets only) and runs them from the
# project root. Results: bench/results/traversal.csv (with watertight.csv and
# instances.csv), layouts.csv (prism's BVH layouts, one binary each, on the
# procedural mesh) and render.csv; the chart docs/images/traversal.png
# (bench/plot_traversal.py, gnuplot).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bash scripts/setup.sh libembree-dev libbenchmark-dev gnuplot-nox
cmake -S . -B build/bench -G Ninja -DCMAKE_BUILD_TYPE=Release -DPRISM_BUILD_BENCH=ON \
  -DPRISM_BUILD_TESTS=OFF -DPRISM_BUILD_EXAMPLES=OFF >/dev/null
layouts=(w4 quant w4_quant)
cmake --build build/bench --target traversal_bench render_bench "${layouts[@]/#/traversal_bench_}"
mkdir -p bench/results
rm -f bench/results/layouts.csv
./build/bench/bench/traversal_bench --layout-csv bench/results/layouts.csv "$@"
# prism's other BVH layouts (compile-time choices), on the procedural mesh:
# their rows join the default layout's in bench/results/layouts.csv.
for l in "${layouts[@]}"; do
  ./build/bench/bench/traversal_bench_$l "$@" --cases procedural --out "build/bench/layouts/$l/traversal.csv" \
    --layout-csv bench/results/layouts.csv
done
./build/bench/bench/render_bench bench/results/render.csv
python3 bench/plot_traversal.py bench/results docs/images
echo "--- bench/results/traversal.csv"; cat bench/results/traversal.csv
echo "--- bench/results/layouts.csv"; cat bench/results/layouts.csv
echo "--- bench/results/render.csv"; cat bench/results/render.csv

#!/usr/bin/env bash
# Installs what the benchmarks need (Embree 3, Google Benchmark), builds them in
# Release with -O3 -march=native (bench targets only) and runs them from the
# project root. Results: bench/results/traversal.csv (with watertight.csv and
# instances.csv), layouts.csv (prism's BVH layouts, one binary each: every
# case for the default layout, the procedural mesh for the others) and
# render.csv; the chart docs/images/traversal.png (bench/plot_traversal.py,
# gnuplot). Arguments go to traversal_bench (--help lists them).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bash scripts/setup.sh libembree-dev libbenchmark-dev gnuplot-nox
cmake -S . -B build/bench -G Ninja -DCMAKE_BUILD_TYPE=Release -DPRISM_BUILD_BENCH=ON \
  -DPRISM_BUILD_TESTS=OFF -DPRISM_BUILD_EXAMPLES=OFF >/dev/null
layouts=(w8 w4 quant w4_quant)
cmake --build build/bench --target traversal_bench render_bench "${layouts[@]/#/traversal_bench_}"
for a in "$@"; do
  if [ "$a" = --help ] || [ "$a" = -h ]; then exec ./build/bench/bench/traversal_bench --help; fi
done
mkdir -p bench/results
# The layouts' rows gather in a new file, which replaces bench/results/layouts.csv
# once every binary has run.
layouts_csv=build/bench/layouts.csv.new
rm -f "$layouts_csv"
./build/bench/bench/traversal_bench "$@" --layout-csv "$layouts_csv"
# prism's other BVH layouts (compile-time choices), on the procedural mesh.
for l in "${layouts[@]}"; do
  ./build/bench/bench/traversal_bench_$l "$@" --cases procedural --out "build/bench/layouts/$l/traversal.csv" \
    --layout-csv "$layouts_csv"
done
mv "$layouts_csv" bench/results/layouts.csv
./build/bench/bench/render_bench bench/results/render.csv
python3 bench/plot_traversal.py bench/results docs/images
echo "--- bench/results/traversal.csv"; cat bench/results/traversal.csv
echo "--- bench/results/layouts.csv"; cat bench/results/layouts.csv
echo "--- bench/results/render.csv"; cat bench/results/render.csv

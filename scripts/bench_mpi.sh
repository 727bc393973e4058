#!/usr/bin/env bash
# Distributed rendering figures (docs/distributed.md), on this machine's cores:
#  1. throughput of the default scene: 2 ranks x 1 thread (mpirun) against
#     1 process x 2 threads, alternating, REPS times each (default 5); the
#     render's own samples/s (after loading; the MPI figure includes the
#     reduction) and the whole command's wall time, best and median;
#  2. the film reduction of a 4K film (bench/mpi_reduce_bench.cpp);
#  3. balance of the samples and tiles splits on an uneven scene
#     (bench/mpi_balance_bench.cpp).
# Writes bench/results/mpi.txt. Usage: scripts/bench_mpi.sh [build dir]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bash scripts/setup.sh
build="${1:-build/bench-mpi}"
if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DPRISM_BUILD_BENCH=ON -DPRISM_BUILD_TESTS=OFF >/dev/null
fi
cmake --build "$build" --target prism-render mpi_reduce_bench mpi_balance_bench
reps="${REPS:-5}"
size=(--width "${WIDTH:-192}" --height "${HEIGHT:-192}" --spp "${SPP:-16}" --seed 1 -q)
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
mpirun_sh=(bash tests/mpi/mpirun.sh)
render="$build/examples/prism-render"
out=bench/results/mpi.txt
mkdir -p bench/results

# Prints "best median" of the numbers on stdin (highest is best unless $1 = low).
stats() { sort -g | awk -v low="${1:-}" '{ v[NR] = $1 } END {
  best = low ? v[1] : v[NR]; m = (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2; print best, m }'; }
now() { date +%s.%N; }

: >"$tmp/single" ; : >"$tmp/mpi"; : >"$tmp/single_wall"; : >"$tmp/mpi_wall"
for ((i = 1; i <= reps; ++i)); do
  t0=$(now)
  "$render" "${size[@]}" --threads 2 -o "$tmp/a.pfm" >"$tmp/log"
  t1=$(now)
  sed -n 's/.* \([0-9.]*\) M samples\/s.*/\1/p' "$tmp/log" >>"$tmp/single"
  awk -v a="$t0" -v b="$t1" 'BEGIN { print b - a }' >>"$tmp/single_wall"
  t0=$(now)
  "${mpirun_sh[@]}" 2 "$render" "${size[@]}" --threads 1 -o "$tmp/b.pfm" >"$tmp/log"
  t1=$(now)
  sed -n 's/.* \([0-9.]*\) M samples\/s.*/\1/p' "$tmp/log" | head -1 >>"$tmp/mpi"
  awk -v a="$t0" -v b="$t1" 'BEGIN { print b - a }' >>"$tmp/mpi_wall"
  echo "run $i: 1x2 $(tail -1 "$tmp/single") M samples/s, 2x1 $(tail -1 "$tmp/mpi") M samples/s"
done
read -r s_best s_med < <(stats <"$tmp/single")
read -r m_best m_med < <(stats <"$tmp/mpi")
read -r sw_best sw_med < <(stats low <"$tmp/single_wall")
read -r mw_best mw_med < <(stats low <"$tmp/mpi_wall")
{
  echo "# scripts/bench_mpi.sh, $(date -u +%F), $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg)"
  echo "throughput, default scene ${size[*]}, $reps runs each (M samples/s, best / median):"
  echo "  1 process x 2 threads: $s_best / $s_med"
  echo "  2 ranks x 1 thread:    $m_best / $m_med"
  echo "  ratio 2x1 / 1x2: best/best $(awk -v a="$m_best" -v b="$s_best" 'BEGIN { printf "%.3f", a / b }'), median/median $(awk -v a="$m_med" -v b="$s_med" 'BEGIN { printf "%.3f", a / b }')"
  echo "  whole command wall time (s, best / median): 1x2 $(printf %.2f "$sw_best") / $(printf %.2f "$sw_med"), 2x1 (with mpirun start) $(printf %.2f "$mw_best") / $(printf %.2f "$mw_med")"
  # tests/mpi/mpirun.sh turns off the single-copy (CMA) mechanism, which some
  # containers forbid; the reduction is also measured with it where it works.
  echo "reduction, shared memory without single copy (tests/mpi/mpirun.sh):"
  "${mpirun_sh[@]}" 2 "$build/bench/mpi_reduce_bench" | sed 's/^/  /'
  "${mpirun_sh[@]}" 2 "$build/bench/mpi_reduce_bench" --no-splats | sed 's/^/  /'
  echo "reduction, shared memory with CMA single copy:"
  PRISM_MPI_SINGLE_COPY=cma "${mpirun_sh[@]}" 2 "$build/bench/mpi_reduce_bench" 2>/dev/null |
    sed 's/^/  /' || echo "  (CMA is not available here)"
  echo "balance, glass heap in one corner:"
  "${mpirun_sh[@]}" 2 "$build/bench/mpi_balance_bench" 256 192 16 1 | grep -v ', run ' | sed 's/^/  /'
} | tee "$out"

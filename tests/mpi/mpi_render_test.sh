#!/usr/bin/env bash
# prism-render under mpirun against a single process (ctest label mpi).
# Usage: mpi_render_test.sh CASE prism-render mpirun.sh pfm_compare TMPDIR SHARED_DIR
# Cases:
#   samples   2 ranks (samples split) = 1 process, default scene, within 1e-5
#   tiles     2 ranks (tiles split) = 1 process, default scene, bitwise
#   gltf      2 ranks = 1 process on a shared glTF model (skipped when absent)
#   uneven    3 ranks, 5 spp (3 does not divide 5) = 1 process
#   repeat    two runs with 2 ranks are bitwise identical
#   aov       --aov under 2 ranks writes an EXR with the AOV layers
#   badscene  a missing scene: one error line, exit non-zero, no hang
#   throw     (mpi_fault, beside pfm_compare) rank 1 throws while rank 0 waits
#             for it: the job ends non-zero, naming rank 1
#   film      (mpi_fault) rank 1's film has another size: rank 0 aborts the job
# Exits 77 (skipped) when mpirun or the shared model is missing, or 1 (failed)
# instead when PRISM_REQUIRE_MPI=1 or PRISM_REQUIRE_SHARED=1 asks for it
# (scripts/test.sh sets them when mpirun and ../shared are there).
set -u
case_name="$1"; bin="$2"; mpirun_sh="$3"; compare="$4"; tmp="$5/$1"; shared="$6"
mkdir -p "$tmp"
# skip REQUIRE_VARIABLE WHAT
skip() {
  if [ "${!1:-}" = 1 ]; then echo "FAILED: $2 though $1=1"; exit 1; fi
  echo "SKIPPED: $2"; exit 77
}
command -v mpirun >/dev/null 2>&1 || skip PRISM_REQUIRE_MPI "mpirun not found (Debian: openmpi-bin)"
size=(--width 48 --height 40 --spp 8 --seed 7 -q)

single() { "$bin" "$@" --threads 2 >"$tmp/single.log" 2>&1 || { cat "$tmp/single.log"; echo "FAIL: single-process render"; exit 1; }; }
ranks() {
  local n="$1"; shift
  bash "$mpirun_sh" "$n" "$bin" "$@" --threads 1 >"$tmp/mpi.log" 2>&1
  local rc=$?
  cat "$tmp/mpi.log"
  [ "$rc" = 0 ] || { echo "FAIL: mpirun -np $n exited $rc"; exit 1; }
  grep -q "$n ranks x 1 threads" "$tmp/mpi.log" || { echo "FAIL: the summary does not say $n ranks"; exit 1; }
  for ((r = 0; r < n; ++r)); do
    grep -q "rank $r: 1 threads" "$tmp/mpi.log" || { echo "FAIL: no time for rank $r in the summary"; exit 1; }
  done
}
same() { "$compare" "$@" || { echo "FAIL: $1 and $2 differ"; exit 1; }; }

case "$case_name" in
  samples|tiles)
    single "${size[@]}" -o "$tmp/single.pfm"
    ranks 2 "${size[@]}" --split "$case_name" -o "$tmp/mpi.pfm"
    # Tiles: each pixel comes from one rank, so the image is the same bitwise.
    bitwise=(); [ "$case_name" = tiles ] && bitwise=(--bitwise)
    same "$tmp/single.pfm" "$tmp/mpi.pfm" "${bitwise[@]}" ;;
  gltf)
    model="$shared/scenes/Box/glTF-Binary/Box.glb"
    [ -f "$model" ] || skip PRISM_REQUIRE_SHARED "$model not found"
    single "$model" "${size[@]}" -o "$tmp/single.pfm"
    ranks 2 "$model" "${size[@]}" -o "$tmp/mpi.pfm"
    same "$tmp/single.pfm" "$tmp/mpi.pfm" ;;
  uneven)
    args=(--width 40 --height 32 --spp 5 --seed 3 -q)
    single "${args[@]}" -o "$tmp/single.pfm"
    ranks 3 "${args[@]}" -o "$tmp/mpi.pfm"
    # 5 samples over 3 ranks: 1, 2 and 2 per pixel.
    grep -q "rank 0: 1 threads, [0-9.]* s, 1280 samples" "$tmp/mpi.log" || { echo "FAIL: rank 0 should take 1280 samples"; exit 1; }
    same "$tmp/single.pfm" "$tmp/mpi.pfm" ;;
  repeat)
    ranks 2 "${size[@]}" -o "$tmp/a.pfm"
    ranks 2 "${size[@]}" -o "$tmp/b.pfm"
    same "$tmp/a.pfm" "$tmp/b.pfm" --bitwise ;;
  aov)
    ranks 2 "${size[@]}" --aov -o "$tmp/aov.exr" -o "$tmp/mpi.pfm"
    [ -s "$tmp/aov.exr" ] || { echo "FAIL: no EXR"; exit 1; }
    for layer in albedo.R N.X Z variance.R; do
      grep -a -q "$layer" "$tmp/aov.exr" || { echo "FAIL: the EXR has no $layer layer"; exit 1; }
    done
    single "${size[@]}" -o "$tmp/single.pfm"
    same "$tmp/single.pfm" "$tmp/mpi.pfm" ;;
  badscene)
    bash "$mpirun_sh" 2 "$bin" "$tmp/does_not_exist.glb" "${size[@]}" -o "$tmp/x.pfm" >"$tmp/out.log" 2>"$tmp/err.log"
    rc=$?
    cat "$tmp/out.log" "$tmp/err.log"
    [ "$rc" != 0 ] || { echo "FAIL: a missing scene exited 0"; exit 1; }
    n=$(grep -c "prism-render: .*does_not_exist.glb" "$tmp/err.log")
    [ "$n" = 1 ] || { echo "FAIL: the error was printed $n times, expected once"; exit 1; }
    [ ! -e "$tmp/x.pfm" ] || { echo "FAIL: an output was written"; exit 1; } ;;
  throw|film)
    fault="$(dirname "$compare")/mpi_fault"
    bash "$mpirun_sh" 2 "$fault" "$case_name" >"$tmp/out.log" 2>"$tmp/err.log"
    rc=$?
    cat "$tmp/out.log" "$tmp/err.log"
    [ "$rc" != 0 ] || { echo "FAIL: the job exited 0"; exit 1; }
    if [ "$case_name" = throw ]; then expected="mpi_fault: rank 1: injected failure"
    else expected="mpi_fault: rank 0: mpi: rank 1's film is 8x8, the root's 16x16"; fi
    grep -q "$expected" "$tmp/err.log" || { echo "FAIL: no '$expected'"; exit 1; } ;;
  *) echo "unknown case $case_name"; exit 2 ;;
esac
echo "ok: $case_name"

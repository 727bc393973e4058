#!/usr/bin/env bash
# scripts/ab_traversal.sh — prism's ray queries, one version against another,
# in one process (bench/ab_traversal.cpp says how and why).
#
# Usage: scripts/ab_traversal.sh A [B] [--res N] [--reps N] [--build]
#   A, B: git revisions (anything `git archive` takes), "worktree" for the
#   include/ of the working tree, or a directory holding an include/ (a copy
#   with an experiment); B defaults to worktree. The same revision
#   twice (an A/A run) measures the harness's own spread.
# Example: scripts/ab_traversal.sh HEAD            (the uncommitted change)
#          scripts/ab_traversal.sh HEAD~3 HEAD --reps 40
# Needs a C++20 compiler (CXX, default c++); compiled with -O3 -march=$ARCH
# (ARCH defaults to native; x86-64-v2 is SSE4.2, x86-64-v3 AVX2 and FMA).
# CXX_A and CXX_B, if set, compile the two sides (one revision under two
# compilers: scripts/ab_traversal.sh HEAD HEAD with CXX_B=clang++).
# FLAGS_A and FLAGS_B, if set, are extra flags for one side (4-wide against
# 8-wide nodes: scripts/ab_traversal.sh HEAD HEAD with
# FLAGS_B=-DPRISM_BVH_WIDTH=4).
# --build also times the mesh's MeshAccel build on 1 and 2 threads, A and B
# alternated (the trees may differ: that is reported, not a failure).
# Exit status 1 when the two versions' hits differ.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ $# -lt 1 ] || [[ "$1" == -* ]]; then
  sed -n 2,19p "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
fi
a=$1
shift
b=worktree
if [ $# -gt 0 ] && [[ "$1" != -* ]]; then
  b=$1
  shift
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
export_include() {  # revision, directory
  mkdir -p "$2"
  if [ "$1" = worktree ]; then
    cp -r include "$2/"
  elif [ -d "$1/include" ]; then
    cp -r "$1/include" "$2/"
  else
    git archive "$1" include | tar -x -C "$2"
  fi
}
export_include "$a" "$tmp/a"
export_include "$b" "$tmp/b"
cxx=${CXX:-c++}
flags=(-std=gnu++20 -O3 -DNDEBUG "-march=${ARCH:-native}" -Ibench)
echo "ab_traversal: A = $a (${CXX_A:-$cxx} ${FLAGS_A:-}), B = $b (${CXX_B:-$cxx} ${FLAGS_B:-}), -march=${ARCH:-native}; compiling..."
"${CXX_A:-$cxx}" "${flags[@]}" ${FLAGS_A:-} -Dprism=prism_ab_a -DAB_SIDE=a -I"$tmp/a/include" -c bench/ab_traversal.cpp -o "$tmp/a.o" &
pa=$!
"${CXX_B:-$cxx}" "${flags[@]}" ${FLAGS_B:-} -Dprism=prism_ab_b -DAB_SIDE=b -I"$tmp/b/include" -c bench/ab_traversal.cpp -o "$tmp/b.o" &
pb=$!
"$cxx" "${flags[@]}" -DAB_MAIN -c bench/ab_traversal.cpp -o "$tmp/main.o"
wait $pa
wait $pb
"$cxx" "$tmp/main.o" "$tmp/a.o" "$tmp/b.o" -o "$tmp/ab_traversal" -pthread
"$tmp/ab_traversal" "$@"

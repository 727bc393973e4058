#!/usr/bin/env bash
# Builds prism's test executables with AddressSanitizer + UndefinedBehaviorSanitizer
# (g++) in build/asan and runs their tests with ctest: each NAME is the
# executable prism_test_NAME (default: gltf_input, whose bad-input corpus is
# what this is for). Any sanitizer report fails its test (-fno-sanitize-recover=all,
# halt_on_error). scripts/test.sh runs it under CI on the loader's bad input
# and the image readers:
#   scripts/sanitize.sh gltf_input io
#   scripts/sanitize.sh gltf accel accel_native   # by hand: about 15 minutes
#   SANITIZE_EXCLUDE='^models$' scripts/sanitize.sh gltf   # leave tags out
#   ASAN_BUILD=build/my-asan JOBS=1 SANITIZE_OPT=-O0 scripts/sanitize.sh io
# libtinygltf.so and libstb.so come from Debian uninstrumented: ASan still
# catches their heap errors at the allocator, but not every read. The fuzz
# target (scripts/fuzz.sh) compiles both in, instrumented.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bash scripts/setup.sh
names=("$@")
if ((${#names[@]} == 0)); then names=(gltf_input); fi
build="${ASAN_BUILD:-build/asan}"
jobs="${JOBS:-$(nproc)}"
san="-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all"
# -O1 -g1 (line tables for the reports) and file by file: quicker to build on
# two cores than the unity build at -O2 -g, for tests that run a little slower.
# SANITIZE_OPT=-O0 builds in half that time again, for tests that run only
# seconds (scripts/test.sh: the bad-input tests and the image readers').
opt="${SANITIZE_OPT:--O1}"
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="$opt -g1 -DNDEBUG" \
  -DCMAKE_CXX_FLAGS="$san" -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" -DPRISM_TEST_UNITY=OFF \
  -DPRISM_BUILD_BENCH=OFF -DPRISM_BUILD_EXAMPLES=OFF -DPRISM_BUILD_TOOLS=OFF >/dev/null
targets=("${names[@]/#/prism_test_}")
cmake --build "$build" --target "${targets[@]}" -j "$jobs"
cd "$build"
export ASAN_OPTIONS="${ASAN_OPTIONS:-halt_on_error=1:abort_on_error=1:detect_stack_use_after_return=1:strict_string_checks=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
# Each test carries its executable's name as a label.
# SANITIZE_EXCLUDE: a regex of labels (Catch tags) whose tests to leave out.
exclude=()
if [ -n "${SANITIZE_EXCLUDE:-}" ]; then exclude=(-LE "$SANITIZE_EXCLUDE"); fi
# --no-tests=error: a label that names no test fails rather than passing empty.
ctest -L "^($(IFS='|'; echo "${targets[*]}"))\$" "${exclude[@]}" --no-tests=error --output-on-failure -j "$jobs"

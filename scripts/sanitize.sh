#!/usr/bin/env bash
# Builds prism's tests with AddressSanitizer + UndefinedBehaviorSanitizer (g++)
# in build/asan and runs those labelled LABEL with ctest (default: gltf, i.e.
# prism_test_gltf, whose bad-input corpus is what this is for). Any sanitizer
# report fails the test. Not part of scripts/test.sh: it is too slow for CI.
#   scripts/sanitize.sh            # ctest -L gltf
#   scripts/sanitize.sh io         # ctest -L io (builds prism_test_io)
#   ASAN_BUILD=build/my-asan JOBS=1 scripts/sanitize.sh
# libtinygltf.so and libstb.so come from Debian uninstrumented: ASan still
# catches their heap errors at the allocator, but not every read. The fuzz
# target (scripts/fuzz.sh) compiles both in, instrumented.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
label="${1:-gltf}"
build="${ASAN_BUILD:-build/asan}"
san="-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined"
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS="$san" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" -DPRISM_BUILD_BENCH=OFF \
  -DPRISM_BUILD_EXAMPLES=OFF -DPRISM_BUILD_TOOLS=OFF >/dev/null
# Build only the label's test executable when there is one.
targets="$(ninja -C "$build" -t targets all 2>/dev/null || true)"
if grep -Eq "(^|/)prism_test_$label: " <<<"$targets"; then
  cmake --build "$build" --target "prism_test_$label" -j "${JOBS:-$(nproc)}"
else
  cmake --build "$build" -j "${JOBS:-$(nproc)}"
fi
cd "$build"
export ASAN_OPTIONS="${ASAN_OPTIONS:-abort_on_error=1:detect_stack_use_after_return=1:strict_string_checks=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
ctest -L "$label" --output-on-failure -j "${JOBS:-$(nproc)}"

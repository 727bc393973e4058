#!/usr/bin/env bash
# Installs what is missing, builds prism and its tests, and runs the whole suite
# with ctest (arguments go to ctest). Under CI (CI=true) it then runs the glTF
# loader's bad-input tests and the image readers' again under ASan + UBSan
# (scripts/sanitize.sh) and fuzzes the glTF loader for FUZZ_RUNS inputs
# (default 10000, seed 1, at most FUZZ_SECONDS; scripts/fuzz.sh). Every step
# runs even when one before it failed; the script exits non-zero if any did,
# and its last line is 'total: N passed, N failed' over all of them.
#
# A run cannot pass by skipping: with ../shared beside the project it exports
# PRISM_REQUIRE_SHARED=1, and with mpirun installed PRISM_REQUIRE_MPI=1, which
# turn the tests' skips for lack of them into failures naming what is missing
# (tests/support/skip.hpp, tests/mpi/); with both set, a test that ctest
# still reports skipped fails the run too, however it skipped.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bash scripts/setup.sh
ci=0
if [ "${CI:-}" = true ]; then ci=1; fi

cmake_args=()
if [ -d "$root/../shared" ]; then export PRISM_REQUIRE_SHARED=1; fi
if command -v mpirun >/dev/null 2>&1; then
  export PRISM_REQUIRE_MPI=1
  cmake_args+=(-DPRISM_WITH_MPI=ON)  # configuring fails without libopenmpi-dev
fi
echo "test.sh: PRISM_REQUIRE_SHARED=${PRISM_REQUIRE_SHARED:-0} PRISM_REQUIRE_MPI=${PRISM_REQUIRE_MPI:-0}"

passed=0 failed=0 skipped=0 times=()
# step NAME COMMAND...: runs the command and adds up what it ran, from ctest's
# summary line when it prints one, else as one test passed or failed.
step() {
  local name="$1" log="$root/build/$1.log" start=$SECONDS rc=0
  shift
  mkdir -p "$root/build"
  "$@" 2>&1 | tee "$log" || rc=$?
  times+=("$name $((SECONDS - start)) s;")
  local summary total=0 bad=0 skip
  summary="$(grep -E '^[0-9]+% tests passed, [0-9]+ tests? failed out of [0-9]+' "$log" | tail -1 || true)"
  if [ -n "$summary" ]; then
    bad="$(sed -E 's/.* ([0-9]+) tests? failed out of.*/\1/' <<<"$summary")"
    total="$(sed -E 's/.*out of ([0-9]+).*/\1/' <<<"$summary")"
    skip="$(grep -cE '^[[:space:]]*[0-9]+ - .* \(Skipped\)$' "$log" || true)"
    passed=$((passed + total - bad - skip))
    if [ "$skip" -gt 0 ] && [ "${PRISM_REQUIRE_SHARED:-}" = 1 ] && [ "${PRISM_REQUIRE_MPI:-}" = 1 ]; then
      echo "test.sh: $name: $skip tests skipped though ../shared and mpirun are both here (fails the run):"
      grep -E '^[[:space:]]*[0-9]+ - .* \(Skipped\)$' "$log"
      bad=$((bad + skip))
      rc=1
    else
      skipped=$((skipped + skip))
    fi
    failed=$((failed + bad))
    # ctest failing with every test passed (a build error after the summary,
    # say) still fails the step.
    if [ "$rc" != 0 ] && [ "$bad" = 0 ]; then failed=$((failed + 1)); fi
  elif [ "$rc" = 0 ]; then
    passed=$((passed + 1))
  else
    failed=$((failed + 1))
  fi
  if [ "$rc" != 0 ]; then echo "test.sh: $name FAILED"; fi
}

suite() {
  local werror=OFF gltf_input=ON
  # Under CI the glTF loader's bad-input tests run once, under ASan + UBSan
  # (the sanitize step below), not a second time uninstrumented.
  if [ $ci = 1 ]; then werror=ON gltf_input=OFF; fi
  # Release at -O2 rather than CMake's -O3: the suite's build is most of its
  # time on 2 cores, and its heaviest files (each instantiating the renderer)
  # compile about 30% faster at -O2 (rough_cornell_test.cpp: 26 s against 37 s).
  cmake -S . -B build/test -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS_RELEASE="-O2 -DNDEBUG" \
    -DPRISM_WERROR=$werror -DPRISM_BUILD_BENCH=OFF -DPRISM_TEST_GLTF_INPUT=$gltf_input "${cmake_args[@]}" >/dev/null ||
    return 1
  # setup.sh installed every optional part's packages: one that CMake still
  # does not find would drop its tests unseen.
  local t targets
  targets="$(ninja -C build/test -t targets all)" || return 1
  local needed=(prism_test_io prism_test_gltf)
  if [ $gltf_input = ON ]; then needed+=(prism_test_gltf_input); fi
  for t in "${needed[@]}"; do
    grep -q "^$t: " <<<"$targets" || { echo "test.sh: $t is not configured (prism::io or prism::gltf not found)"; return 1; }
  done
  # libwebp, libdraco and libmeshoptimizer (setup.sh installs them) must have
  # been found.
  grep -q -- "-DPRISM_HAS_WEBP=1" build/test/build.ninja ||
    { echo "test.sh: prism::gltf was configured without libwebp (EXT_texture_webp)"; return 1; }
  grep -q -- "-DPRISM_HAS_DRACO=1" build/test/build.ninja ||
    { echo "test.sh: prism::gltf was configured without draco (KHR_draco_mesh_compression)"; return 1; }
  grep -q -- "-DPRISM_HAS_MESHOPT=1" build/test/build.ninja ||
    { echo "test.sh: prism::gltf was configured without meshoptimizer (EXT_meshopt_compression)"; return 1; }
  # (Called from step's '||', where set -e does not stop a function.)
  cmake --build build/test || return 1
  cd build/test
  ctest --output-on-failure -j "$(nproc)" "$@"
}

step suite suite "$@"
if [ $ci = 1 ]; then
  # The glTF loader's bad-input tests and the image readers' (scripts/
  # sanitize.sh). Left to run by hand for time: the renders of the shared
  # models (`scripts/sanitize.sh gltf`, which read no input the bad-input
  # tests do not) and the ray queries (`scripts/sanitize.sh accel
  # accel_native`, about 15 minutes under ASan at -O1).
  # At -O0: half the build time of -O1, for tests that run seconds.
  step sanitize env SANITIZE_OPT=-O0 bash scripts/sanitize.sh gltf_input io
  # A fixed seed and number of inputs, so that a run is repeatable (a failure
  # is a bug in the change, not a new roll of the dice; long fuzzing is for
  # scripts/fuzz.sh by hand). Stopping at the first crash, leak or timeout,
  # which fails the step; FUZZ_SECONDS caps a slow machine.
  step fuzz env FUZZ_STOP=1 bash scripts/fuzz.sh "${FUZZ_SECONDS:-120}" -print_funcs=0 -seed=1 \
    -runs="${FUZZ_RUNS:-10000}"
fi
echo "test.sh: wall time: ${times[*]}"
echo "total: $passed passed, $failed failed$( ((skipped)) && echo ", $skipped skipped")"
[ "$failed" = 0 ]

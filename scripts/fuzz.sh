#!/usr/bin/env bash
# Fuzzes prism's glTF loader with libFuzzer for DURATION_SECONDS (default 60):
# builds fuzz/gltf_fuzz.cpp with clang++ -fsanitize=fuzzer,address,undefined
# (tinygltf and stb_image compiled in, instrumented), seeds the corpus from the
# small shared models and runs one job on one core. Crash, leak and timeout
# inputs land in build/fuzz/artifacts/; the corpus grows in build/fuzz/corpus/.
#   scripts/fuzz.sh 900            # 15 minutes
#   FUZZ_BUILD=build/my-fuzz scripts/fuzz.sh 60 -seed=1   # extra args go to libFuzzer
# Needs clang and libFuzzer (Debian: clang, libclang-rt-dev), which it installs
# when missing (scripts/setup.sh). scripts/test.sh runs it under CI for 120 s
# with FUZZ_STOP=1, so that anything found fails the run.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$root/scripts/setup.sh" clang libclang-rt-dev
duration="${1:-60}"
shift || true
out="$(cd "$root" && mkdir -p "${FUZZ_BUILD:-build/fuzz}" && cd "${FUZZ_BUILD:-build/fuzz}" && pwd)"
shared="$root/../shared/scenes"
cxx="${CXX_FUZZ:-clang++}"
if ! command -v "$cxx" >/dev/null; then
  echo "fuzz.sh: $cxx not found (apt-get install clang libclang-rt-dev)" >&2
  exit 1
fi

flags=(-std=c++20 -g -O1 -fno-omit-frame-pointer -fsanitize=fuzzer,address,undefined
       -fno-sanitize-recover=undefined -I"$root/include" -I/usr/include/stb)
# WebP (EXT_texture_webp) through libwebp, as prism::gltf has it when found
# (link_libs: the libraries of the optional decoders found).
link_libs=()
if pkg-config --exists libwebp 2>/dev/null; then
  flags+=(-DPRISM_HAS_WEBP=1 $(pkg-config --cflags libwebp))
  read -r -a link_libs <<<"$(pkg-config --libs libwebp)"
fi
# meshoptimizer (EXT_meshopt_compression), as prism::gltf has it when found.
if [ -f /usr/include/meshoptimizer.h ]; then
  flags+=(-DPRISM_HAS_MESHOPT=1)
  link_libs+=(-lmeshoptimizer)
fi
bin="$out/gltf_fuzz"
srcs=("$root/fuzz/gltf_fuzz.cpp" "$root/fuzz/tinygltf_impl.cpp" "$root/include/prism/io/gltf.hpp"
      "$root"/include/prism/io/gltf/*.hpp "$root/include/prism/io/image_io.hpp")
need=0
[ -x "$bin" ] || need=1
for s in "${srcs[@]}"; do [ "$s" -nt "$bin" ] && need=1; done
if [ $need = 1 ]; then
  echo "fuzz.sh: building $bin"
  # The tinygltf/stb object rarely changes: build it once, in parallel with
  # the target's own.
  impl=0
  if [ ! -f "$out/tinygltf_impl.o" ] || [ "$root/fuzz/tinygltf_impl.cpp" -nt "$out/tinygltf_impl.o" ]; then
    "$cxx" "${flags[@]}" -w -c "$root/fuzz/tinygltf_impl.cpp" -o "$out/tinygltf_impl.o" &
    impl=$!
  fi
  "$cxx" "${flags[@]}" -c "$root/fuzz/gltf_fuzz.cpp" -o "$out/gltf_fuzz.o"
  if [ $impl != 0 ]; then wait $impl; fi
  "$cxx" "${flags[@]}" "$out/gltf_fuzz.o" "$out/tinygltf_impl.o" -o "$bin" -pthread "${link_libs[@]}"
fi

# Seeds: the small single-file models (GLB and data-URI glTF), once.
corpus="$out/corpus"
mkdir -p "$corpus" "$out/artifacts"
if [ -d "$shared" ] && [ -z "$(ls -A "$corpus")" ]; then
  for f in Box/glTF-Binary/Box.glb Box/glTF-Embedded/Box.gltf BoxTextured/glTF-Binary/BoxTextured.glb \
           Cameras/glTF-Embedded/Cameras.gltf SimpleInstancing/glTF-Binary/SimpleInstancing.glb \
           TextureCoordinateTest/glTF-Binary/TextureCoordinateTest.glb \
           EmissiveStrengthTest/glTF-Binary/EmissiveStrengthTest.glb \
           OrientationTest/glTF-Binary/OrientationTest.glb AnimatedCube/glTF/AnimatedCube.gltf \
           TextureTransformTest/glTF/TextureTransformTest.gltf AnimatedMorphCube/glTF-Binary/AnimatedMorphCube.glb; do
    [ -f "$shared/$f" ] && cp "$shared/$f" "$corpus/$(echo "$f" | tr / _)"
  done
  # A meshopt-compressed file (every filter): tests/gltf/data.
  cp "$root/tests/gltf/data/CesiumMan.meshopt.glb" "$corpus/"
  # A skin and animated morph targets, small: tests/gltf/data.
  cp "$root/tests/gltf/data/skin_two_bone.gltf" "$root/tests/gltf/data/morph_triangle.gltf" "$corpus/"
fi

cd "$out"
# One core: -fork=1 runs one child at a time and, with the -ignore_* flags,
# keeps fuzzing after a crash, timeout or OOM (each saved to artifacts/), so a
# long run reports every bug it meets. FUZZ_STOP=1: stop at the first one.
mode=(-fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1)
[ "${FUZZ_STOP:-0}" = 1 ] && mode=()
"$bin" "$corpus" "${mode[@]}" -max_total_time="$duration" -rss_limit_mb=2048 -timeout=10 -max_len=262144 \
  -artifact_prefix="$out/artifacts/" -print_final_stats=1 "$@"
echo "fuzz.sh: artifacts (crash-*, timeout-*, oom-*, leak-*) in $out/artifacts:"
ls "$out/artifacts"

#!/usr/bin/env bash
# Cross-checks prism's glTF loader against the Khronos glTF-Validator (npm
# package gltf-validator, installed on demand into tools/validator/node_modules,
# which git ignores). Not part of CI: it needs npm and the network once.
#   scripts/validate_gltf.sh [BUILD_DIR]
# 1. validates every .gltf/.glb under ../shared/scenes (expects no errors);
# 2. runs the bad-input tests of BUILD_DIR (default build/h) so that they leave
#    their corrupted corpus and prism's verdicts in
#    BUILD_DIR/tests/tmp/gltf_bad/, then reports how many of those files the
#    validator flags as invalid (errors > 0) against how many prism rejects.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$root/build/h}"
tool="$root/tools/validator"
if [[ ! -d "$tool/node_modules/gltf-validator" ]]; then
  (cd "$tool" && npm install --no-audit --no-fund --silent)
fi
shared="$root/../shared/scenes"
status=0
if [[ -d "$shared" ]]; then
  node "$tool/validate.js" --models "$shared" || status=1
else
  echo "validate_gltf: $shared is absent, skipping the shared models"
fi
corpus="$build/tests/tmp/gltf_bad"
rm -f "$corpus/prism_verdicts.tsv"
if [[ -x "$build/tests/prism_test_gltf_input" ]]; then
  "$build/tests/prism_test_gltf_input" "[bad_input]" > /dev/null
  node "$tool/validate.js" --corpus "$corpus" "$corpus/prism_verdicts.tsv"
else
  echo "validate_gltf: $build/tests/prism_test_gltf_input is missing (cmake --build $build --target prism_test_gltf_input)"
  status=1
fi
exit $status

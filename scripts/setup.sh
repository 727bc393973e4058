#!/usr/bin/env bash
# Installs the Debian packages prism needs, only those that are missing, then
# configures a build tree. Sourced by demo.sh, test.sh and bench.sh.
# Usage: scripts/setup.sh [extra packages...]
set -euo pipefail

PRISM_PACKAGES=(g++ cmake ninja-build pkg-config python3 catch2 libstb-dev libtinyexr-dev
  libtinygltf-dev nlohmann-json3-dev libwebp-dev libdraco-dev libmeshoptimizer-dev libcli11-dev libopenmpi-dev openmpi-bin "$@")

missing=()
for p in "${PRISM_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "prism: installing ${missing[*]}"
  SUDO=""
  if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

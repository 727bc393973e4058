#!/usr/bin/env bash
# Runs a program on N local ranks with Open MPI, with the options a container
# needs (no binding, shared-memory transport without the kernel's single-copy
# mechanism, no remote launcher) and as root when the tests run as root.
# Usage: mpirun.sh N program [args...]. Exits 77 (ctest: skipped) when mpirun
# is missing. PRISM_MPI_SINGLE_COPY=cma turns the kernel's single copy back on
# where the container allows it (faster for large films).
set -u
if ! command -v mpirun >/dev/null 2>&1; then
  echo "SKIPPED: mpirun not found (Debian: openmpi-bin)"
  exit 77
fi
np="$1"; shift
root_args=()
if [ "$(id -u)" = 0 ]; then root_args=(--allow-run-as-root); fi
exec mpirun "${root_args[@]}" --oversubscribe --bind-to none --mca btl self,vader \
  --mca btl_vader_single_copy_mechanism "${PRISM_MPI_SINGLE_COPY:-none}" --mca plm isolated -np "$np" "$@"

#!/usr/bin/env bash
# Quick start, second command: the whole test suite, against LAMMPS 4 Feb 2025 (build/) and
# LAMMPS 29 Sep 2021 (build-2021/).  Installs and builds whatever is missing first.
# Exits non-zero if any test fails; tests that need a GPU are reported as skipped without one.
set -uo pipefail
source "$(dirname "$0")/common.sh"
cd "$HSGPU_ROOT"

install_packages || exit 1
mpi_env
status=0
summary=()
for which in 2021 2025; do
  dir=build
  options=()
  # The CUDA kernels and their tests include nothing of LAMMPS, and the styles compile the same
  # with and without them: build them once, against LAMMPS 2025.
  if [ "$which" = 2021 ]; then
    dir=build-2021
    options=(-D HSGPU_ENABLE_CUDA=OFF)
  fi
  if ! build_plugin "$which" "$dir" "${options[@]}"; then
    summary+=("LAMMPS $which: BUILD FAILED")
    status=1
    continue
  fi
  say "ctest against LAMMPS $which"
  (cd "$dir" && ctest -j "$(nproc)" --output-on-failure --timeout 600) | tee "$dir/ctest.log"
  rc=${PIPESTATUS[0]}
  line=$(grep -E "tests passed|tests failed" "$dir/ctest.log" | tail -n1)
  summary+=("LAMMPS $which: ${line:-no ctest summary}")
  [ "$rc" -eq 0 ] || status=1
done
say "summary"
printf '%s\n' "${summary[@]}"
exit $status

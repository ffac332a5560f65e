#!/usr/bin/env bash
# Quick start, first command: installs what is missing (Debian packages, a LAMMPS 4 Feb 2025
# built from Debian's source package into ~/.cache/hardsphere_gpu), builds the plugin in
# build/, and runs the default example, which prints LAMMPS's thermo output and draws the
# final state to build/quickstart/collapse.png.
set -euo pipefail
source "$(dirname "$0")/common.sh"
cd "$HSGPU_ROOT"

install_packages
build_plugin 2025 build
mpi_env
lmp=$(lammps_binary build)
run="$HSGPU_ROOT/build/quickstart"
rm -rf "$run"
mkdir -p "$run"
cp examples/gravity/in.collapse "$run/"
say "running examples/gravity/in.collapse with $lmp on 2 MPI ranks"
(cd "$run" && mpirun -np 2 "$lmp" -in in.collapse -var plugin "$HSGPU_ROOT/build/hardspheregpuplugin.so")
test -s "$run/collapse.png"
say "LAMMPS: $lmp"
say "plugin: $HSGPU_ROOT/build/hardspheregpuplugin.so"
say "picture of the final state: $run/collapse.png"

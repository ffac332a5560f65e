#!/usr/bin/env bash
# Quick start, first command: installs what is missing (Debian packages, a LAMMPS 4 Feb 2025
# built from Debian's source package into ~/.cache/hardsphere_gpu), builds the plugin in
# build/, and runs the default example: 2000 hard spheres poured onto a floor under gravity
# (fix hardsphere), which prints LAMMPS's thermo output and draws the settled pile to
# build/quickstart/pour.png.
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
cp examples/hardsphere/in.pour "$run/"
say "running examples/hardsphere/in.pour with $lmp on 2 MPI ranks"
(cd "$run" && mpirun -np 2 "$lmp" -in in.pour -var plugin "$HSGPU_ROOT/build/hardspheregpuplugin.so")
test -s "$run/pour.png"
say "LAMMPS: $lmp"
say "plugin: $HSGPU_ROOT/build/hardspheregpuplugin.so"
say "picture of the final state: $run/pour.png"

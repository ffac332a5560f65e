# Shared by tools/setup.sh and tools/test.sh: system packages and plugin builds.
# shellcheck shell=bash

HSGPU_ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
HSGPU_PACKAGES=(build-essential cmake ninja-build xz-utils ca-certificates dpkg-dev
  libopenmpi-dev openmpi-bin libgtest-dev libgmock-dev googletest
  libpng-dev libjpeg-dev zlib1g-dev)

say() { echo "== $*"; }

as_root() {
  if [ "$(id -u)" = 0 ]; then "$@"
  elif command -v sudo >/dev/null; then sudo "$@"
  else echo "need root for: $*" >&2; return 1; fi
}

# Installs the Debian packages that are missing (nothing when all are present).
install_packages() {
  local missing=()
  for p in "${HSGPU_PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed" || missing+=("$p")
  done
  if [ ${#missing[@]} -gt 0 ]; then
    say "installing ${missing[*]}"
    as_root apt-get update -q
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${missing[@]}"
  else
    say "system packages present"
  fi
}

# OpenMPI refuses to start as root, and more ranks than cores, unless told.
mpi_env() {
  export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
  export OMPI_MCA_rmaps_base_oversubscribe=1 OMPI_MCA_mpi_yield_when_idle=1
}

# build_plugin <2025|2021> <build-dir> [cmake options...]: obtains LAMMPS (cached) and builds
# the plugin and tests.
build_plugin() {
  local which=$1 dir=$2
  shift 2
  say "building the plugin against LAMMPS $which in $dir"
  cmake -S "$HSGPU_ROOT" -B "$dir" -G Ninja -D HSGPU_LAMMPS="$which" -D HSGPU_WARNINGS_AS_ERRORS=ON "$@"
  cmake --build "$dir" -j "$(nproc)"
}

lammps_binary() {
  sed -n 's/^LAMMPS_BINARY:FILEPATH=//p' "$1/CMakeCache.txt"
}

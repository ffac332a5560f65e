#!/usr/bin/env bash
# Obtain a LAMMPS source release from Debian's source packages, build it with the
# packages HARDSPHERE_GPU needs (PLUGIN, GRANULAR, MPI, OpenMP, PNG/JPEG images),
# and install it into a cache directory outside the source tree.  A finished
# build is recognised by its stamp file and reused.
#
#   tools/get_lammps.sh <2025|2021> [cache-dir]
#
# Prints the install prefix on the last line of standard output.
set -euo pipefail

which_lammps=${1:?usage: get_lammps.sh <2025|2021> [cache-dir]}
cache=${2:-${HSGPU_LAMMPS_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/hardsphere_gpu}}

case "$which_lammps" in
  2025) suite=trixie;   debver=20250204+dfsg.1-2 ;;
  2021) suite=bookworm; debver=20220106.git7586adbb6a+ds1-2 ;;
  *) echo "get_lammps.sh: unknown LAMMPS '$which_lammps' (use 2025 or 2021)" >&2; exit 2 ;;
esac

# Bump when the configuration below changes, so stale caches are rebuilt.
recipe=3
top="$cache/lammps-$which_lammps"
prefix="$top/install"
stamp="$top/.complete-$debver-r$recipe"
log() { echo "[get_lammps] $*" >&2; }

if [ -f "$stamp" ] && [ -x "$prefix/bin/lmp" ]; then
  log "reusing LAMMPS $which_lammps in $prefix"
  echo "$prefix"
  exit 0
fi

as_root() { if [ "$(id -u)" = 0 ]; then "$@"; elif command -v sudo >/dev/null; then sudo "$@"; else
  log "need root to run: $*"; exit 1; fi; }

# A deb-src entry for the suite holding the wanted release.
srclist=/etc/apt/sources.list.d/hardsphere-gpu-src.sources
if ! grep -qs "$suite" "$srclist"; then
  log "adding deb-src entries to $srclist"
  as_root tee "$srclist" >/dev/null <<SRC
Types: deb-src
URIs: http://deb.debian.org/debian
Suites: bookworm trixie
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
SRC
  as_root apt-get update -q >&2
fi

mkdir -p "$top/download"
cd "$top/download"
tarball=$(ls lammps_*.orig.tar.* 2>/dev/null | head -n1 || true)
if [ -z "$tarball" ]; then
  log "downloading the source of lammps=$debver"
  apt-get source --tar-only "lammps=$debver" >&2 || {
    as_root apt-get update -q >&2; apt-get source --tar-only "lammps=$debver" >&2; }
  tarball=$(ls lammps_*.orig.tar.* | head -n1)
fi

rm -rf "$top/source" "$top/build" "$prefix"
mkdir -p "$top/source"
log "unpacking $tarball"
tar xf "$tarball" -C "$top/source" --strip-components=1

gen=()
command -v ninja >/dev/null && gen=(-G Ninja)
jobs=${HSGPU_JOBS:-$(nproc)}
log "configuring LAMMPS $which_lammps"
cmake -S "$top/source/cmake" -B "$top/build" "${gen[@]}" \
  -D CMAKE_BUILD_TYPE=Release \
  -D CMAKE_INSTALL_PREFIX="$prefix" -D CMAKE_INSTALL_LIBDIR=lib \
  -D CMAKE_INSTALL_RPATH="$prefix/lib" \
  -D BUILD_SHARED_LIBS=on -D BUILD_MPI=on -D BUILD_OMP=on \
  -D LAMMPS_EXCEPTIONS=on -D BUILD_TOOLS=off -D BUILD_LAMMPS_SHELL=off \
  -D PKG_PLUGIN=on -D PKG_GRANULAR=on -D PKG_EXTRA-FIX=off \
  -D WITH_PNG=on -D WITH_JPEG=on -D WITH_GZIP=on -D WITH_FFMPEG=off \
  -D ENABLE_TESTING=off >"$top/configure.log" 2>&1 || { tail -40 "$top/configure.log" >&2; exit 1; }
log "building LAMMPS $which_lammps with $jobs jobs (log: $top/build.log)"
cmake --build "$top/build" -j "$jobs" >"$top/build.log" 2>&1 || { tail -40 "$top/build.log" >&2; exit 1; }
cmake --install "$top/build" >"$top/install.log" 2>&1 || { tail -20 "$top/install.log" >&2; exit 1; }
# The plugin compiles against LAMMPS's internal headers: keep the configured
# source tree next to the install and record where it is.
echo "$top/source/src" >"$prefix/LAMMPS_SOURCE_DIR"
rm -f "$top"/.complete-*
touch "$stamp"
log "LAMMPS $which_lammps installed in $prefix"
echo "$prefix"

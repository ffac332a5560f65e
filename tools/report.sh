#!/usr/bin/env bash
# Speed against error, one command (issue 11): runs the cases, writes Markdown pages with
# tables and PNG plots into doc/report/.
#
#   bash tools/report.sh [--quick] [--only SECTION[,SECTION...]] [--out DIR] [build-dir]
#
# --quick   small sizes and short runs: a few minutes on 2 cores (the pages say "quick mode")
# --only    run only these sections (seed, granular, gravity, pick); the index lists all pages
# --out     where the pages go (default doc/report)
# build-dir the plugin's build directory (default build/; built against LAMMPS 4 Feb 2025, with
#           the packages it needs, when it holds no plugin yet)
# Installs the Debian packages it needs (those of tools/setup.sh and python3-matplotlib).
# Rows that need a GPU are measured when a CUDA device is present and the plugin was built
# with CUDA, and marked "not measured" otherwise.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
cmd="bash tools/report.sh $*"
mode=full
only=
out=$HSGPU_ROOT/doc/report
build=
while [ $# -gt 0 ]; do
  case $1 in
    --quick) mode=quick ;;
    --only) only=${2:?--only needs a list of sections}; shift ;;
    --out) out=${2:?--out needs a directory}; shift ;;
    -h|--help) sed -n '2,14p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "tools/report.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
    *) build=$1 ;;
  esac
  shift
done
sections=(seed granular gravity pick)
if [ -n "$only" ]; then
  IFS=, read -r -a chosen <<< "$only"
  for s in "${chosen[@]}"; do
    [[ " ${sections[*]} " == *" $s "* ]] || { echo "tools/report.sh: no section '$s' (seed, granular, gravity, pick)" >&2; exit 2; }
  done
  sections=("${chosen[@]}")
fi

HSGPU_PACKAGES+=(python3-matplotlib python3-numpy)
install_packages
build=${build:-$HSGPU_ROOT/build}
if [ ! -f "$build/hardspheregpuplugin.so" ]; then
  build_plugin 2025 "$build"
fi
build=$(cd "$build" && pwd)
lmp=$(lammps_binary "$build")
[ -x "$lmp" ] || { echo "tools/report.sh: no LAMMPS executable recorded in $build/CMakeCache.txt" >&2; exit 1; }
mkdir -p "$out"
export HSGPU_REPORT_DIR=$(cd "$out" && pwd) HSGPU_REPORT_LMP=$lmp \
  HSGPU_REPORT_PLUGIN=$build/hardspheregpuplugin.so HSGPU_REPORT_BUILD=$build \
  HSGPU_REPORT_CMD=$cmd
say "report ($mode mode) into $HSGPU_REPORT_DIR: ${sections[*]}"
status=0
for s in "${sections[@]}"; do
  start=$SECONDS
  say "section $s"
  if bash "$HSGPU_ROOT/tools/report/$s.sh" "$mode"; then
    say "section $s: $((SECONDS - start)) s"
  else
    say "section $s FAILED after $((SECONDS - start)) s"
    status=1
  fi
done
bash "$HSGPU_ROOT/tools/report/index.sh"
exit $status

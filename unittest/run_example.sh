#!/usr/bin/env bash
# Runs an example input in a scratch copy of its folder and checks that LAMMPS finished
# without an ERROR and wrote the expected files.
#   run_example.sh <mpiexec|-> <np> <lmp> <plugin> <example-dir> <input> [file-to-expect ...] -- [lmp args]
set -euo pipefail
mpiexec=$1 np=$2 lmp=$3 plugin=$4 dir=$5 input=$6
shift 6
expect=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do expect+=("$1"); shift; done
[ $# -gt 0 ] && shift
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cp -r "$dir"/. "$work"
cd "$work"
launcher=()
if [ "$mpiexec" != "-" ]; then launcher=("$mpiexec" -np "$np"); fi
set +e
"${launcher[@]}" "$lmp" -in "$input" -var plugin "$plugin" "$@" >out.log 2>&1
rc=$?
set -e
cat out.log
if [ $rc -ne 0 ] || grep -q "^ERROR" out.log; then echo "example failed (exit $rc)"; exit 1; fi
grep -q "Total wall time" out.log || { echo "example did not finish"; exit 1; }
for f in "${expect[@]}"; do
  [ -s "$f" ] || { echo "example did not write $f"; exit 1; }
  echo "wrote $f ($(stat -c %s "$f") bytes)"
done

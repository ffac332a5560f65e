#!/usr/bin/env bash
# Several GPUs of one host, one MPI rank per GPU (each rank takes the GPU of its node-local
# rank): the seed paper's m-GPU benchmark (Hawick & Playne 2011) with fix hardsphere and
# pair_style gravity.  Prints three Markdown tables:
#
#   1. strong scaling, collisions plus all-pairs gravity: dilute, lattice2d and lattice3d of
#      examples/hardsphere with `pair_style gravity 0.001 0.5 gpu yes precision single` added
#      (in.seed's settings), at each N, on each rank count;
#   2. weak scaling, collisions only: `per` atoms per GPU of lattice3d and of the fluid
#      (in.fluid; nx the nearest cube, so N is within a few % of ranks x per);
#   3. collision-only runs from one data file (written once on one rank) on each rank count:
#      the final positions and velocities of every atom compared bit for bit with the 1-rank
#      run (write_dump ... sorted by ID, %.17g), and the same for the gravity runs of table 1
#      at the smallest N, where the forces are summed per rank and differ at round-off: there
#      the largest position difference is printed;
#   4. `gpu/gather yes` (the default: each step's atoms gathered on rank 0, whose device runs
#      the step) against `gpu/gather no` (each rank's device resolves its host's groups):
#      lattice3d collisions only, `per` atoms per rank, on each rank count above 1.
#
#   examples/benchmarks/bench_multi_gpu.sh lmp plugin ["ranks"] ["sizes"] [per] [reps]
#
#   ranks  rank (GPU) counts, default "1 2";  sizes  N for table 1, default
#   "65536 262144 1048576";  per  atoms per GPU for table 2, default 262144;  reps  repetitions
#   of each run, default 1 (the median is printed).  HSGPU_MGPU_TABLES="1 2 3" picks tables.
#
# Each timed run follows a warm-up run of HSGPU_MGPU_WARM steps (default 3) in the same
# process; the tables give the second run.
# Columns of tables 1 and 2 come from LAMMPS's timer breakdown on rank 0, per step: Loop (the
# whole step), Pair (the gravity: with several ranks each GPU sums over all atoms for its own),
# Modify (fix hardsphere, fix nve/sphere and fix gravity), Comm and Neigh; "fix step" is the
# fix's own time per step after the first (its run summary); "on device" says how many steps
# the collisions ran whole on a device (with several ranks, gpu/gather yes: on rank 0's device
# over every rank's atoms; table 4 compares gpu/gather no, where each rank's GPU resolves the
# groups of its host's windows).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
lmp=$(readlink -f "${1:?usage: bench_multi_gpu.sh lmp plugin [ranks] [sizes] [per] [reps]}")
plugin=$(readlink -f "${2:?usage: bench_multi_gpu.sh lmp plugin [ranks] [sizes] [per] [reps]}")
read -r -a ranks <<< "${3:-1 2}"
read -r -a sizes <<< "${4:-65536 262144 1048576}"
per=${5:-262144}
reps=${6:-1}
tables=${HSGPU_MGPU_TABLES:-1 2 3 4}
warm=${HSGPU_MGPU_WARM:-3}    # steps of the warm-up run before each timed run (tables 1, 2, 4)
mpirun=${MPIRUN:-mpirun}    # may carry options, e.g. "mpirun --bind-to none"
export OMP_NUM_THREADS=1 OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
scenes=${HSGPU_SCENES:-$here}
cp "$root"/examples/hardsphere/in.dilute "$root"/examples/hardsphere/in.lattice2d \
  "$root"/examples/hardsphere/in.lattice3d "$scenes"/in.fluid "$work"/

# Variants of each input: .col (collisions on the GPU), .grav (plus all-pairs gravity on the
# GPU), .write (writes its start as a data file instead of running), .read (starts from it and
# dumps the end state sorted by ID).
for f in "$work"/in.dilute "$work"/in.lattice2d "$work"/in.lattice3d "$work"/in.fluid; do
  sed 's/^\(fix *hs all hardsphere.*\)$/\1 gpu yes/' "$f" > "$f.col"
  grep -q 'hardsphere.*gpu yes' "$f.col" || { echo "no fix hardsphere line in $f" >&2; exit 2; }
  # (Sort bins of 2.0, as measured in doc/bench_multi_gpu.md; before commit 'pair gravity picks
  # its own sort bin size' LAMMPS's default, half the neighbor cutoff, made too many here.)
  sed 's/^\(comm_modify.*\)$/pair_style gravity 0.001 0.5 gpu yes precision single\npair_coeff * *\n\1/; s/^\(atom_modify *map array\)$/\1 sort 1000 2.0/' \
    "$f.col" > "$f.grav"
  sed 's/^\(fix *hs all hardsphere.*\)$/\1 gpu yes gpu\/gather no/' "$f" > "$f.nogather"
  for v in col grav; do
    sed 's/^run .*$/write_data ${dfile}/; /^print/d; /^variable *rate/d; /^variable *events/d' \
      "$f.$v" > "$f.$v.write"
    sed '/^variable *a /,/^velocity/c read_data ${dfile}' "$f.$v" |
      sed '/^print/d; /^variable *rate/d; /^variable *events/d' > "$f.$v.read"
    printf '%s\n' 'write_dump all custom ${dump} id x y z vx vy vz modify sort id format float %.17g' \
      >> "$f.$v.read"
  done
  # The timed variants run `warm` steps first: a run's first step allocates the device
  # buffers, page-locks the atom arrays and opens the other ranks' buffers (about 0.1 s on
  # four GPUs at N = 1048576), which a 10-step run would spread over its steps.  The tables
  # give the second run.
  sed -i "s/^run \(.*\)$/run $warm\nrun \1/" "$f.col" "$f.grav" "$f.nogather"
done

median() { sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : 0.5 * (v[NR / 2] + v[NR / 2 + 1])}'; }

# One run on r ranks; prints "loop pair modify comm neigh fixstep resident steps collisions", the
# times in ms per step, collisions per step (the run summary's).
one() {
  local r=$1 input=$2 log=$3; shift 3
  (cd "$work" && $mpirun -np "$r" "$lmp" -in "$input" -var plugin "$plugin" "$@" -log "$log" \
    -echo none -screen none > "$log.out" 2>&1) ||
    { echo "run failed: $r ranks, $input $*" >&2; tail -n 8 "$work/$log" "$work/$log.out" >&2; exit 1; }
  awk -v st="$(sed -n 's/^Loop time of [0-9.e+-]* on [0-9]* procs for \([0-9]*\) steps.*/\1/p' "$work/$log" | tail -n 1)" '
    /^Loop time of/ {loop = $4}
    /^Pair  *\|/ {split($0, c, "|"); pair = c[3]}
    /^Modify  *\|/ {split($0, c, "|"); modify = c[3]}
    /^Comm  *\|/ {split($0, c, "|"); comm = c[3]}
    /^Neigh  *\|/ {split($0, c, "|"); neigh = c[3]}
    /^Fix hardsphere \(/ {
      s = $0; sub(/.*\(/, "", s); sub(/ ms after the first.*/, "", s); fix = s
      s = $0; sub(/.*backend\): /, "", s); split(s, w, " "); coll = w[3]
    }
    /whole on the device/ {s = $0; sub(/^Fix hardsphere: /, "", s); split(s, w, " "); res = w[1]}
    END {printf "%g %g %g %g %g %g %d %d %g\n", 1e3 * loop / st, 1e3 * pair / st,
           1e3 * modify / st, 1e3 * comm / st, 1e3 * neigh / st, fix, res, st, coll}' "$work/$log"
}

# Median of `reps` runs, each column separately.
runs() {
  local r=$1; shift
  : > "$work/rows"
  for ((k = 0; k < reps; ++k)); do one "$r" "$@" >> "$work/rows"; done
  local out="" c
  for c in 1 2 3 4 5 6 7 8 9; do out="$out $(awk -v k=$c '{print $k}' "$work/rows" | median)"; done
  echo "$out"
}

row() {    # label N ranks base_loop base_ranks weak(0/1) base_n fields...
  local label=$1 n=$2 r=$3 b=$4 br=$5 weak=$6 bn=$7; shift 7
  awk -v lab="$label" -v n="$n" -v r="$r" -v b="$b" -v br="$br" -v weak="$weak" -v bn="$bn" \
    -v loop="$1" -v pair="$2" -v mod="$3" -v comm="$4" -v neigh="$5" -v fix="$6" -v res="$7" \
    -v st="$8" -v coll="$9" 'BEGIN {
      eff = weak ? (b / bn) / (loop / n) * br / r : b * br / (loop * r)
      printf "| %s | %d | %d | %.2f | %.2f | %.2f | %.2f | %.2f | %.3f | %.0f%% | %.3g | %d of %d |\n",
        lab, n, r, loop, pair, mod, comm, neigh, fix, 100 * eff, coll, res, st }'
}

hdr="| configuration | N | ranks (GPUs) | Loop ms/step | Pair (gravity) | Modify (collisions, integration) | Comm | Neigh | fix step ms | efficiency | collisions/step | on device |"
rul="|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"

if [[ " $tables " == *" 1 "* ]]; then
  echo "Strong scaling, collisions plus all-pairs gravity (single precision), efficiency against"
  echo "the first rank count: t(${ranks[0]}) ${ranks[0]} / (t(P) P) of the whole step."
  echo
  echo "$hdr"
  echo "$rul"
  for n in "${sizes[@]}"; do
    steps=$([ "$n" -ge 1000000 ] && echo 10 || echo 20)
    for c in dilute lattice2d lattice3d; do
      base=""
      for r in "${ranks[@]}"; do
        set -- $(runs "$r" "in.$c.grav" "log.$c" -var N "$n" -var steps "$steps")
        [ -n "$base" ] || { base=$1; br=$r; }
        row "$c" "$n" "$r" "$base" "$br" 0 0 "$@"
      done
    done
  done
  echo
fi

if [[ " $tables " == *" 2 "* ]]; then
  echo "Weak scaling, collisions only, about $per atoms per GPU, efficiency (time per atom of the"
  echo "first rank count) / (time per atom x ranks): t(${ranks[0]}) N(P) ${ranks[0]} / (t(P) N(${ranks[0]}) P) of the whole step."
  echo
  echo "$hdr"
  echo "$rul"
  for c in lattice3d fluid; do
    base=""
    for r in "${ranks[@]}"; do
      if [ $c = fluid ]; then
        nx=$(awk -v t=$((per * r)) 'BEGIN {printf "%d", t ^ (1 / 3) + 0.5}')
        n=$((nx * nx * nx))
        set -- $(runs "$r" "in.fluid.col" log.weak -var nx "$nx" -var steps 50)
      else
        n=$((per * r))
        set -- $(runs "$r" "in.lattice3d.col" log.weak -var N "$n" -var steps 50)
      fi
      [ -n "$base" ] || { base=$1; br=$r; bn=$n; }
      row "$c" "$n" "$r" "$base" "$br" 1 "$bn" "$@"
    done
  done
  echo
fi

if [[ " $tables " == *" 3 "* ]]; then
  echo "Runs from one data file on each rank count, against the run on ${ranks[0]} rank:"
  echo
  echo "| configuration | N | steps | ranks (GPUs) | collisions/step | end state |"
  echo "|---|---:|---:|---:|---:|---|"
  for spec in "fluid col 32768 100" "lattice3d col 65536 100" "lattice3d grav ${sizes[0]} 20"; do
    read -r c v n steps <<< "$spec"
    sz=(-var N "$n")
    [ $c = fluid ] && sz=(-var nx "$(awk -v t="$n" 'BEGIN {printf "%d", t ^ (1 / 3) + 0.5}')")
    (cd "$work" && "$lmp" -in "in.$c.$v.write" -var plugin "$plugin" "${sz[@]}" -var dfile "data.$c.$v" \
      -log none -echo none -screen none > /dev/null 2>&1) || { echo "write_data failed: $c" >&2; exit 1; }
    ref=""
    for r in "${ranks[@]}"; do
      set -- $(one "$r" "in.$c.$v.read" log.same -var dfile "data.$c.$v" -var steps "$steps" \
        -var dump "dump.$c.$v.$r")
      coll=$9
      if [ -z "$ref" ]; then
        ref="dump.$c.$v.$r"
        verdict="reference"
      elif cmp -s "$work/$ref" "$work/dump.$c.$v.$r"; then
        verdict="bitwise equal"
      else
        verdict=$(paste -d' ' <(sed -n '10,$p' "$work/$ref") <(sed -n '10,$p' "$work/dump.$c.$v.$r") |
          awk '{for (k = 2; k <= 4; ++k) {d = $k - $(k + 7); if (d < 0) d = -d; if (d > m) m = d}
                for (k = 5; k <= 7; ++k) {d = $k - $(k + 7); if (d < 0) d = -d; if (d > mv) mv = d}
                if ($0 != "") n++}
               END {printf "differs: largest |dx| %.3g, |dv| %.3g over %d atoms", m, mv, n}')
      fi
      label=$c
      [ $v = grav ] && label="$c with gravity"
      echo "| $label | $n | $steps | $r | $coll | $verdict |"
    done
  done
fi

if [[ " $tables " == *" 4 "* ]]; then
  echo
  echo "lattice3d, collisions only, $per atoms per rank: the fix's step after the first (ms), and"
  echo "for gpu/gather yes the time moving the atoms between the ranks and the bytes all ranks"
  echo "received per step (the fix's log lines); 50 steps with gathering, 10 without:"
  echo
  echo "| ranks (GPUs) | N | gpu/gather yes: fix step ms | gpu/gather no: fix step ms | moving the atoms ms/step (yes) | MB received per step (yes) |"
  echo "|---:|---:|---:|---:|---:|---:|"
  for r in "${ranks[@]}"; do
    [ "$r" -gt 1 ] || continue
    n=$((per * r))
    set -- $(one "$r" in.lattice3d.col log.gy -var N "$n" -var steps 50)
    yes=$6
    set -- $(one "$r" in.lattice3d.nogather log.gn -var N "$n" -var steps 10)
    no=$6
    mv=$(sed -n 's/.* and \([0-9.e+-]*\) s gathering the atoms.*/\1/p' "$work/log.gy" | tail -n 1)
    kb=$(sed -n 's/.*, \([0-9.e+-]*\) kB received by all.*/\1/p' "$work/log.gy" | tail -n 1)
    awk -v r="$r" -v n="$n" -v y="$yes" -v o="$no" -v mv="$mv" -v kb="$kb" \
      'BEGIN {printf "| %d | %d | %.2f | %.1f | %.1f | %.1f |\n", r, n, y, o, 1e3 * mv / 50, kb / 1e3}'
  done
fi

#!/usr/bin/env bash
# Weak and strong scaling of fix hardsphere on the CPU over MPI ranks (one rank per core,
# mpirun --bind-to core).  Prints two Markdown tables:
#
#   weak    about `per` atoms per rank: lattice3d (examples/hardsphere, N = per x P), the fluid
#           (in.fluid, nx the nearest cube) and the pour (examples/hardsphere/in.pour, a block
#           n x n cells wide and 16 layers high, n the nearest integer to sqrt(per P / 16);
#           the first `pour` steps: the block falls and lands on the floor);
#   strong  N = `big` (lattice3d; the fluid with the nearest cube) on every rank count.
#
#   examples/benchmarks/bench_scaling_mpi.sh lmp plugin ["ranks"] [per] [big] [reps]
#
#   ranks  default "1 2 4 8 16";  per  default 32768;  big  default 1048576;  reps  default 1
#   (the median of each column is printed, and the least and most fix step of the runs; the
#   repetitions go round the rank counts, so that a slow spell of a shared host falls on all of
#   them alike: one run of one rank varied by a factor of 1.8 within minutes on a 16-core
#   virtual machine, 2026-11-27).
#   HSGPU_SCALING="weak strong" picks the tables; HSGPU_POUR_STEPS the pour's steps (600);
#   HSGPU_WEAK="lattice3d fluid pour" the weak table's scenes; HSGPU_STRONG_STEPS the strong
#   table's steps (20);
#   HSGPU_SPANNING=view|gather adds that `spanning` keyword to the fix (default: the fix's);
#   HSGPU_RUN_LIMIT=s stops a run after s seconds (a pile on many ranks may take hours): its
#   row then gives the least the fix's step can have taken ("> t", the limit over the steps,
#   setup included) and the most its efficiency can be ("< e"), and counts the runs stopped.
#   HSGPU_BOUND=0 leaves out the host's bound (below; lattice3d and the fluid, on by default).
#
# Columns: the fix's own time per step after the run's first (its run summary; median, and the
# least and most of the runs), LAMMPS's Loop
# time per step, the efficiency of the fix's time (weak: t(P0) N(P) / (t(P) N(P0)) x P0 / P; strong:
# t(P0) P0 / (t(P) P), P0 the first rank count), the atoms per step in groups that span ranks,
# gathers per step, the fix's communication of the last step: collective operations
# (f_ID[24]), ghost updates (f_ID[25]) and bytes brought to all ranks (f_ID[26]), and from the
# run's log (several ranks; 0 on one): the least and the most time per step a rank spent in the
# fix's communication (waits for the other ranks included) and the most a rank spent on the
# groups that span ranks (gathered, resolved, results sent back, missed pairs joined), and the
# atoms of the rank with the most (LAMMPS's Nlocal max) over the mean: a coupled step goes at
# the pace of its most loaded rank, so this ratio bounds the efficiency from the decomposition
# alone (a lattice of nx planes over a grid of ranks that does not divide nx).
# The host's bound (lattice3d and the fluid, P > 1): right after each P-rank run, P single-rank
# runs at once of one rank's share (weak: `per` atoms; strong: N / P, the fluid the nearest
# cube), each pinned to its own core (taskset -c 0 ... P-1) and sharing nothing; their median
# and slowest fix step, and the efficiencies a run whose ranks went at those paces would have
# (the single run's time scaled to the rank's atoms, in the efficiency above).  The ranks of a
# coupled run wait for each other every step, so it goes at the pace of its slowest core: the
# slowest single run bounds its efficiency on that host, whatever the code.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
lmp=$(readlink -f "${1:?usage: bench_scaling_mpi.sh lmp plugin [ranks] [per] [big] [reps]}")
plugin=$(readlink -f "${2:?usage: bench_scaling_mpi.sh lmp plugin [ranks] [per] [big] [reps]}")
read -r -a ranks <<< "${3:-1 2 4 8 16}"
per=${4:-32768}
big=${5:-1048576}
reps=${6:-1}
tables=${HSGPU_SCALING:-weak strong}
pour_steps=${HSGPU_POUR_STEPS:-600}
strong_steps=${HSGPU_STRONG_STEPS:-20}
read -r -a weak_cases <<< "${HSGPU_WEAK:-lattice3d fluid pour}"
scenes=${HSGPU_SCENES:-$here}
export OMP_NUM_THREADS=1 OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cp "$root"/examples/hardsphere/in.lattice3d "$root"/examples/hardsphere/in.pour "$scenes"/in.fluid "$work"/
for f in "$work"/in.*; do
  sed -i '/^write_dump/d' "$f"
  if [ -n "${HSGPU_SPANNING:-}" ]; then
    sed -i -e ':a' -e '/&$/N; s/&\n *//; ta' "$f"    # continued lines joined
    sed -i "s/^\(fix *hs all hardsphere.*\)$/\1 spanning $HSGPU_SPANNING/" "$f"
    grep -q "spanning $HSGPU_SPANNING" "$f" || { echo "no spanning keyword added to $f" >&2; exit 2; }
  fi
  printf '%s\n' 'print "comm: $(f_hs[24]) $(f_hs[25]) $(f_hs[26])"' >> "$f"
done
echo "spanning: ${HSGPU_SPANNING:-default}"
echo "host: $(nproc --all) logical CPUs, $(lscpu | sed -n 's/^Core(s) per socket: *//p') cores per socket x $(lscpu | sed -n 's/^Socket(s): *//p') sockets, $(lscpu | sed -n 's/^Thread(s) per core: *//p') thread(s) per core, $(lscpu | sed -n 's/^Model name: *//p'); $(date -u '+%F %T UTC')"
echo

median() { sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : 0.5 * (v[NR / 2] + v[NR / 2 + 1])}'; }
# The side of the cube of lattice sites nearest to $1 atoms (the fluid's nx).
cube_side() { awk -v t="$1" 'BEGIN {printf "%d", t ^ (1 / 3) + 0.5}'; }

# One run: prints "fixstep loop spanning gathers collectives ghostupdates bytes commleast
# commmost spanningmost atomsmost atomsmean".
# A run stopped at HSGPU_RUN_LIMIT prints "stopped" instead.
one() {
  local np=$1 input=$2 log=$3; shift 3
  local limit=() rc=0
  [ -z "${HSGPU_RUN_LIMIT:-}" ] || limit=(timeout --kill-after=30 "$HSGPU_RUN_LIMIT")
  (cd "$work" && "${limit[@]}" mpirun -np "$np" --bind-to core "$lmp" -in "$input" -var plugin "$plugin" "$@" \
    -log "$log" -echo none -screen none > "$log.out" 2>&1) || rc=$?
  if [ "$rc" -eq 124 ] && [ -n "${HSGPU_RUN_LIMIT:-}" ]; then
    echo stopped
    return
  fi
  [ "$rc" -eq 0 ] ||
    { echo "run failed: $np ranks, $input $*" >&2; tail -n 8 "$work/$log" "$work/$log.out" >&2; exit 1; }
  awk '
    /^Loop time of/ {loop = $4; steps = $9}
    /^Fix hardsphere \(/ {
      s = $0; sub(/.*\(/, "", s); sub(/ ms after the first.*/, "", s); fix = s
      s = $0; sub(/ atoms per step in groups spanning ranks.*/, "", s); n = split(s, w, " "); span = w[n]
      s = $0; sub(/ gathers per step.*/, "", s); n = split(s, w, " "); gath = w[n]
    }
    /^comm: / {coll = $2; ghost = $3; bytes = $4}
    /^Fix hardsphere: communication per step/ {
      s = $0; sub(/ ms per step in it on a rank.*/, "", s); n = split(s, w, " ")
      clo = w[n - 2]; chi = w[n]
    }
    /^Fix hardsphere: a rank.s search and windows/ {n = split($0, w, " "); shi = w[n]}
    /^Nlocal:/ {nave = $2; nmax = $4}
    END {printf "%g %g %g %g %g %g %g %g %g %g %g %g\n", fix, 1e3 * loop / steps, span, gath, coll,
                ghost, bytes, clo + 0, chi + 0, shi + 0, nmax + 0, nave + 0}' \
    "$work/$log"
}

hdr="| configuration | N | ranks | fix step ms | fix step ms, least-most run | Loop ms/step | efficiency (fix) | spanning atoms/step | gathers/step | collectives | ghost updates | bytes | communication ms/step (least-most rank) | spanning groups ms/step (most) | atoms per rank, most (/ mean) | single runs at once: atoms, fix step ms median (slowest) | host's bound: median, slowest |"
rul="|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"

# P single-rank runs at once (the host's bound): case np args... -> prints "atoms median slowest"
# (ms per step of the fix after the first), or nothing where a run failed.
alone() {
  local c=$1 np=$2 n input a i k
  case $c in
    lattice3d|fluid) read -r -a a <<< "$(size_args "$c" 1)" ;;
    big_lattice3d) a=($((big / np)) -var N $((big / np)) -var steps "$strong_steps") ;;
    big_fluid) local nx
      nx=$(cube_side $((big / np)))
      a=($((nx * nx * nx)) -var nx "$nx" -var steps "$strong_steps") ;;
    *) return ;;
  esac
  n=${a[0]}
  input=in.${c#big_}
  for ((i = 0; i < np; ++i)); do
    (cd "$work" && taskset -c "$i" "$lmp" -in "$input" -var plugin "$plugin" "${a[@]:1}" \
      -log "alone.$i" -echo none -screen none > "alone.$i.out" 2>&1) &
  done
  wait
  local times=""
  for ((i = 0; i < np; ++i)); do
    k=$(sed -n 's/^Fix hardsphere (.*(\([0-9.e+-]*\) ms after the first).*/\1/p' "$work/alone.$i")
    [ -n "$k" ] || { echo "single run $i of $np failed: $input ${a[*]:1}" >&2; return; }
    times+="$k"$'\n'
  done
  echo "$n $(printf '%s' "$times" | median) $(printf '%s' "$times" | sort -g | tail -n 1)"
}

size_args() {    # case np -> prints "N args..."
  local c=$1 np=$2 total=$((per * $2))
  case $c in
    lattice3d) echo "$total -var N $total -var steps 50" ;;
    fluid) local nx
      nx=$(cube_side "$total")
      echo "$((nx * nx * nx)) -var nx $nx -var steps 50" ;;
    pour) local n
      n=$(awk -v t="$total" 'BEGIN {printf "%d", sqrt(t / 16) + 0.5}')
      echo "$total -var N $total -var n $n -var steps $pour_steps" ;;
    big_lattice3d) echo "$big -var N $big -var steps $strong_steps" ;;
    big_fluid) local nx
      nx=$(cube_side "$big")
      echo "$((nx * nx * nx)) -var nx $nx -var steps $strong_steps" ;;
  esac
}

# The efficiency of a row's fix step ($1 ms, N = $2 on $3 ranks) against the table's first row
# (base ms, bn atoms on bp ranks; table()'s), as a fraction.
efficiency() {
  awk -v kind="$kind" -v b="$base" -v bn="$bn" -v bp="$bp" -v fix="$1" -v n="$2" -v np="$3" \
    'BEGIN {print (kind == "weak") ? (b / bn) / (fix / n) * bp / np : b * bp / (fix * np)}'
}

table() {    # weak|strong cases...  Each case's rows are printed once its runs are done.
  local kind=$1; shift
  local c np rep
  echo "$hdr"
  echo "$rul"
  for c in "$@"; do
    local base="" bn="" bp=""
    for np in "${ranks[@]}"; do : > "$work/rows.$c.$np"; done
    # The repetitions go round the rank counts (1 2 4 ... 1 2 4 ...), so that a slow spell of
    # the host falls on every rank count alike rather than on one row.
    for ((rep = 0; rep < reps; ++rep)); do
      for np in "${ranks[@]}"; do
        read -r -a a <<< "$(size_args "$c" "$np")"
        one "$np" "in.${c#big_}" "log.$c.$np" "${a[@]:1}" >> "$work/rows.$c.$np"
        [ "${HSGPU_BOUND:-1}" = 0 ] || [ "$np" -le 1 ] || alone "$c" "$np" >> "$work/alone.$c.$np"
        # (each run as it ends, on standard error: a row whose later runs do not end is kept)
        echo "# ${c#big_}, $np ranks, run $((rep + 1)) of $reps: fix step $(tail -n 1 "$work/rows.$c.$np" | awk '{print ($1 == "stopped") ? "- (stopped after '"${HSGPU_RUN_LIMIT:-}"' s)" : $1 " ms"}')" >&2
      done
    done
    for np in "${ranks[@]}"; do
      read -r -a a <<< "$(size_args "$c" "$np")"
      local n=${a[0]} m=() steps=0 stopped
      for ((k = 1; k + 1 < ${#a[@]}; ++k)); do [ "${a[$k]}" != steps ] || steps=${a[$((k + 1))]}; done
      stopped=$(grep -c '^stopped' "$work/rows.$c.$np" || true)
      if [ "$stopped" -gt 0 ] && ! grep -qv '^stopped' "$work/rows.$c.$np"; then
        # Every run stopped: the least the step took, the most the efficiency can be.
        local least eff=-
        least=$(awk -v lim="$HSGPU_RUN_LIMIT" -v steps="$steps" 'BEGIN {print 1e3 * lim / steps}')
        [ -z "$base" ] || eff=$(efficiency "$least" "$n" "$np")
        awk -v lab="${c#big_}" -v n="$n" -v np="$np" -v lim="$HSGPU_RUN_LIMIT" -v fix="$least" \
          -v eff="$eff" -v k="$stopped" 'BEGIN {
            printf "| %s | %d | %d | > %.4g | %d of %d runs stopped after %s s | - | %s | - | - | - | - | - | - | - | - | - | - |\n",
              lab, n, np, fix, k, k, lim, (eff == "-") ? "-" : sprintf("< %.0f%%", 100 * eff) }'
        continue
      fi
      for k in 1 2 3 4 5 6 7 8 9 10 11 12; do m+=("$(grep -v '^stopped' "$work/rows.$c.$np" | awk -v k=$k '{print $k}' | median)"); done
      [ -n "$base" ] || { base=${m[0]}; bn=$n; bp=$np; }
      local spread
      spread=$(grep -v '^stopped' "$work/rows.$c.$np" | awk '{print $1}' | sort -g | awk '{v[NR] = $1} END {printf (NR > 1) ? "%.4g-%.4g" : "-", v[1], v[NR]}')
      [ "$stopped" -eq 0 ] || spread="$spread ($stopped stopped)"
      # The host's bound: the medians over the repetitions of the single runs' median and
      # slowest, each scaled to this row's atoms per rank.
      local single="-" bound="-"
      if [ -s "$work/alone.$c.$np" ]; then
        local sn smed sslow
        sn=$(awk '{print $1}' "$work/alone.$c.$np" | median)
        smed=$(awk '{print $2}' "$work/alone.$c.$np" | median)
        sslow=$(awk '{print $3}' "$work/alone.$c.$np" | median)
        single=$(awk -v n="$sn" -v a="$smed" -v b="$sslow" 'BEGIN {printf "%d, %.4g (%.4g)", n, a, b}')
        bound=$(awk -v a="$(efficiency "$(awk -v t="$smed" -v sn="$sn" -v n="$n" -v np="$np" 'BEGIN {print t * n / np / sn}')" "$n" "$np")" \
          -v b="$(efficiency "$(awk -v t="$sslow" -v sn="$sn" -v n="$n" -v np="$np" 'BEGIN {print t * n / np / sn}')" "$n" "$np")" \
          'BEGIN {printf "%.0f%%, %.0f%%", 100 * a, 100 * b}')
      fi
      awk -v lab="${c#big_}" -v n="$n" -v np="$np" -v eff="$(efficiency "${m[0]}" "$n" "$np")" \
        -v fix="${m[0]}" -v loop="${m[1]}" -v span="${m[2]}" -v gath="${m[3]}" -v coll="${m[4]}" \
        -v ghost="${m[5]}" -v bytes="${m[6]}" -v clo="${m[7]}" -v chi="${m[8]}" -v shi="${m[9]}" \
        -v nmax="${m[10]}" -v nave="${m[11]}" -v spread="$spread" -v single="$single" \
        -v bound="$bound" 'BEGIN {
          printf "| %s | %d | %d | %.2f | %s | %.2f | %.0f%% | %.0f | %.2f | %.0f | %.0f | %.3g | %.3g-%.3g | %.3g | %.0f (%.3f) | %s | %s |\n",
            lab, n, np, fix, spread, loop, 100 * eff, span, gath, coll, ghost, bytes, clo, chi, shi,
            nmax, (nave > 0) ? nmax / nave : 0, single, bound }'
    done
  done
  echo
}

if [[ " $tables " == *" weak "* ]]; then
  echo "Weak scaling, about $per atoms per rank (the pour: its first $pour_steps steps):"
  echo
  table weak "${weak_cases[@]}"
fi
if [[ " $tables " == *" strong "* ]]; then
  echo "Strong scaling, N = $big (the fluid: the nearest cube):"
  echo
  table strong big_lattice3d big_fluid
fi

#!/usr/bin/env bash
# Section "gravity" of tools/report.sh (issue 11, item 2.3): precision and cost of
# pair_style gravity.  Force error against wall time per step on the CPU (double precision, on
# 1 and on all usable OpenMP threads) and, where a GPU is usable, on the GPU in single, mixed
# and double precision.  Writes gravity.md, gravity_error_vs_time.png, gravity_time_vs_n.png
# and gravity_points.csv into $HSGPU_REPORT_DIR.
#
#   bash tools/report/gravity.sh quick|full      (run by tools/report.sh, which sets the env)
#
# The system is examples/benchmarks/in.gravity_step as it is (N bodies at random in a unit
# cube, open box, G = 1, eps = 0.01).  References: for the GPU, the CPU path's forces (double
# precision) of the same positions; for the CPU, a long-double direct sum in numpy
# (gravity_plot.py error_ld), over all targets up to N = 4096 and over 1024 targets spread
# over the IDs above.  Any LAMMPS error, a missing result or a value that is not finite stops
# the section with a non-zero exit; no page is written then.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
# shellcheck source=tools/report/lib.sh
source "$here/lib.sh"
mode=$(report_mode "${1:-}")
report_env
out=$HSGPU_REPORT_DIR
bench=$HSGPU_ROOT/examples/benchmarks/in.gravity_step
forces_in=$here/in.gravity_forces
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
helper() { python_plot "$here/gravity_plot.py" "$@"; }

if [ "$mode" = quick ]; then
  cpu_ns=(1024 2048 4096)
  gpu_ns=(1024 4096 16384)
else
  cpu_ns=(1024 2048 4096 8192 16384)
  gpu_ns=(1024 4096 16384 65536)
fi
maxth=$(usable_cpus)
threads=(1)
[ "$maxth" -gt 1 ] && threads+=("$maxth")
ld_all=4096      # long-double reference over all targets up to this N
ld_sample=1024   # and over this many targets above it
gpu=no
if has_gpu; then gpu=yes; fi
load=$(cut -d' ' -f1-3 /proc/loadavg)

# Steps per timed run: about N^2 pair terms a step, so fewer steps at large N.
cpu_steps() {
  local n=$1 budget max=20 min=3
  if [ "$mode" = quick ]; then budget=$((4096 * 4096 * 6)); else budget=$((8192 * 8192 * 10)); fi
  local s=$((budget / (n * n)))
  [ "$s" -gt "$max" ] && s=$max
  [ "$s" -lt "$min" ] && s=$min
  echo "$s"
}
gpu_steps() { echo 20; }

fail() {
  echo "gravity: $1; the end of its log:" >&2
  tail -n 20 "$2" >&2
  exit 1
}

# timed <log> <threads> <N> <steps> <gpu> <prec>: a run of in.gravity_step; prints
# "N steps ms_per_step threads".
timed() {
  local log=$1 th=$2 n=$3 steps=$4 g=$5 prec=$6
  OMP_NUM_THREADS=$th lmp_run "$log" "$bench" -var N "$n" -var steps "$steps" -var gpu "$g" \
    -var prec "$prec" || fail "LAMMPS failed (in.gravity_step N = $n gpu $g $prec)" "$log"
  helper timing "$log" "$g" "$prec"
}

# forces <dump> <threads> <N> <gpu> <prec>: the forces of one force-only step.
forces() {
  local dump=$1 th=$2 n=$3 g=$4 prec=$5
  OMP_NUM_THREADS=$th lmp_run "$dump.log" "$forces_in" -var bench "$bench" -var N "$n" \
    -var steps 0 -var gpu "$g" -var prec "$prec" -var dump "$dump" ||
    fail "LAMMPS failed (in.gravity_forces N = $n gpu $g $prec)" "$dump.log"
  [ -s "$dump" ] || fail "no forces written (N = $n gpu $g $prec)" "$dump.log"
}

rows=$work/points.csv
echo "backend,precision,threads,N,steps,ms_per_step,reference,rms_rel,max_rel,maxabs_rel" > "$rows"
bitwise=""
for n in "${cpu_ns[@]}"; do
  start=$SECONDS
  forces "$work/cpu_$n.txt" "$maxth" "$n" no double
  read -r rms mx mabs nt < <(helper error_ld "$work/cpu_$n.txt" 1.0 0.01 \
    "$([ "$n" -le "$ld_all" ] && echo "$n" || echo "$ld_sample")")
  if [ "$nt" -eq "$n" ]; then ref="long double (all $n targets)"; else ref="long double ($nt targets)"; fi
  if [ "$n" = "${cpu_ns[0]}" ] && [ "$maxth" -gt 1 ]; then
    forces "$work/cpu1_$n.txt" 1 "$n" no double
    helper same "$work/cpu1_$n.txt" "$work/cpu_$n.txt" >/dev/null
    bitwise="The CPU forces on 1 and on $maxth threads were compared at N = $n: bitwise equal."
  fi
  for th in "${threads[@]}"; do
    read -r nn steps ms tt < <(timed "$work/t_cpu_${th}_$n.log" "$th" "$n" "$(cpu_steps "$n")" no double)
    if [ "$nn" != "$n" ] || [ "$tt" != "$th" ]; then
      fail "expected N = $n on $th threads, LAMMPS ran N = $nn on $tt" "$work/t_cpu_${th}_$n.log"
    fi
    echo "cpu,double,$th,$n,$steps,$ms,$ref,$rms,$mx,$mabs" >> "$rows"
  done
  say "gravity: CPU N = $n: $((SECONDS - start)) s"
done

if [ "$gpu" = yes ]; then
  for n in "${gpu_ns[@]}"; do
    start=$SECONDS
    [ -f "$work/cpu_$n.txt" ] || forces "$work/cpu_$n.txt" "$maxth" "$n" no double
    for prec in single mixed double; do
      read -r nn steps ms _ < <(timed "$work/t_gpu_${prec}_$n.log" 1 "$n" "$(gpu_steps "$n")" yes "$prec")
      [ "$nn" = "$n" ] || fail "expected N = $n, LAMMPS ran $nn" "$work/t_gpu_${prec}_$n.log"
      forces "$work/gpu_${prec}_$n.txt" 1 "$n" yes "$prec"
      read -r rms mx mabs < <(helper error "$work/gpu_${prec}_$n.txt" "$work/cpu_$n.txt")
      echo "gpu,$prec,1,$n,$steps,$ms,CPU double,$rms,$mx,$mabs" >> "$rows"
    done
    say "gravity: GPU N = $n: $((SECONDS - start)) s"
  done
fi
cp "$rows" "$out/gravity_points.csv"

helper plot "$out/gravity_points.csv" "$out" "$gpu"
helper table "$out/gravity_points.csv" "$gpu" "${gpu_ns[0]} ... ${gpu_ns[-1]}" > "$work/table.md"
helper summary "$out/gravity_points.csv" "$gpu" > "$work/summary.md"

steps_list=$(for n in "${cpu_ns[@]}"; do printf '%s: %s, ' "$n" "$(cpu_steps "$n")"; done)
steps_list=${steps_list%, }
if [ "$gpu" = yes ]; then
  gpu_note="GPU: \`-var gpu yes -var prec single|mixed|double\`, one MPI rank, N =
${gpu_ns[*]}, $(gpu_steps) steps; its forces are compared with the CPU path's forces of the
same positions (double precision: the reference)."
else
  gpu_note="GPU: **not measured** on this machine (no usable CUDA device, or a plugin built
without CUDA): the GPU rows of the table say so and the plots have no GPU points. The GPU's
reference would be the CPU path's forces (double precision) of the same positions."
fi

{
  page_header "Precision and cost of pair_style gravity" "$mode"
  cat <<EOF
**What is measured.** \`pair_style gravity\` (softened all-pairs Newtonian gravity) on the
system of \`examples/benchmarks/in.gravity_step\`: N bodies of mass 1 at random in a unit cube,
open box, G = 1, eps = 0.01. For each backend, precision and N: the wall time of a whole
LAMMPS step (LAMMPS's loop time over the steps; the run's last step also computes energy and
virial), and the error of the forces of one force-only step against a reference, per body
|F - F_ref| / |F_ref| (RMS and maximum over the bodies checked), and the largest
|F - F_ref| over the largest |F_ref|.

**The CPU path** computes in double precision only (the \`precision\` keyword applies to the
GPU; see [pair_gravity.md](../pair_gravity.md)). Its loop over a rank's atoms runs on
LAMMPS's OpenMP threads (\`OMP_NUM_THREADS\` at startup), so it is timed on 1 thread and on
$maxth (all usable CPUs of this machine), one MPI rank. Its reference is a direct sum
written in numpy in long double (machine epsilon $("$HSGPU_REPORT_PYTHON" -c 'import numpy as np; print("%.2g" % np.finfo(np.longdouble).eps)'), against 2.2e-16 for double; numpy's
pairwise summation, a different order from the CPU path's sum in atom-ID order) from the exact
double positions LAMMPS wrote (\`%.17g\`), over all targets up to N = $ld_all and over
$ld_sample targets spread over the IDs above. $bitwise $gpu_note

**Inputs.** Timing: \`lmp -in examples/benchmarks/in.gravity_step -var N N -var steps S
-var gpu no|yes -var prec P\` (steps on the CPU, N: steps, $steps_list). Forces:
\`lmp -in tools/report/in.gravity_forces -var bench examples/benchmarks/in.gravity_step
-var N N -var steps 0 -var gpu no|yes -var prec P -var dump FILE\` (the same system, bodies held
in place, one force-only step, \`write_dump ... id x y z fx fy fz\`). One MPI rank; the CPU
runs with \`OMP_NUM_THREADS\` as in the threads column, the GPU runs with 1. The load average
of this machine when the section started was $load (other work may share its cores, which
shows as scatter in the times, most in the runs on all threads). The raw numbers are in
[gravity_points.csv](gravity_points.csv).

![error against time per step](gravity_error_vs_time.png)

![time per step against N](gravity_time_vs_n.png)

EOF
  cat "$work/summary.md"
  echo
  cat "$work/table.md"
  echo
  echo "pair forces/s: N (N - 1) over the time per step, the interactions delivered per second."
} > "$work/gravity.md"
mv "$work/gravity.md" "$out/gravity.md"
say "gravity: wrote $out/gravity.md"

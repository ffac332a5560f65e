#!/usr/bin/env bash
# Section "seed" of tools/report.sh (issue 11, item 2.1): the seed paper's benchmark, whole
# (Hawick & Playne 2011, Figures 7-9): its three configurations (dilute, lattice2d, lattice3d)
# with all-pairs gravity between the spheres plus the uniform field, for N = 1024 doubling, on
# the CPU in the paper's order (order serial) and the fix's default order, and on the GPU
# (both styles gpu yes) when one is usable.  Writes seed.md, seed_ms_per_step.png and
# seed_runs.csv into $HSGPU_REPORT_DIR.
#
#   bash tools/report/seed.sh quick|full      (run by tools/report.sh, which sets the env)
#
# quick: N = 1024 ... 4096 on the CPU (16384 on a GPU), few steps;
# full:  N = 1024 ... 65536 on the CPU in both orders, 1048576 on a GPU.
# Any LAMMPS error, a missing result or a value that is not finite stops the section with a
# non-zero exit; no page is written then.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
# shellcheck source=tools/report/lib.sh
source "$here/lib.sh"
mode=$(report_mode "${1:-}")
report_env
out=$HSGPU_REPORT_DIR
input=$here/in.seed_config
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
helper() { python_plot "$here/seed_plot.py" "$@"; }

if [ "$mode" = quick ]; then
  cpu_ns=(1024 2048 4096)
  gpu_ns=(1024 2048 4096 8192 16384)
else
  cpu_ns=(1024 2048 4096 8192 16384 32768 65536)
  gpu_ns=(1024 2048 4096 8192 16384 32768 65536 131072 262144 524288 1048576)
fi
configs=(dilute lattice2d lattice3d)
gpu=no
if has_gpu; then gpu=yes; fi

# Steps per run.  On the CPU the all-pairs gravity costs about N^2 pair terms per step
# (seconds per step at N = 65536), so the step count falls with N^2 down to a floor; the
# collision rate is still an average over N x steps particle-steps.
cpu_steps() {
  local n=$1 budget max min
  if [ "$mode" = quick ]; then budget=$((4096 * 4096 * 10)); max=20; min=4
  else budget=$((8192 * 8192 * 8)); max=50; min=2; fi
  local s=$((budget / (n * n)))
  [ "$s" -gt "$max" ] && s=$max
  [ "$s" -lt "$min" ] && s=$min
  echo "$s"
}
gpu_steps() {
  if [ "$mode" = quick ]; then echo 20
  elif [ "$1" -le 65536 ]; then echo 50
  else echo 20; fi
}

csv=$out/seed_runs.csv
echo "config,backend,N,steps,ms_per_step,pair_ms_per_step,modify_ms_per_step,fix_ms_per_step,search_ms_per_step,resolve_ms_per_step,collision_rate,events_per_step,ke_end" > "$work/runs.csv"

# run_one <config> <backend> <N> <steps> <order> <gpu>
warmup=100
load=$(cut -d' ' -f1-3 /proc/loadavg)
run_one() {
  local config=$1 backend=$2 n=$3 steps=$4 order=$5 g=$6
  local log=$work/$config-$backend-$n.log start=$SECONDS
  if ! lmp_run "$log" "$input" -var config "$config" -var N "$n" -var steps "$steps" \
      -var order "$order" -var gpu "$g" -var warmup "$warmup"; then
    echo "seed: LAMMPS failed for $config $backend N = $n; the end of its log:" >&2
    tail -n 20 "$log" >&2
    return 1
  fi
  helper row "$log" "$config" "$backend" "$g" >> "$work/runs.csv"
  say "seed: $config $backend N = $n, $steps steps: $((SECONDS - start)) s"
}

for config in "${configs[@]}"; do
  for n in "${cpu_ns[@]}"; do
    s=$(cpu_steps "$n")
    run_one "$config" cpu-serial "$n" "$s" serial no
    run_one "$config" cpu-default "$n" "$s" parallel no
  done
  if [ "$gpu" = yes ]; then
    for n in "${gpu_ns[@]}"; do
      run_one "$config" gpu "$n" "$(gpu_steps "$n")" parallel yes
    done
  fi
done
cp "$work/runs.csv" "$csv"

helper plot "$csv" "$out/seed_ms_per_step.png" "$gpu" > "$work/plot.txt"
helper table "$csv" "$gpu" "${gpu_ns[0]} ... ${gpu_ns[-1]}" > "$work/tables.md"
helper summary "$csv" > "$work/summary.md"

cpu_list="${cpu_ns[0]} ... ${cpu_ns[-1]}"
steps_list=$(for n in "${cpu_ns[@]}"; do printf '%s: %s, ' "$n" "$(cpu_steps "$n")"; done)
steps_list=${steps_list%, }
if [ "$gpu" = yes ]; then
  gpu_note="GPU rows: both styles with \`gpu yes\` (the fix's device-resident step and the
CUDA gravity path in its default precision, mixed), N = ${gpu_ns[0]} ... ${gpu_ns[-1]}, $(gpu_steps "${gpu_ns[0]}") steps (20 above N = 65536)."
else
  gpu_note="GPU rows: **not measured** on this machine (no usable CUDA device, or a plugin built
without CUDA); the plot has no GPU curves."
fi

{
  page_header "The seed paper's benchmark, whole: ms per step against N" "$mode"
  cat <<EOF
**What is measured.** The benchmark of K.A. Hawick and D.P. Playne, "Hard-Sphere Collision
Simulations with Multiple GPUs, PCIe Extension Buses and GPU-GPU Communications" (CSTN-138,
Massey University, 2011), as the paper ran it: hard spheres of diameter 1 with exact
collisions (\`fix hardsphere\`), all-pairs Newtonian gravity between them
(\`pair_style gravity 0.001 0.5\`, nearest periodic image) and the uniform field g = 0.1, in a
box periodic in x and y with a floor and a roof, dt = 0.1, in its three configurations: a
dilute gas (volume fraction 0.001, random positions), one square-lattice layer (spacing 1.1)
and a cubic-lattice slab (spacing 2, 16 layers), all with random velocities of temperature 1.
The geometry and fix settings are those of \`examples/hardsphere/in.dilute\`,
\`in.lattice2d\` and \`in.lattice3d\`; the gravity is that of \`in.seed\`. Each run is timed as
a whole step (LAMMPS's loop time over the steps), and split into the gravity (LAMMPS's Pair
time) and the fix's own step (its timer \`f_hs[20]\`: candidate search, resolution and the
rest of its post_integrate). Backends: **CPU serial** is \`order serial\`, the paper's loop
(one globally earliest collision at a time); **CPU default** is the fix's default order (time
windows split into independent groups; the same collisions, bitwise); **GPU** puts both
styles on the device.

**How each run goes.** The configuration first runs $warmup steps (t = $((warmup / 10))) with the
spheres' collisions and the uniform field only, in the default order (on the device in the GPU
rows), untimed: the lattices start with a burst (lattice2d, spacing 1.1) or a lull (lattice3d,
spacing 2) of collisions; after these steps the collision rate is about that of the middle
of the examples' 200-step runs (which average 0.0008, 0.027 and 0.062 per particle per step
from the start; the rates of the timed steps are in the tables). Then the gravity between the
spheres is switched on, fix hardsphere is defined anew in the order of the row (its counters
and timers start from zero) and S steps are timed. The warm-up leaves out the pair gravity
because at large N it would cost far more than the timed steps; so the timed steps start from
a state slightly different from the one the paper's system (pair gravity from t = 0) would
reach.

**Inputs.** \`lmp -in tools/report/in.seed_config -var config C -var N N -var steps S
-var order serial|parallel -var gpu no|yes -var warmup $warmup\` with the plugin loaded, one MPI
rank, \`OMP_NUM_THREADS=1\`; thermo output only at the first and last timed step. CPU: N =
$cpu_list (doubling) in both orders, steps per run (N: steps) $steps_list: the gravity costs
about N^2 pair terms per step (seconds per step at N = 65536), so the large-N rows average
over only a few steps. $gpu_note The load average of this machine when the section started
was $load (other work may share its cores, which shows as scatter in the times). The raw
numbers are in [seed_runs.csv](seed_runs.csv).

![ms per step against N](seed_ms_per_step.png)

Solid lines: the whole step; dashed: the fix's own step. $(cat "$work/plot.txt")

EOF
  cat "$work/summary.md"
  echo
  cat "$work/tables.md"
} > "$work/seed.md"
mv "$work/seed.md" "$out/seed.md"
say "seed: wrote $out/seed.md"

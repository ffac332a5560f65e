# Shared by tools/report.sh and its sections (tools/report/<section>.sh): where things are,
# how to run LAMMPS with the plugin, and the header every page carries.
# shellcheck shell=bash
# A section script is run as
#   bash tools/report/<section>.sh <quick|full>
# with these in the environment (set by tools/report.sh):
#   HSGPU_REPORT_DIR   where the section writes <section>.md and its PNGs (doc/report/)
#   HSGPU_REPORT_LMP   the LAMMPS executable;  HSGPU_REPORT_PLUGIN  hardspheregpuplugin.so
#   HSGPU_REPORT_BUILD the plugin's build directory;  HSGPU_REPORT_CMD  the command as typed
# It writes its raw numbers as CSV next to its page (<section>_*.csv), so that the plots and
# the "what to pick" page are made from the same numbers as the tables.

source "$(dirname "${BASH_SOURCE[0]}")/../common.sh"

report_env() {
  : "${HSGPU_REPORT_DIR:?run the sections through tools/report.sh}"
  : "${HSGPU_REPORT_LMP:?}" "${HSGPU_REPORT_PLUGIN:?}" "${HSGPU_REPORT_BUILD:?}"
  : "${HSGPU_REPORT_CMD:=bash tools/report.sh}"
  export OMP_NUM_THREADS=1
  mpi_env
  mkdir -p "$HSGPU_REPORT_DIR"
  HSGPU_REPORT_PYTHON=${HSGPU_REPORT_PYTHON:-$(report_python)}
  export HSGPU_REPORT_PYTHON
}

# report_mode <arg>: prints the section's mode, quick or full; fails with a usage line otherwise.
report_mode() {
  case ${1:-} in
    quick|full) echo "$1" ;;
    *) echo "usage: $0 quick|full" >&2; return 2 ;;
  esac
}

# has_gpu: true when a CUDA device answers and the plugin was built with CUDA.
has_gpu() {
  command -v nvidia-smi >/dev/null && nvidia-smi -L >/dev/null 2>&1 &&
    grep -q '^HSGPU_HAVE_CUDA:INTERNAL=ON' "$HSGPU_REPORT_BUILD/CMakeCache.txt" 2>/dev/null
}

cpu_model() { lscpu | sed -n 's/^Model name: *//p' | head -n1; }
# Physical cores: unique (core, socket) pairs.
physical_cores() { lscpu -p=core,socket | grep -v '^#' | sort -u | wc -l; }
# Usable CPUs: nproc without the OMP_NUM_THREADS=1 of report_env (GNU nproc obeys it).
usable_cpus() { env -u OMP_NUM_THREADS -u OMP_THREAD_LIMIT nproc; }
gpu_model() {
  if has_gpu; then nvidia-smi --query-gpu=name --format=csv,noheader | head -n1
  else echo "none"; fi
}
lammps_version() {
  echo "info" | "$HSGPU_REPORT_LMP" -nocite -log none 2>/dev/null |
    sed -n 's/^LAMMPS (\(.*\))$/\1/p' | head -n1
}

# page_header <title> <mode>: the lines every page starts with.
page_header() {
  local title=$1 mode=$2 commit
  commit=$(git -C "$HSGPU_ROOT" rev-parse --short HEAD 2>/dev/null || echo unknown)
  # The report's own pages do not count as local changes: regenerating them changes them.
  if ! git -C "$HSGPU_ROOT" diff --quiet HEAD -- . ':(exclude)doc/report' 2>/dev/null; then
    commit="$commit (with local changes)"
  fi
  cat <<HDR
# $title

Made by \`$HSGPU_REPORT_CMD\` ($mode mode) on $(date -u '+%Y-%m-%d %H:%M UTC'): $(cpu_model),
$(physical_cores) physical cores ($(usable_cpus) usable), GPU: $(gpu_model); LAMMPS $(lammps_version);
HARDSPHERE_GPU $commit. Runs are one MPI rank, one OpenMP thread unless a table says
otherwise; times are LAMMPS's wall-clock timers on a machine that may be shared.

HDR
}

# lmp_run <log> <input> [lmp args...]: runs LAMMPS with the plugin (its path in -var plugin),
# screen output off, the log in <log>.  Fails (non-zero) if LAMMPS does.
lmp_run() {
  local log=$1 input=$2
  shift 2
  "$HSGPU_REPORT_LMP" -nocite -screen none -log "$log" -in "$input" \
    -var plugin "$HSGPU_REPORT_PLUGIN" "$@"
}

# loop_time <log>: seconds of LAMMPS's last "Loop time of" line.
loop_time() { sed -n 's/^Loop time of \([0-9.e+-]*\) on.*/\1/p' "$1" | tail -n1; }

# report_python: the Python that has the packages tools/report.sh installs (Debian's
# python3-matplotlib and python3-numpy are in /usr/bin/python3; another python3, e.g. pyenv's,
# may come first on PATH without them).
report_python() {
  if ! python3 -c 'import matplotlib, numpy' 2>/dev/null && [ -x /usr/bin/python3 ]; then
    echo /usr/bin/python3
  else
    echo python3
  fi
}

# python_plot <script.py> [args...]: runs a plotting script with matplotlib's file backend, in
# the Python report_env chose (report_python once, not at every call).
python_plot() { MPLBACKEND=Agg "${HSGPU_REPORT_PYTHON:-$(report_python)}" "$@"; }
